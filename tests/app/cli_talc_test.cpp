// `ttp talc replay` and `ttp talc sweep` end to end on the real FL thermal
// data: the replay's figures, bad input, and one sweep run in this process,
// through GNU parallel and through a real single-node Slurm (job array),
// all three merged results byte-identical.
#include <fcntl.h>
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sys/file.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include "run_ttp.h"
#include "thermal_log_text.h"

namespace ttp {
namespace {

namespace fs = std::filesystem;
const std::string kTalcTrain =
    std::string(TTP_DATA_DIR) + "/reference/fl-thermal/train.csv";

TEST(CliTalc, ReplayOnTheRealDataBeatsHoldingTheLastMeasurement) {
  const fs::path json = test::TestDir("talc") / "replay.json";
  const auto r = test::RunTtp("talc replay " + kTalcTrain +
                              " --interval-s 3600 --json " + json.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("Q_Prod"), std::string::npos) << r.output;
  const auto j = test::ReadJson(json);
  ASSERT_EQ(j["outputs"].size(), 5u);
  EXPECT_EQ(j["strategy"]["interval_s"], 3600.0);
  for (const auto& o : j["outputs"]) {
    EXPECT_LT(o["talc"]["p99_um"].get<double>(),
              0.5 * o["hold"]["p99_um"].get<double>())
        << o["name"];
  }
  const double q = j["q_prod_percent"];
  EXPECT_GT(q, 80.0);
  EXPECT_LT(q, 100.0);
  EXPECT_TRUE(j["warnings"].empty()) << j["warnings"];
}

// A log whose T_t7 jumps by 3 K (the real log with the step put in at
// 30000 s): the replay says so and replays it as logged.
TEST(CliTalc, ReplayNamesASensorThatJumps) {
  const fs::path dir = test::TestDir("talc");
  const std::string log =
      test::WriteWithStep(kTalcTrain, dir / "jumped.csv", "T_t7", 30000, 3.0);
  const fs::path json = dir / "replay.json";
  const auto r = test::RunTtp("talc replay " + log +
                              " --interval-s 3600 --json " + json.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("warning: T_t7 jumps by +"), std::string::npos)
      << r.output;
  const auto j = test::ReadJson(json);
  ASSERT_EQ(j["warnings"].size(), 1u);
  EXPECT_NE(j["warnings"][0].get<std::string>().find("at t = 30000 s"),
            std::string::npos)
      << j["warnings"];
}

TEST(CliTalc, ReplayReadsATalcLogWithItsRTestsAsSparseOutputs) {
  const fs::path dir = test::TestDir("talc");
  std::ofstream(dir / "s.toml") << "calibration_s = 7200\n"
                                   "calibration_interval_s = 600\n"
                                   "interval_s = 1800\n";
  const fs::path json = dir / "replay.json";
  const auto r =
      test::RunTtp("talc replay " + std::string(TTP_DATA_DIR) +
                   "/samples/run-a/talc.csv --strategy " +
                   (dir / "s.toml").string() + " --json " + json.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto j = test::ReadJson(json);
  ASSERT_EQ(j["outputs"].size(), 7u);
  // Measurements only at R-tests: none in a row of temperatures alone.
  EXPECT_GT(j["measurements"].get<int>(), 10);
  for (const auto& o : j["outputs"]) {
    EXPECT_GT(o["talc"]["samples"].get<int>(), 20) << o["name"];
    // The large linear errors (the C-axis load drives them) are compensated
    // far better than by holding the last R-test.
    if (o["name"] == "d_EZ0T" || o["name"] == "d_EY0C") {
      EXPECT_LT(o["talc"]["p99_um"].get<double>(),
                0.6 * o["hold"]["p99_um"].get<double>())
          << o["name"];
    }
  }
}

TEST(CliTalc, BadInputNamesFileLineColumnOrField) {
  const fs::path dir = test::TestDir("talc");
  std::ofstream(dir / "s.toml") << "interval_s = 3600\nforgeting_per_h = 0.9\n";
  auto r = test::RunTtp("talc replay " + kTalcTrain + " --strategy " +
                        (dir / "s.toml").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("forgeting_per_h"), std::string::npos) << r.output;

  std::ofstream(dir / "log.csv")
      << "# thermal-log: 1\n# start: 2024-01-01T00:00:00+00:00\n"
         "t_s,n_spindle,T_a,d_x\n0,0,20,0\n15,0,x,0.1\n";
  r = test::RunTtp("talc replay " + (dir / "log.csv").string() +
                   " --interval-s 60");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("log.csv"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(":5"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("T_a"), std::string::npos) << r.output;

  // The default calibration phase (8.5 h) outlasts a 6 h log: it is
  // shortened to a third of the log, as on the report's page, and said;
  // one chosen with --calibration-s that leaves nothing compensated is
  // refused (zeros would read as perfect compensation).
  {
    std::ifstream in(kTalcTrain);
    std::ofstream out(dir / "six_hours.csv");
    std::string line;
    while (std::getline(in, line)) {
      if (!line.empty() && std::isdigit(static_cast<unsigned char>(line[0])) &&
          std::stod(line) > 6 * 3600)
        break;
      out << line << "\n";
    }
  }
  const std::string six = (dir / "six_hours.csv").string();
  r = test::RunTtp("talc replay " + six + " --interval-s 1800 --json " +
                   (dir / "six_default.json").string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("calibration phase shortened to"), std::string::npos)
      << r.output;
  const nlohmann::json shortened =
      nlohmann::json::parse(test::FileBytes(dir / "six_default.json"));
  // The log's last sample lies at most one step (15 s) before 6 h.
  EXPECT_NEAR(shortened["strategy"]["calibration_s"].get<double>(),
              6 * 3600.0 / 3.0, 15.0 / 3.0 + 1e-9);
  r = test::RunTtp("talc replay " + six +
                   " --interval-s 1800 --calibration-s 30600");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--calibration-s"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("reaches past the log's end"), std::string::npos)
      << r.output;
  r = test::RunTtp("talc replay " + six +
                   " --interval-s 1800 --calibration-s 7200");
  EXPECT_NE(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("Q_Prod"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("shortened"), std::string::npos) << r.output;
  r = test::RunTtp("talc replay " + kTalcTrain +
                   " --interval-s 3600 --static-from-s 100 --static-to-s 101");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("holds no sample"), std::string::npos) << r.output;

  std::ofstream(dir / "g.toml") << "[grid]\ninterval_s = [3600, 0]\n";
  r = test::RunTtp("talc sweep " + (dir / "g.toml").string() + " --log " +
                   kTalcTrain);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("grid.interval_s[1]"), std::string::npos) << r.output;
  r = test::RunTtp("talc replay " + kTalcTrain);  // neither option
  EXPECT_EQ(r.exit_code, 2) << r.output;
  // Numbers that are not: refused, not replaced by a default.
  for (const char* bad : {" --interval-s 3600 --calibration-s nan",
                          " --interval-s inf", " --interval-s nan"}) {
    r = test::RunTtp("talc replay " + kTalcTrain + bad);
    EXPECT_EQ(r.exit_code, 2) << bad << "\n" << r.output;
    EXPECT_NE(r.output.find("is not a number in"), std::string::npos)
        << r.output;
  }
  // Outputs measured only within the calibration: nothing compensated is
  // measured, said instead of an exit 1 with zeros.
  {
    std::ifstream in(kTalcTrain);
    std::ofstream out(dir / "early_outputs.csv");
    std::string line;
    while (std::getline(in, line)) {
      if (!line.empty() && std::isdigit(static_cast<unsigned char>(line[0])) &&
          std::stod(line) > 3000) {
        // t_s,n_spindle,d_ch1..d_ch5,T_...: the five d_ cells emptied.
        std::vector<std::string> cells;
        std::stringstream ss(line);
        for (std::string c; std::getline(ss, c, ',');) cells.push_back(c);
        line.clear();
        for (size_t k = 0; k < cells.size(); ++k)
          line += (k ? "," : "") + (k >= 2 && k <= 6 ? "" : cells[k]);
      }
      out << line << "\n";
    }
  }
  r = test::RunTtp("talc replay " + (dir / "early_outputs.csv").string() +
                   " --interval-s 1800 --calibration-s 3600");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("no output is measured after the calibration"),
            std::string::npos)
      << r.output;
  // A plan of more shards than points fails before the cluster runs.
  std::ofstream(dir / "g3.toml") << "[grid]\ninterval_s = [1800, 3600, 7200]\n";
  r = test::RunTtp("talc sweep " + (dir / "g3.toml").string() + " --log " +
                   kTalcTrain + " --plan 4 " + (dir / "plan4").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("4 shards for a grid of 3 points"), std::string::npos)
      << r.output;
}

// A small grid on the real data: 12 strategies.
fs::path WriteGrid(const fs::path& dir) {
  std::ofstream(dir / "grid.toml")
      << "limit_p99_um = 4\n[base]\ncalibration_s = 30600\n"
         "[grid]\ninterval_s = [1800, 3600, 7200]\n"
         "forgetting_per_h = [1.0, 0.9]\nspeed_lags_s = [[3600], [1800, "
         "7200]]\n";
  return dir / "grid.toml";
}

std::string InProcess(const fs::path& dir) {
  const fs::path grid = WriteGrid(dir);
  const auto r =
      test::RunTtp("talc sweep " + grid.string() + " --log " + kTalcTrain +
                   " --json " + (dir / "in-process.json").string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("Pareto front"), std::string::npos) << r.output;
  return test::FileBytes(dir / "in-process.json");
}

TEST(CliTalc, SweepThroughGnuParallelEqualsTheInProcessRun) {
  if (test::RunCommand("command -v parallel >/dev/null").exit_code != 0)
    GTEST_SKIP() << "GNU parallel not installed (scripts/install-deps.sh)";
  const fs::path dir = test::TestDir("talc");
  const std::string expected = InProcess(dir);
  auto r =
      test::RunTtp("talc sweep " + (dir / "grid.toml").string() + " --log " +
                   kTalcTrain + " --plan 5 " + (dir / "plan").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = test::RunCommand("sh " + (dir / "plan/parallel.sh").string() + " 2>&1");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = test::RunTtp("talc sweep --merge " + (dir / "plan").string() +
                   " --json " + (dir / "merged.json").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(test::FileBytes(dir / "merged.json"), expected);
}

// Runs `sh -c cmd`, true when it exits 0.
bool Sh(const std::string& cmd) {
  return test::RunCommand("{ " + cmd + "; } >/dev/null 2>&1").exit_code == 0;
}

int ReadPid(const fs::path& p) {
  std::ifstream in(p);
  int pid = 0;
  in >> pid;
  return pid;
}

// Stops the daemons this test started (by their pid files) however the
// test ends.
struct Daemons {
  std::vector<fs::path> pid_files;
  ~Daemons() {
    for (auto it = pid_files.rbegin(); it != pid_files.rend(); ++it) {
      const int pid = ReadPid(*it);
      if (pid <= 0) continue;
      ::kill(pid, SIGTERM);
      for (int i = 0; i < 50 && ::kill(pid, 0) == 0; ++i)
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  }
};

TEST(CliTalc, SweepThroughARealSlurmJobArrayEqualsTheInProcessRun) {
  for (const char* bin :
       {"slurmctld", "slurmd", "sbatch", "sinfo", "munged", "munge", "unmunge"})
    if (!Sh(std::string("PATH=$PATH:/usr/sbin command -v ") + bin))
      GTEST_SKIP() << bin << " not installed (scripts/install-deps.sh)";
  // One Slurm on the machine at a time (its ports are fixed).
  const int lock = ::open("/tmp/ttp-slurm.lock", O_CREAT | O_RDWR, 0666);
  ASSERT_GE(lock, 0);
  ASSERT_EQ(::flock(lock, LOCK_EX), 0);
  struct Unlock {
    int fd;
    ~Unlock() { ::close(fd); }
  } unlock{lock};

  const fs::path dir = test::TestDir("talc");
  const std::string expected = InProcess(dir);
  // slurmd makes Unix sockets in its spool folder, whose paths may not
  // exceed 108 bytes: the spool lives in a short folder of its own,
  // removed after the daemons have stopped.
  char spool_template[] = "/tmp/ttp-slurmd-XXXXXX";
  ASSERT_NE(::mkdtemp(spool_template), nullptr);
  struct RemoveSpool {
    fs::path p;
    ~RemoveSpool() {
      std::error_code ec;
      fs::remove_all(p, ec);
    }
  } remove_spool{spool_template};
  Daemons daemons;

  // munge: reuse a running one, else start it and stop it afterwards.
  if (!Sh("munge -n | unmunge")) {
    ASSERT_TRUE(Sh("mkdir -p /run/munge && chown munge:munge /run/munge"));
    ASSERT_TRUE(Sh("su -s /bin/sh munge -c /usr/sbin/munged"));
    daemons.pid_files.push_back("/run/munge/munged.pid");
    ASSERT_TRUE(Sh("munge -n | unmunge"));
  }
  const fs::path s = dir / "slurm";
  for (const char* sub : {"state", "log"}) fs::create_directories(s / sub);
  const std::string host = test::RunCommand("hostname -s").output;
  const std::string h = host.substr(0, host.find_first_of("\r\n"));
  const std::string cpus =
      std::to_string(std::max(1u, std::thread::hardware_concurrency()));
  std::ofstream(s / "slurm.conf")
      << "ClusterName=ttptest\nSlurmctldHost=" << h
      << "\nAuthType=auth/munge\nCredType=cred/munge\n"
         "SlurmUser=root\nSlurmdUser=root\n"
      << "StateSaveLocation=" << (s / "state").string() << "\n"
      << "SlurmdSpoolDir=" << spool_template << "\n"
      << "SlurmctldPidFile=" << (s / "slurmctld.pid").string() << "\n"
      << "SlurmdPidFile=" << (s / "slurmd.pid").string() << "\n"
      << "SlurmctldLogFile=" << (s / "log/slurmctld.log").string() << "\n"
      << "SlurmdLogFile=" << (s / "log/slurmd.log").string() << "\n"
      << "ProctrackType=proctrack/linuxproc\nTaskPlugin=task/none\n"
         "SelectType=select/cons_tres\nSelectTypeParameters=CR_Core\n"
         "ReturnToService=2\n"
      << "NodeName=" << h << " CPUs=" << cpus << " RealMemory=2000\n"
      << "PartitionName=debug Nodes=" << h << " Default=YES State=UP\n";
  const std::string env = "SLURM_CONF=" + (s / "slurm.conf").string() + " ";
  ASSERT_TRUE(Sh(env + "/usr/sbin/slurmctld -f " + (s / "slurm.conf").string()))
      << test::FileBytes(s / "log/slurmctld.log");
  daemons.pid_files.push_back(s / "slurmctld.pid");
  ASSERT_TRUE(Sh(env + "/usr/sbin/slurmd -f " + (s / "slurm.conf").string()))
      << test::FileBytes(s / "log/slurmd.log");
  daemons.pid_files.push_back(s / "slurmd.pid");
  bool idle = false;
  for (int i = 0; i < 60 && !idle; ++i) {
    idle = test::RunCommand(env + "sinfo -h -o %t 2>/dev/null")
               .output.find("idle") != std::string::npos;
    if (!idle) std::this_thread::sleep_for(std::chrono::milliseconds(500));
  }
  ASSERT_TRUE(idle) << test::FileBytes(s / "log/slurmctld.log");

  auto r =
      test::RunTtp("talc sweep " + (dir / "grid.toml").string() + " --log " +
                   kTalcTrain + " --plan 3 " + (dir / "plan").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = test::RunCommand(env + "timeout 90 sbatch --array=0-2 --wait " +
                       (dir / "plan/talc-sweep.sbatch").string() + " 2>&1");
  ASSERT_EQ(r.exit_code, 0)
      << r.output << test::FileBytes(s / "log/slurmctld.log");
  for (int k = 0; k < 3; ++k)
    EXPECT_TRUE(
        fs::exists(dir / "plan" / ("result-" + std::to_string(k) + ".json")));
  r = test::RunTtp("talc sweep --merge " + (dir / "plan").string() +
                   " --json " + (dir / "merged.json").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(test::FileBytes(dir / "merged.json"), expected);
}

}  // namespace
}  // namespace ttp
