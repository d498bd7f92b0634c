// Bad input, misuse and faults through the `ttp` program: each ends in
// exit 2 with a message naming the file (or option), the line and the field,
// or in a correct result. Outputs follow the output policy (never over an
// input, through symbolic links, into devices and FIFOs, all or none).
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "run_ttp.h"
#include "test_dir.h"

namespace ttp::test {
namespace {

namespace fs = std::filesystem;

fs::path Put(const fs::path& p, const std::string& text) {
  std::ofstream(p, std::ios::binary) << text;
  return p;
}

// The sample log with `from` replaced by `to` (first occurrence).
std::string LogWith(const std::string& from, const std::string& to) {
  std::string text = FileBytes(DataPath("samples/run-a/talc.csv"));
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

// Exit 2 and every fragment in the message.
void ExpectBadInput(const RunResult& r,
                    std::initializer_list<const char*> fragments) {
  EXPECT_EQ(r.exit_code, 2) << r.output;
  for (const char* f : fragments)
    EXPECT_NE(r.output.find(f), std::string::npos)
        << "'" << f << "' not in: " << r.output;
  EXPECT_EQ(r.output.find("internal error"), std::string::npos) << r.output;
}

// ---------------------------------------------------------------- TALC log

TEST(CliHardening, TalcLogHeaderAndValueLimits) {
  const fs::path dir = TestDir("hard");
  struct Case {
    std::string from, to;
    std::vector<const char*> expect;
  };
  const std::vector<Case> cases = {
      {"# compensation: off",
       "# compensation: off\n# compensation: on",
       {"bad.csv:7", "compensation", "twice", "line 6"}},
      {"2026-03-02T06:00:00+01:00",
       "2026-02-30T06:00:00+01:00",
       {"bad.csv:3", "start", "day 30"}},
      {"2026-03-02T06:00:00+01:00",
       "2026-03-02T06:00:00+25:00",
       {"bad.csv:3", "start", "offset"}},
      {"# sphere_distance_mm: 160",
       "# sphere_distance_mm: 1e-300",
       {"bad.csv:4", "sphere_distance_mm"}},
      {"95.0000,rtest,,,,,,,0.0003",
       "95.0000,rtest,,,,,,,1e300",
       {"bad.csv:10", "EX0C", "limit"}},
      {"29700.0000,sample", "1000000000,sample", {"bad.csv:", "t_s", "limit"}},
  };
  for (const Case& c : cases) {
    const fs::path log = Put(dir / "bad.csv", LogWith(c.from, c.to));
    const RunResult r = RunTtp("log " + ShellQuoted(log));
    EXPECT_EQ(r.exit_code, 2) << c.to << "\n" << r.output;
    for (const char* f : c.expect)
      EXPECT_NE(r.output.find(f), std::string::npos)
          << c.to << ": '" << f << "' not in " << r.output;
  }
  // A span beyond the limit ends in bad input for every reader of logs,
  // before anything is allocated for it.
  const fs::path span =
      Put(dir / "span.csv", LogWith("29700.0000,sample", "9000000,sample"));
  for (const std::string& cmd :
       {"log " + ShellQuoted(span), "simulate --log " + ShellQuoted(span),
        "check --log " + ShellQuoted(span) + " " +
            DataPath("samples/run-a/piece.ply")}) {
    const RunResult r = RunTtp(cmd);
    ExpectBadInput(r, {"span.csv:", "t_s", "limit"});
  }
}

// ---------------------------------------------------------------- clouds

TEST(CliHardening, CloudLimitsAndTrailingData) {
  const fs::path dir = TestDir("hard");
  // COUNT 1e9 of one field: refused from the header, no allocation.
  Put(dir / "count.pcd",
      "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 8 8 8\nTYPE F F F\n"
      "COUNT 1000000000 1 1\nWIDTH 10\nHEIGHT 1\nPOINTS 10\nDATA binary\n" +
          std::string(240, '\0'));
  ExpectBadInput(RunTtp("inspect " + ShellQuoted(dir / "count.pcd")),
                 {"count.pcd", "COUNT of x", "limit"});
  // A PLY element count that overflows the skip size.
  Put(dir / "overflow.ply",
      "ply\nformat binary_little_endian 1.0\nelement face "
      "4611686018427387904\nproperty int a\nelement vertex 3\nproperty "
      "double x\nproperty double y\nproperty double z\nend_header\n" +
          std::string(72, '\0'));
  ExpectBadInput(RunTtp("inspect " + ShellQuoted(dir / "overflow.ply")),
                 {"overflow.ply:3", "element face", "limit"});
  // Data after the declared vertices: read, and said aloud.
  std::string ply = FileBytes(DataPath("samples/run-a/piece.ply"));
  ply += std::string(48, '\x01');
  Put(dir / "trailing.ply", ply);
  const RunResult r = RunTtp("inspect " + ShellQuoted(dir / "trailing.ply") +
                             " --json " + ShellQuoted(dir / "t.json"));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  const auto doc = ReadJson(dir / "t.json");
  EXPECT_NE(doc.dump().find("48 bytes after the 19530 declared vertices"),
            std::string::npos);
  // A coordinate of 1e300 in a text cloud.
  Put(dir / "huge.xyz", "1 2 3\n4 1e300 6\n7 8 9\n");
  ExpectBadInput(RunTtp("inspect " + ShellQuoted(dir / "huge.xyz")),
                 {"huge.xyz:2", "limit"});
}

// ---------------------------------------------------------------- JSON

TEST(CliHardening, InspectionJsonOutOfRangeValues) {
  const fs::path dir = TestDir("hard");
  const fs::path good = dir / "good.json";
  ASSERT_EQ(RunTtp("inspect " + DataPath("samples/run-a/piece.ply") +
                   " --json " + ShellQuoted(good))
                .exit_code,
            0);
  const std::string text = FileBytes(good);
  const std::regex first_distance(R"("distance_mm": [-0-9.e]+)");
  const std::regex first_u(R"("U_distance_um": [-0-9.e]+)");
  struct Case {
    std::string replaced;
    std::vector<const char*> expect;
  };
  const std::vector<Case> cases = {
      {std::regex_replace(text, first_distance, "\"distance_mm\": 1e308",
                          std::regex_constants::format_first_only),
       {"bad.json", "distance_mm", "limit"}},
      {std::regex_replace(text, first_distance, "\"distance_mm\": 1e100",
                          std::regex_constants::format_first_only),
       {"bad.json", "distance_mm", "limit"}},
      {std::regex_replace(text, first_distance, "\"distance_mm\": 1e400",
                          std::regex_constants::format_first_only),
       {"bad.json", "not valid JSON"}},
      {std::regex_replace(text, first_u, "\"U_distance_um\": -3",
                          std::regex_constants::format_first_only),
       {"bad.json", "U_distance_um", "negative"}},
  };
  for (const Case& c : cases) {
    ASSERT_NE(c.replaced, text);
    const fs::path bad = Put(dir / "bad.json", c.replaced);
    for (const std::string& cmd :
         {"inspect " + ShellQuoted(bad),
          "diagnose --log " + DataPath("samples/run-a/talc.csv") + " " +
              ShellQuoted(bad),
          "report --log " + DataPath("samples/run-a/talc.csv") + " " +
              ShellQuoted(bad) + " -o " + ShellQuoted(dir / "r.html")}) {
      const RunResult r = RunTtp(cmd);
      EXPECT_EQ(r.exit_code, 2) << cmd << "\n" << r.output;
      for (const char* f : c.expect)
        EXPECT_NE(r.output.find(f), std::string::npos)
            << cmd << ": '" << f << "' not in " << r.output;
    }
  }
  // A truth-style file with an angle of 1e308: a truth file is no
  // measurement, whatever its values.
  std::string truth = FileBytes(DataPath("samples/run-a/truth.json"));
  const std::regex angle(
      R"(("facet_angle_err_urad": \{\s*"[^"]+": )[-0-9.e]+)");
  const std::string bad_truth = std::regex_replace(
      truth, angle, "$011e308", std::regex_constants::format_first_only);
  ASSERT_NE(bad_truth, truth);
  const fs::path bt = Put(dir / "truth.json", bad_truth);
  ExpectBadInput(RunTtp("diagnose --log " + DataPath("samples/run-a/talc.csv") +
                        " " + ShellQuoted(bt)),
                 {"truth.json", "not a measurement"});
}

// ---------------------------------------------------------------- DMIS, dial

TEST(CliHardening, DmisUnitsNormalsAndHugeReadings) {
  const fs::path dir = TestDir("hard");
  // UNITS/INCH on millimetre values: the piece would be 25 times its size.
  const fs::path inch = dir / "inch.dmo";
  Put(inch,
      "DMISMN/'x'\nUNITS/INCH,ANGDEC\n"
      "FA(X1_5)=FEAT/PLANE,CART,48.6505,84.2660,-6,0.5,0.8660254,0\n");
  ExpectBadInput(RunTtp("inspect " + ShellQuoted(inch)),
                 {"inch.dmo:3", "FA(X1_5)", "units"});
  // A reading of 1e300.
  const fs::path huge = dir / "huge.dmo";
  Put(huge,
      "DMISMN/'x'\nUNITS/MM,ANGDEC\n"
      "FA(X1_1)=FEAT/PLANE,CART,1e300,0,-6,1,0,0\n");
  ExpectBadInput(RunTtp("inspect " + ShellQuoted(huge)),
                 {"huge.dmo:3", "limit"});
  // A plane normal reported into the piece: the same plane, said aloud.
  const fs::path out_n = dir / "out.dmo", in_n = dir / "in.dmo";
  Put(out_n,
      "DMISMN/'x'\nUNITS/MM,ANGDEC\n"
      "FA(X1_5)=FEAT/PLANE,CART,48.6505,84.2660,-6,0.5,0.8660254,0\n"
      "FA(X1_1)=FEAT/PLANE,CART,78.7182,57.1921,-6,0.8090170,0.5877853,0\n");
  Put(in_n,
      "DMISMN/'x'\nUNITS/MM,ANGDEC\n"
      "FA(X1_5)=FEAT/PLANE,CART,48.6505,84.2660,-6,-0.5,-0.8660254,0\n"
      "FA(X1_1)=FEAT/PLANE,CART,78.7182,57.1921,-6,-0.8090170,-0.5877853,"
      "0\n");
  const RunResult a = RunTtp("inspect " + ShellQuoted(out_n) + " --json " +
                             ShellQuoted(dir / "out.json"));
  const RunResult b = RunTtp("inspect " + ShellQuoted(in_n) + " --json " +
                             ShellQuoted(dir / "in.json"));
  ASSERT_EQ(a.exit_code, 0) << a.output;
  ASSERT_EQ(b.exit_code, 0) << b.output;
  auto ja = ReadJson(dir / "out.json"), jb = ReadJson(dir / "in.json");
  EXPECT_EQ(ja["facets"], jb["facets"]);
  EXPECT_NE(jb.dump().find("pointing into the piece"), std::string::npos);
}

TEST(CliHardening, DialReadingsHugeAndHeaderOnly) {
  const fs::path dir = TestDir("hard");
  Put(dir / "huge.csv", "feature,reading_um\nX1-1,1e300\n");
  ExpectBadInput(RunTtp("inspect " + ShellQuoted(dir / "huge.csv")),
                 {"huge.csv:2", "reading_um", "limit"});
  Put(dir / "header.csv", "feature,reading_um\n");
  ExpectBadInput(RunTtp("inspect " + ShellQuoted(dir / "header.csv")),
                 {"header.csv", "no readings"});
}

// ---------------------------------------------------------------- options

TEST(CliHardening, OptionLimits) {
  const fs::path dir = TestDir("hard");
  const std::string out = " -o " + ShellQuoted(dir / "p.nc");
  // An output given as an empty word is refused, not skipped.
  ExpectBadInput(RunTtp("grade " +
                        ShellQuoted(std::string(TTP_DATA_DIR) +
                                    "/samples/run-b/piece.xyz") +
                        " --json ''"),
                 {"--json", "file name"});
  ExpectBadInput(RunTtp("gcode pre -o ''"), {"--output", "file name"});
  ExpectBadInput(RunTtp("plan probe --facet-columns 100000 --facet-rows "
                        "100000" +
                        out),
                 {"facet_columns", "limit"});
  ExpectBadInput(RunTtp("plan probe --strip-points 2000000000" + out),
                 {"strip_points_per_side", "limit"});
  ExpectBadInput(
      RunTtp("plan cmm --facet-rows 2147483647 -o " + ShellQuoted(dir / "cmm")),
      {"facet_rows", "limit"});
  ExpectBadInput(RunTtp("plan probe --overtravel-mm 1e308" + out),
                 {"overtravel_mm"});
  ExpectBadInput(RunTtp("plan probe --overtravel-mm 200" + out),
                 {"overtravel_mm", "table"});
  EXPECT_FALSE(fs::exists(dir / "p.nc"));
  for (const char* bad :
       {"--stray-fraction 5", "--stray-fraction -1", "--size 1e30",
        "--stray-fraction nan", "--points 0"}) {
    const RunResult r = RunTtp(std::string("twin --effect tool_wear ") + bad +
                               " -o " + ShellQuoted(dir / "twin"));
    EXPECT_EQ(r.exit_code, 2) << bad << "\n" << r.output;
  }
  EXPECT_FALSE(fs::exists(dir / "twin"));
  const std::string log = DataPath("samples/run-a/talc.csv");
  const std::string piece = DataPath("samples/run-a/piece.ply");
  for (const std::string& args :
       {"check --log " + log + " " + piece + " --time-tolerance-s nan",
        "check --log " + log + " " + piece + " --time-tolerance-s -5",
        "diagnose --log " + log + " " + piece + " --evidence nan"}) {
    const RunResult r = RunTtp(args);
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.output;
    EXPECT_EQ(r.output.find("talc.csv:"), std::string::npos) << r.output;
  }
  // Values no measurement or machine can mean (a grading limit above the
  // largest readable figure passes every piece), each named by its flag.
  for (const auto& [args, flag] :
       std::vector<std::pair<std::string, std::string>>{
           {"grade " + piece + " --limit-linear-um 1e300", "--limit-linear-um"},
           {"grade " + piece + " --limit-angular-um-per-m 1e5",
            "--limit-angular-um-per-m"},
           {"rtest --resolution --axis-resolution-um 1e300",
            "--axis-resolution-um"},
           {"simulate --log " + log +
                " --compare-interpolation --rtest-interval-s 1e300",
            "--rtest-interval-s"},
           {"thermal fit " + DataPath("samples/thermal-log.csv") + " -o " +
                ShellQuoted(dir / "m.json") + " --temperature-lag-s 1e300",
            "--temperature-lag-s"}}) {
    const RunResult r = RunTtp(args);
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.output;
    EXPECT_NE(r.output.find(flag), std::string::npos) << args << "\n"
                                                      << r.output;
  }
  EXPECT_FALSE(fs::exists(dir / "m.json"));
  // An R-test cycle id beyond every integer type.
  const fs::path spheres =
      Put(dir / "spheres.csv",
          "cycle,c_deg,x,y,z\n1,0,160,0,80\n1,90,0,160,80\n1,180,-160,0,80\n"
          "99999999999999999999,0,160,0,80\n99999999999999999999,90,0,160,80\n"
          "99999999999999999999,180,-160,0,80\n");
  ExpectBadInput(RunTtp("rtest " + ShellQuoted(spheres)),
                 {"spheres.csv:5", "cycle", "limit"});
}

// ---------------------------------------------------------------- programs

TEST(CliHardening, ProgramsEmptyHugeAndLongDwells) {
  const fs::path dir = TestDir("hard");
  const fs::path empty = Put(dir / "empty.nc", "%\n%\n");
  for (const std::string& cmd :
       {"gcode read " + ShellQuoted(empty), "gcode check " + ShellQuoted(empty),
        "verify " + ShellQuoted(empty)}) {
    const RunResult r = RunTtp(cmd);
    EXPECT_EQ(r.exit_code, 2) << cmd << "\n" << r.output;
    EXPECT_NE(r.output.find("empty.nc"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("empty"), std::string::npos) << r.output;
  }
  const fs::path dwell =
      Put(dir / "dwell.ngc", "G21 G90\nG4 P999999999999\nM30\n");
  ExpectBadInput(RunTtp("gcode read " + ShellQuoted(dwell)),
                 {"dwell.ngc:2", "limit"});
  const fs::path huge =
      Put(dir / "huge.ngc", "G21 G90\nG0 X123456789012.5\nM30\n");
  ExpectBadInput(RunTtp("gcode read " + ShellQuoted(huge)),
                 {"huge.ngc:2", "limit"});
  const fs::path digits = Put(
      dir / "digits.ngc", "G21 G90\nG0 X" + std::string(400, '9') + "\nM30\n");
  ExpectBadInput(RunTtp("gcode read " + ShellQuoted(digits)),
                 {"digits.ngc:2", "digits"});
  // One line of a hundred thousand comments: a line past the limit, not a
  // hundred thousand statements.
  std::string comments;
  for (int k = 0; k < 100000; ++k) comments += "(a)";
  const fs::path wide =
      Put(dir / "wide.ngc", "G21 G90\n" + comments + "\nM30\n");
  ExpectBadInput(RunTtp("gcode read " + ShellQuoted(wide)),
                 {"wide.ngc:2", "limit"});
}

// ---------------------------------------------------------------- outputs

TEST(CliHardening, NeverWritesOverAnInput) {
  const fs::path dir = TestDir("hard");
  // `command INPUT --json INPUT` on a copy of a sample: refused, the input
  // kept as it was.
  const auto json_over_input = [&dir](const std::string& command,
                                      const std::string& sample,
                                      const std::string& name) {
    const fs::path input = dir / name;
    fs::copy_file(DataPath(sample), input);
    const std::string before = FileBytes(input);
    ExpectBadInput(RunTtp(command + " " + ShellQuoted(input) + " --json " +
                          ShellQuoted(input)),
                   {name.c_str(), "input"});
    EXPECT_EQ(FileBytes(input), before);
    return before;
  };
  const fs::path log = dir / "same.csv";
  const std::string before =
      json_over_input("log", "samples/run-a/talc.csv", "same.csv");
  // Through another name: a symbolic link to the input.
  fs::create_symlink(log, dir / "link.json");
  ExpectBadInput(RunTtp("log " + ShellQuoted(log) + " --json " +
                        ShellQuoted(dir / "link.json")),
                 {"input"});
  EXPECT_EQ(FileBytes(log), before);

  json_over_input("inspect", "samples/run-a/piece.ply", "same.ply");

  const fs::path nc = dir / "same.nc";
  ASSERT_EQ(RunTtp("gcode cycle -o " + ShellQuoted(nc)).exit_code, 0);
  const std::string nc_before = FileBytes(nc);
  ExpectBadInput(RunTtp("gcode translate " + ShellQuoted(nc) +
                        " --to linuxcnc -o " + ShellQuoted(nc)),
                 {"same.nc", "input"});
  EXPECT_EQ(FileBytes(nc), nc_before);
}

TEST(CliHardening, WritesThroughLinksIntoDevicesAndFifos) {
  const fs::path dir = TestDir("hard");
  const std::string log = DataPath("samples/run-a/talc.csv");
  // A symbolic link: the target gets the output, the link stays a link.
  Put(dir / "target.json", "old\n");
  fs::create_symlink(dir / "target.json", dir / "link.json");
  ASSERT_EQ(RunTtp("log " + log + " --json " + ShellQuoted(dir / "link.json"))
                .exit_code,
            0);
  EXPECT_TRUE(fs::is_symlink(dir / "link.json"));
  EXPECT_NE(FileBytes(dir / "target.json").find("\"rtests\""),
            std::string::npos);
  // A dangling link is refused.
  fs::create_symlink(dir / "nowhere" / "x.json", dir / "dangling.json");
  ExpectBadInput(
      RunTtp("log " + log + " --json " + ShellQuoted(dir / "dangling.json")),
      {"dangling.json", "missing"});
  EXPECT_TRUE(fs::is_symlink(dir / "dangling.json"));
  // A FIFO is written into, not replaced.
  const fs::path fifo = dir / "fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const RunResult r =
      RunCommand("(cat " + ShellQuoted(fifo) + " > " +
                 ShellQuoted(dir / "from_fifo.json") + " &) ; " +
                 std::string(TTP_BINARY_DIR) + "/app/ttp log " + log +
                 " --json " + ShellQuoted(fifo) + " 2>&1; wait");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(fs::is_fifo(fifo));
  // /dev/null is written into; /dev/full (a full disk) fails as bad output,
  // and stays a device.
  EXPECT_EQ(RunTtp("log " + log + " --json /dev/null").exit_code, 0);
  if (fs::exists("/dev/full")) {
    const RunResult full = RunTtp("log " + log + " --json /dev/full");
    EXPECT_EQ(full.exit_code, 2) << full.output;
    EXPECT_TRUE(fs::is_character_file("/dev/full"));
  }
}

// Inputs are regular files or pipes. A device would be read without end
// (ran the machine out of memory, exit 3); it is bad input naming the
// path. A pipe (process substitution, /dev/stdin) is read once and whole:
// the measurement's format is told from its head and the same bytes read,
// so a piece and a log through pipes give what the files give.
TEST(CliHardening, InputsFromDevicesAndPipes) {
  const std::string log = DataPath("samples/run-a/talc.csv");
  const std::string piece = DataPath("samples/run-a/piece.ply");
  for (const std::string& cmd : std::vector<std::string>{
           "inspect /dev/zero", "diagnose --log /dev/zero " + piece,
           "diagnose --log " + log + " /dev/urandom",
           "thermal fit /dev/zero -o " +
               ShellQuoted(TestDir("hard-dev") / "m.json"),
           "--config /dev/zero schedule"}) {
    ExpectBadInput(RunTtp(cmd), {"/dev/", "is a device, not a file"});
  }
  const std::string ttp = std::string(TTP_BINARY_DIR) + "/app/ttp";
  const RunResult files =
      RunCommand(ttp + " diagnose --log " + log + " " + piece + " 2>&1");
  const RunResult pipes = RunCommand(
      "bash -c " + ShellQuoted(ttp + " diagnose --log <(cat " + log +
                               ") /dev/stdin < <(cat " + piece + ") 2>&1"));
  ASSERT_EQ(files.exit_code, 0) << files.output;
  EXPECT_EQ(pipes.exit_code, 0) << pipes.output;
  // Only the names differ (the report names its inputs).
  const auto first_lines = [](const std::string& text) {
    return text.substr(0, text.find("\n", text.find("\n") + 1));
  };
  EXPECT_EQ(first_lines(pipes.output), first_lines(files.output));
  EXPECT_NE(files.output.find("workpiece_expansion"), std::string::npos);
}

// A UTF-8 byte order mark first (a spreadsheet's "CSV UTF-8") is not
// content: the dial and probe CSVs and a text cloud read as without it.
TEST(CliHardening, ByteOrderMarkFirst) {
  for (const char* sample :
       {"samples/run-c/dial.csv", "samples/run-c/probe.csv",
        "samples/run-b/piece.xyz", "samples/run-c/talc.csv"}) {
    const fs::path plain_dir = TestDir("bom-plain"), bom_dir = TestDir("bom");
    const std::string name = fs::path(sample).filename().string();
    const std::string bytes = FileBytes(DataPath(sample));
    { std::ofstream(plain_dir / name, std::ios::binary) << bytes; }
    {
      std::ofstream(bom_dir / name, std::ios::binary)
          << "\xEF\xBB\xBF" << bytes;
    }
    const std::string cmd = name == "talc.csv" ? "log " : "inspect ";
    const auto run_in = [&](const fs::path& dir) {
      return RunCommand("cd " + ShellQuoted(dir) + " && " +
                        std::string(TTP_BINARY_DIR) + "/app/ttp " + cmd + name +
                        " 2>&1");
    };
    const RunResult plain = run_in(plain_dir);
    const RunResult bom = run_in(bom_dir);
    ASSERT_EQ(plain.exit_code, 0) << plain.output;
    EXPECT_EQ(bom.exit_code, 0) << bom.output;
    EXPECT_EQ(bom.output, plain.output) << sample;
  }
}

TEST(CliHardening, SeveralOutputsAllOrNone) {
  const fs::path dir = TestDir("hard");
  // A folder stands where the second output goes.
  fs::create_directories(dir / "blocked.json");
  ExpectBadInput(RunTtp("schedule --csv " + ShellQuoted(dir / "ok.csv") +
                        " --json " + ShellQuoted(dir / "blocked.json")),
                 {"blocked.json", "folder"});
  EXPECT_FALSE(fs::exists(dir / "ok.csv"));
  const RunResult p =
      RunTtp("plan probe -o " + ShellQuoted(dir / "probe.nc") +
             " --points-csv " + ShellQuoted(dir / "blocked.json"));
  EXPECT_EQ(p.exit_code, 2) << p.output;
  EXPECT_FALSE(fs::exists(dir / "probe.nc"));
  // A file where a command writes its folder (or above it) is the user's.
  Put(dir / "afile", "x\n");
  for (const char* plan : {"plan cmm -o ", "plan dial -o "}) {
    ExpectBadInput(RunTtp(plan + ShellQuoted(dir / "afile")), {"afile"});
    ExpectBadInput(RunTtp(plan + ShellQuoted(dir / "afile" / "sub")),
                   {"afile"});
  }
  EXPECT_EQ(FileBytes(dir / "afile"), "x\n");
  // The twin: an existing run survives a failure untouched.
  fs::create_directories(dir / "twin" / "truth.json");
  Put(dir / "twin" / "talc.csv", "previous run\n");
  const RunResult t = RunTtp(
      "twin --effect tool_wear --size 3 --points 2000 "
      "-o " +
      ShellQuoted(dir / "twin"));
  EXPECT_EQ(t.exit_code, 2) << t.output;
  EXPECT_EQ(FileBytes(dir / "twin" / "talc.csv"), "previous run\n");
  EXPECT_FALSE(fs::exists(dir / "twin" / "piece.ply"));
  int entries = 0;
  for (const auto& e : fs::directory_iterator(dir)) {
    EXPECT_EQ(e.path().filename().string().find("staging"), std::string::npos)
        << e.path();
    ++entries;
  }
  EXPECT_GT(entries, 0);
  // Without the obstacle the twin writes all three files.
  fs::remove_all(dir / "twin" / "truth.json");
  ASSERT_EQ(RunTtp("twin --effect tool_wear --size 3 --points 2000 -o " +
                   ShellQuoted(dir / "twin"))
                .exit_code,
            0);
  EXPECT_TRUE(fs::is_regular_file(dir / "twin" / "truth.json"));
  EXPECT_NE(FileBytes(dir / "twin" / "talc.csv"), "previous run\n");
}

// A result that cannot reach standard output (a full disk behind `>`) is
// an error, as a failed -o is.
TEST(CliHardening, StandardOutputThatCannotBeWritten) {
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "no /dev/full";
  for (const char* command : {"gcode pre", "schedule", "config"})
    EXPECT_EQ(RunTtp(std::string(command) + " > /dev/full").exit_code, 2)
        << command;
  EXPECT_EQ(RunTtp("gcode pre > /dev/null").exit_code, 0);
}

// ---------------------------------------------------------------- fits

TEST(CliHardening, FitsThePointsDoNotDetermine) {
  const fs::path dir = TestDir("hard");
  const fs::path four = Put(dir / "four.xyz", "0 0 0\n1 0 0\n0 1 0\n0 0 1\n");
  const RunResult cone = RunTtp("fit cone " + ShellQuoted(four));
  EXPECT_EQ(cone.exit_code, 2) << cone.output;
  EXPECT_EQ(cone.output.find("inf"), std::string::npos) << cone.output;
  // Points on a plane (a lattice, not collinear): no cylinder.
  std::string plane;
  for (int i = 0; i < 7; ++i)
    for (int j = 0; j < 7; ++j)
      plane += std::to_string(i * 1.5 + 0.1 * j) + " " +
               std::to_string(j * 1.25) + " 0\n";
  const fs::path p = Put(dir / "plane.xyz", plane);
  const RunResult cyl = RunTtp("fit cylinder " + ShellQuoted(p));
  ExpectBadInput(cyl, {"plane.xyz", "cylinder", "do not determine"});
  EXPECT_EQ(cyl.output.find("covariance_impl"), std::string::npos)
      << cyl.output;
}

}  // namespace
}  // namespace ttp::test
