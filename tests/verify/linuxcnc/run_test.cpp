// The LinuxCNC programs on LinuxCNC's own controller (task, motion and HAL
// from linuxcnc-uspace; a simulated XYZBC machine, ttp.ini, no display):
// the generator's dry run (dwells shortened, nothing else) runs to its end
// without an error (soft limits held), C turns through the roll-over, and
// every cut report, (debug,...), arrives when the cut's last move has
// finished, in the order and at the table angles of `ttp schedule`.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/file.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>

#include "test_dir.h"
#include "ttp/cam/programs.h"
#include "ttp/cam/schedule.h"
#include "ttp/gcode/reader.h"
#include "ttp/gcode/writer.h"
#include "ttp/geometry/frames.h"

namespace ttp {
namespace {

namespace fs = std::filesystem;
constexpr double kDryRunDwellS = 0.01;
const fs::path kConfigDir = fs::path(TTP_SOURCE_DIR) / "tests/verify/linuxcnc";

// Runs `program` on the simulated machine; returns the display's log.
nlohmann::json RunOnController(const std::string& name, const std::string& text,
                               const Config& config) {
  const fs::path dir = test::TestDir("linuxcnc") / name;
  fs::create_directories(dir);
  fs::permissions(dir, fs::perms::all);
  // rtapi_app's fifo path must be short (a socket path, 108 bytes) and
  // writable by the fallback user.
  std::string fifo_dir = "/tmp/ttp-lcnc-XXXXXX";
  if (!mkdtemp(fifo_dir.data())) ADD_FAILURE() << "mkdtemp";
  fs::permissions(fifo_dir, fs::perms::all);
  // The INI's display is the script next to it, by absolute path.
  std::ifstream in(kConfigDir / "ttp.ini");
  std::ofstream ini(dir / "ttp.ini");
  for (std::string line; std::getline(in, line);)
    ini << (line.rfind("DISPLAY =", 0) == 0
                ? "DISPLAY = " + (kConfigDir / "run_program.py").string()
                : line)
        << "\n";
  ini.close();
  std::ofstream tbl(dir / "ttp.tbl");
  for (const ToolSpec* t : config.process.Tools())
    tbl << "T" << t->number << " P" << t->number << " Z" << t->length_mm << " D"
        << t->diameter_mm << "\n";
  tbl.close();
  std::ofstream(dir / "ttp.var")
      << "5220\t1.000000\n5223\t" << WorkpieceOriginHeightMm(config) << "\n";
  fs::permissions(dir / "ttp.var", fs::perms::all);
  std::ofstream(dir / "prog.ngc") << text;
  const std::string cmd =
      "cd '" + dir.string() +
      "' && TTP_PROGRAM=prog.ngc TTP_RUN_LOG=run.json TTP_FEED_OVERRIDE=50 "
      "TTP_RUN_LIMIT_S=150 RTAPI_UID=65534 RTAPI_FIFO_PATH='" +
      fifo_dir + "/rtapi_fifo" +
      "' timeout 200 linuxcnc ttp.ini >linuxcnc.out 2>&1";
  {
    // One LinuxCNC or rs274 on the machine at a time.
    const int fd = open("/tmp/ttp-rs274.lock", O_CREAT | O_RDWR, 0666);
    if (fd >= 0) flock(fd, LOCK_EX);
    const int status = std::system(cmd.c_str());
    if (fd >= 0) close(fd);
    EXPECT_EQ(status, 0) << cmd;
  }
  std::error_code ec;
  fs::remove_all(fifo_dir, ec);
  std::ifstream log(dir / "run.json");
  if (!log) return nlohmann::json();
  return nlohmann::json::parse(log);
}

bool ControllerAvailable() {
  return access("/usr/bin/linuxcnc", X_OK) == 0 && geteuid() == 0;
}

double Wrap360(double deg) {
  double d = std::fmod(deg, 360.0);
  if (d < 0) d += 360.0;
  return d >= 360.0 - 1e-6 ? 0.0 : d;
}

// The program's time on the simulated machine of ttp.ini by the schedule's
// time model with that machine's rates: feeds at the feed override, every
// move at most at the INI's velocities (2000 mm/s, C 20000 deg/s; the
// accelerations are high enough not to count), dwells as written, no
// spindle or C ramps (the simulated spindles reach their speed at once),
// and the tool changer's handshake (task and iocontrol, 0.3 s).
constexpr double kFeedOverride = 50.0;
constexpr double kSimMaxMmS = 2000.0, kSimMaxDegS = 20000.0;
constexpr double kSimToolChangeS = 0.3;
double ControllerTimeS(const std::vector<gcode::CanonStatement>& canon) {
  constexpr double kRadToDeg = 180.0 / M_PI;
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  double c_deg = 0, total = 0;
  for (const auto& s : canon) {
    const double length = (s.end_mm - p).norm();
    const double turn = std::abs(s.end_c_rad * kRadToDeg - c_deg);
    if (s.kind == gcode::CanonKind::kTraverse)
      total += std::max(length / kSimMaxMmS, turn / kSimMaxDegS);
    if (s.kind == gcode::CanonKind::kFeed) {
      const double f = s.feed_per_min / 60 * kFeedOverride;
      total += length > 0 ? length / std::min(f, kSimMaxMmS)
                          : turn / std::min(f, kSimMaxDegS);
    }
    if (s.kind == gcode::CanonKind::kDwell) total += s.value;
    if (s.kind == gcode::CanonKind::kToolChange) total += kSimToolChangeS;
    p = s.end_mm;
    c_deg = s.end_c_rad * kRadToDeg;
  }
  return total;
}

// Reports of the program as the controller sent them: every message is a
// report of the schedule, in its order, with its table angle; the polled
// table angle when it arrived is that angle.
void ExpectReportsOfTheSchedule(const nlohmann::json& log,
                                const cam::Schedule& schedule) {
  const auto& messages = log.at("messages");
  ASSERT_EQ(messages.size(), schedule.table_angles_deg.size());
  for (size_t i = 0; i < messages.size(); ++i) {
    const std::string text_i = messages[i].at("text");
    gcode::ReportText r;
    ASSERT_TRUE(gcode::ParseReportText(text_i, &r)) << text_i;
    EXPECT_NEAR(r.c_deg, schedule.table_angles_deg[i], 1e-3) << text_i;
    const double t_msg = messages[i].at("t").get<double>();
    const nlohmann::json* before = nullptr;
    for (const auto& sample : log.at("samples"))
      if (sample[0].get<double>() <= t_msg) before = &sample;
    ASSERT_NE(before, nullptr);
    EXPECT_NEAR(Wrap360((*before)[6].get<double>()),
                Wrap360(schedule.table_angles_deg[i]), 1e-3)
        << text_i;
  }
}

// The run took the schedule's time at the simulated machine's rates: never
// less (less than half a poll early), and more only by the controller's
// own cycle (task runs every 10 ms: at most one cycle per statement).
void ExpectTheScheduleTime(const nlohmann::json& log,
                           const std::vector<gcode::CanonStatement>& canon,
                           const std::string& what) {
  const double predicted = ControllerTimeS(canon);
  // When the controller went idle for good (the display then waits 1 s).
  const double measured = log.contains("end_s")
                              ? log.at("end_s").get<double>()
                              : log.at("run_s").get<double>();
  size_t statements = 0;
  for (const auto& s : canon)
    if (s.kind != gcode::CanonKind::kComment) ++statements;
  std::cout << what << ": controller " << measured << " s, schedule "
            << predicted << " s at the simulated machine's rates, "
            << statements << " statements\n";
  EXPECT_GE(measured, predicted - 0.05) << what;
  EXPECT_LE(measured, predicted + 0.01 * statements) << what;
}

TEST(LinuxCncController, TestCycleRunsWithReportsAtTheEndOfEachCut) {
  if (!ControllerAvailable())
    GTEST_SKIP() << "linuxcnc-uspace missing or not root";
  const Config config;
  gcode::Program program = cam::BuildTestCycleProgram(config);
  cam::ShortenDwells(program, kDryRunDwellS);
  const std::string text =
      gcode::WriteProgram(program, gcode::Dialect::kLinuxCnc, config);
  const cam::Schedule schedule = cam::BuildSchedule(config);
  const auto canon =
      gcode::ReadProgram(text, gcode::Dialect::kLinuxCnc, config, "cycle");

  const nlohmann::json log = RunOnController("cycle", text, config);
  ASSERT_TRUE(log.is_object());
  EXPECT_TRUE(log.at("errors").empty()) << log.at("errors").dump();
  EXPECT_TRUE(log.at("completed").get<bool>());
  ExpectReportsOfTheSchedule(log, cam::BuildSchedule(config, kDryRunDwellS));
  ExpectTheScheduleTime(log, canon, "test cycle");
  const auto& messages = log.at("messages");
  ASSERT_EQ(messages.size(), schedule.cuts.size());
  // Cut feeds of the program, in order: the one before each report.
  std::vector<const gcode::CanonStatement*> cut_feeds;
  const gcode::CanonStatement* last_feed = nullptr;
  for (const auto& s : canon) {
    if (s.kind == gcode::CanonKind::kFeed) last_feed = &s;
    if (s.kind == gcode::CanonKind::kReport) cut_feeds.push_back(last_feed);
  }
  ASSERT_EQ(cut_feeds.size(), schedule.cuts.size());
  for (size_t i = 0; i < messages.size(); ++i) {
    const cam::ScheduledCut& cut = schedule.cuts[i];
    const std::string text_i = messages[i].at("text");
    gcode::ReportText r;
    ASSERT_TRUE(gcode::ParseReportText(text_i, &r)) << text_i;
    EXPECT_EQ(r.feature, cut.feature.ToString()) << i;
    EXPECT_NEAR(r.c_deg, cut.c_deg, 1e-3) << cut.feature;
    // The controller's table angle at the last poll before the report
    // arrived (during the cut or just after it; the next index may already
    // have started when the message is read).
    const double t_msg = messages[i].at("t").get<double>();
    const nlohmann::json* before = nullptr;
    for (const auto& sample : log.at("samples"))
      if (sample[0].get<double>() <= t_msg) before = &sample;
    ASSERT_NE(before, nullptr);
    EXPECT_NEAR(Wrap360((*before)[6].get<double>()), Wrap360(cut.c_deg), 1e-3)
        << cut.feature;
    const auto& pos = messages[i].at("pos");
    // The report arrived when the cut was over: the axes stood at or past
    // the cut's end, not anywhere before it along the pass.
    const auto* feed = cut_feeds[i];
    ASSERT_NE(feed, nullptr);
    const Eigen::Vector2d end = feed->end_mm.head<2>();
    const Eigen::Vector2d at(pos[0].get<double>(), pos[1].get<double>());
    // Start of the pass: the statement before the feed.
    const size_t k = static_cast<size_t>(feed - canon.data());
    ASSERT_GT(k, 0u);
    const Eigen::Vector2d start = canon[k - 1].end_mm.head<2>();
    const double pass = (end - start).norm();
    EXPECT_GE((at - start).norm(), pass - 0.01)
        << cut.feature << " reported before its cut ended";
    if (i > 0) {
      EXPECT_GE(messages[i].at("t").get<double>(),
                messages[i - 1].at("t").get<double>());
    }
  }
}

// The TALC run's R-test (process.rtest_interval_s) on a short test (three
// cycles of ten minutes, an R-test every ten minutes): it runs to its end,
// the R-test reports come in the schedule's order with the probe standing
// over the sphere, and the run takes the schedule's time.
TEST(LinuxCncController, RTestVariantRunsWithItsReportsInOrder) {
  if (!ControllerAvailable())
    GTEST_SKIP() << "linuxcnc-uspace missing or not root";
  Config config;
  config.part.facets_per_segment = 3;
  config.part.reference_index = 2;
  config.process.warmup_cycles = 1;
  config.process.cycle_period_s = 600;
  config.process.rtest_interval_s = 600;
  gcode::Program program = cam::BuildTestCycleProgram(config);
  cam::ShortenDwells(program, kDryRunDwellS);
  const std::string text =
      gcode::WriteProgram(program, gcode::Dialect::kLinuxCnc, config);
  const cam::Schedule schedule = cam::BuildSchedule(config, kDryRunDwellS);
  ASSERT_EQ(schedule.rtests.size(), 3u);

  const nlohmann::json log = RunOnController("rtest", text, config);
  ASSERT_TRUE(log.is_object());
  EXPECT_TRUE(log.at("errors").empty()) << log.at("errors").dump();
  EXPECT_TRUE(log.at("completed").get<bool>());
  ExpectReportsOfTheSchedule(log, schedule);
  // R-test reports: R<n>-P<k> in order, the probe over the sphere (the
  // sphere's place at the reported angle, from the frames of geometry).
  size_t rtest_reports = 0;
  for (const auto& m : log.at("messages")) {
    gcode::ReportText r;
    ASSERT_TRUE(gcode::ParseReportText(m.at("text"), &r));
    if (r.event != "rtest") continue;
    const size_t n = rtest_reports / cam::kRTestPositions;
    const size_t k = rtest_reports % cam::kRTestPositions + 1;
    EXPECT_EQ(r.feature, "R" + std::to_string(n) + "-P" + std::to_string(k));
    const double phi = config.machine.sphere_phi_deg * M_PI / 180.0;
    const Eigen::Vector3d sphere_w(
        config.machine.sphere_distance_mm * std::cos(phi),
        config.machine.sphere_distance_mm * std::sin(phi), 0.0);
    const Eigen::Vector3d sphere_m =
        WorkpieceToMachine(config, sphere_w, r.c_deg * M_PI / 180.0);
    const auto& pos = m.at("pos");
    EXPECT_NEAR(pos[0].get<double>(), sphere_m.x(), 0.01) << r.feature;
    EXPECT_NEAR(pos[1].get<double>(), sphere_m.y(), 0.01) << r.feature;
    ++rtest_reports;
  }
  EXPECT_EQ(rtest_reports, 3u * cam::kRTestPositions);
  const auto canon =
      gcode::ReadProgram(text, gcode::Dialect::kLinuxCnc, config, "rtest");
  ExpectTheScheduleTime(log, canon, "R-test variant");
}

TEST(LinuxCncController, PreMachiningTurnsCThroughTheRollOver) {
  if (!ControllerAvailable())
    GTEST_SKIP() << "linuxcnc-uspace missing or not root";
  const Config config;
  gcode::Program program = cam::BuildPreMachiningProgram(config);
  cam::ShortenDwells(program, kDryRunDwellS);
  const std::string text =
      gcode::WriteProgram(program, gcode::Dialect::kLinuxCnc, config);
  const nlohmann::json log = RunOnController("pre", text, config);
  ASSERT_TRUE(log.is_object());
  EXPECT_TRUE(log.at("errors").empty()) << log.at("errors").dump();
  EXPECT_TRUE(log.at("completed").get<bool>());
  // The program turns C by whole revolutions both ways: the wrapped axis
  // passes through 0/360 and is back at 0 at the end.
  double c_min = 1e9, c_max = -1e9;
  for (const auto& sample : log.at("samples")) {
    c_min = std::min(c_min, sample[6].get<double>());
    c_max = std::max(c_max, sample[6].get<double>());
  }
  EXPECT_GT(c_max - c_min, 180.0);
  const auto& last = log.at("samples").back();
  EXPECT_NEAR(Wrap360(last[6].get<double>()), 0.0, 1e-3);
}

}  // namespace
}  // namespace ttp
