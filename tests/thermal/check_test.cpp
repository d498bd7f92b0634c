// Check of a measured piece against its log, and the log <-> program
// schedule check, with figures from the simulation plus known offsets.
#include "ttp/thermal/check.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>

#include "synthetic_log.h"
#include "ttp/geometry/error.h"

namespace ttp::thermal {
namespace {

struct Fixture {
  Config config;
  test::SyntheticRun run;
  TalcLog log;
  Simulation sim;
  Fixture() {
    log = ParseTalcLog(run.Text(config), "syn.csv");
    sim = SimulatePiece(log, config);
  }
  // The simulation's figures as a measurement with U = 2 * u_um.
  std::vector<CycleFigures> Measured(double u_um) const {
    std::vector<CycleFigures> m = sim.figures;
    for (auto& f : m) {
      f.u_x_mm = f.u_y_mm = f.u_z_mm = f.u_ttp_mm = u_um * 1e-3;
      f.u_b_rad = u_um * 1e-6;
    }
    return m;
  }
};

TEST(Check, SimulatedFiguresAgreeWithThemselves) {
  Fixture fx;
  const CheckResult r = CheckPiece(fx.log, fx.config, fx.Measured(0.5));
  EXPECT_EQ(r.compared, 40);
  EXPECT_EQ(r.disagreements, 0);
  EXPECT_TRUE(r.agree());
  for (const auto& c : r.cycles) {
    for (const auto& f : c.figures) {
      EXPECT_NEAR(f.difference, 0, 1e-9);
      EXPECT_NEAR(f.u_measured, 1.0, 1e-12);
      EXPECT_GE(f.u_combined, f.u_measured);
    }
  }
}

// A known offset larger than the combined U is found, exactly there; one
// inside U is not.
TEST(Check, FindsAnOffsetOutsideTheCombinedU) {
  Fixture fx;
  std::vector<CycleFigures> m = fx.Measured(0.5);
  m[2].e_ttp_mm += 3e-3;  // cycle 3, E_TTP + 3 um
  m[5].e_y_mm += 0.5e-3;  // cycle 6, E_Y + 0.5 um: inside U = 1 um
  const CheckResult r = CheckPiece(fx.log, fx.config, m);
  EXPECT_EQ(r.disagreements, 1);
  EXPECT_FALSE(r.agree());
  const FigureCheck& f = r.cycles[2].figures[4];
  EXPECT_FALSE(f.agree);
  EXPECT_NEAR(f.difference, 3.0, 1e-9);
  EXPECT_TRUE(r.cycles[5].figures[1].agree);
  EXPECT_NEAR(r.cycles[5].figures[1].difference, 0.5, 1e-9);
}

// The run's verdict: a figure a little outside its own U (one in twenty is,
// by chance) does not fail a run of forty; one beyond the run's limit,
// z(1 - 0.05 / 80) = 3.227 combined standard uncertainties (normal
// tables), does.
TEST(Check, TheRunDisagreesBeyondItsLimitNotAtEveryFigureOutsideU) {
  Fixture fx;
  const CheckResult base = CheckPiece(fx.log, fx.config, fx.Measured(0.5));
  ASSERT_EQ(base.compared, 40);
  EXPECT_NEAR(base.run_limit_k, 3.227, 2e-3);
  const double u_comb = base.cycles[2].figures[4].u_combined;  // k = 2
  for (double factor : {1.2, 1.5, 1.7, 2.0}) {
    std::vector<CycleFigures> m = fx.Measured(0.5);
    m[2].e_ttp_mm += factor * u_comb * 1e-3;  // cycle 3, E_TTP
    const CheckResult r = CheckPiece(fx.log, fx.config, m);
    const FigureCheck& f = r.cycles[2].figures[4];
    EXPECT_FALSE(f.agree) << factor;
    EXPECT_EQ(r.disagreements, 1) << factor;
    const bool beyond = factor > 3.227 / 2;
    EXPECT_EQ(f.beyond_run_limit, beyond) << factor;
    EXPECT_EQ(r.agree(), !beyond) << factor;
    EXPECT_EQ(CheckTable(r).find("measured and simulated DISAGREE") !=
                  std::string::npos,
              beyond)
        << factor;
  }
}

// Pieces whose figures scatter about the simulation by their combined
// standard uncertainty (normal, fixed seed): per figure about 5 % lie
// outside U, so with forty figures most runs have one; the run's verdict
// fails about 5 % of them.
TEST(Check, RunsFollowingTheSimulationFailAtTheStatedRate) {
  Fixture fx;
  const CheckResult base = CheckPiece(fx.log, fx.config, fx.Measured(0.5));
  std::mt19937 rng(20261126);
  std::normal_distribution<double> normal(0.0, 1.0);
  int runs_with_a_figure_outside_u = 0, runs_failed = 0;
  const int runs = 400;
  for (int k = 0; k < runs; ++k) {
    CheckResult r = base;
    int outside_u = 0;
    for (CycleCheck& c : r.cycles)
      for (FigureCheck& f : c.figures) {
        f.difference = 0.5 * f.u_combined * normal(rng);
        if (std::abs(f.difference) > f.u_combined) ++outside_u;
      }
    // The verdict from the differences, as CheckPiece decides it.
    JudgeRun(0.05, &r);
    if (outside_u > 0) ++runs_with_a_figure_outside_u;
    if (!r.agree()) ++runs_failed;
  }
  EXPECT_GT(runs_with_a_figure_outside_u, runs / 2);
  EXPECT_LE(runs_failed, 0.08 * runs);
  EXPECT_GE(runs_failed, 0.01 * runs);
}

TEST(Check, MissingFiguresAreNotCounted) {
  Fixture fx;
  std::vector<CycleFigures> m = fx.Measured(0.5);
  m[0].e_x_mm = std::nan("");
  m.pop_back();  // no cycle 8
  const CheckResult r = CheckPiece(fx.log, fx.config, m);
  EXPECT_EQ(r.compared, 40 - 1 - 5);
  EXPECT_FALSE(r.cycles[0].figures[0].available);
  EXPECT_TRUE(r.agree());
  const auto j = CheckToJson(r);
  EXPECT_TRUE(j["cycles"][0]["E_X"]["measured"].is_null());
  EXPECT_TRUE(j["cycles"][7]["E_Y"]["agree"].is_null());
  EXPECT_NE(CheckTable(r).find("missing"), std::string::npos);
}

// The simulated U comes from the estimator's budget at the cut times (the
// diagnosis's ErrorSigmaAt): it grows with the R-test noise.
TEST(Check, SimulatedUncertaintyFollowsTheEstimator) {
  Fixture quiet;
  test::SyntheticRun noisy_run;
  noisy_run.rtest_noise_um = 0.5;
  const TalcLog noisy = ParseTalcLog(noisy_run.Text(Config{}), "n.csv");
  auto u_of = [](const TalcLog& log) {
    const auto est = MachineErrorEstimator::Fit(log);
    const auto u = SimulatedFigureUncertainty(log, Config{}, est, {});
    double s = 0;
    for (const auto& f : u) {
      EXPECT_TRUE(std::isfinite(f.u_ttp_mm));
      s += f.u_z_mm + f.u_ttp_mm;
    }
    return s;
  };
  const double a = u_of(quiet.log), b = u_of(noisy);
  EXPECT_GT(a, 0);
  // Above the floor of the R-tests' stated noise (thesis table 5.4), which
  // both logs share.
  EXPECT_GT(b, 2 * a);
  // E_Z follows EZ0T: a cycle's u is the estimator's budget at its cuts
  // and at the reference cycle's, independent.
  const auto est = MachineErrorEstimator::Fit(noisy);
  const auto u = SimulatedFigureUncertainty(noisy, Config{}, est, {});
  std::map<int, std::pair<double, int>> time;
  for (const CutRecord& c : noisy.cuts) {
    time[c.feature.index].first += c.t_s;
    ++time[c.feature.index].second;
  }
  const auto at = [&](int index) {
    return est.ErrorSigmaAt(2, time[index].first / time[index].second);
  };
  const PartSpec& part = Config{}.part;
  for (const CycleFigures& f : u) {
    const double expected =
        std::hypot(at(IndexForCycle(part, f.cycle)), at(part.reference_index));
    EXPECT_NEAR(f.u_z_mm * 1e3, expected, 0.1 * expected) << f.cycle;
  }
}

// Thesis 7.10: dT = E / (alpha R), piece and table.
TEST(Check, TemperatureChangeFromETtpAndER0T) {
  Fixture fx;
  std::vector<CycleFigures> m = fx.Measured(0.5);
  m[3].e_ttp_mm = 5e-3;
  const CheckResult r = CheckPiece(fx.log, fx.config, m);
  const TemperatureCheck& t = r.cycles[3].temperature;
  EXPECT_NEAR(t.piece_measured_k, 5e-3 / (23.4e-6 * 97.3), 1e-9);
  EXPECT_NEAR(t.u_piece_measured_k, 1e-3 / (23.4e-6 * 97.3), 1e-9);
  // The synthetic ER0T is 3 um per unit load: the table change at cycle 4.
  const double er =
      fx.run.TruthMicro(r.cycles[3].t_s)[3] - fx.run.TruthMicro(330)[3];
  EXPECT_NEAR(t.table_rtest_k, er * 1e-3 / (11e-6 * 160), 0.05);
  // T_ws in the synthetic log is T_env + 0.5: the same change.
  EXPECT_NEAR(t.ws_log_k, t.env_log_k, 1e-9);
  EXPECT_NE(std::abs(t.env_log_k), 0.0);
}

// ---- schedule ------------------------------------------------------------

// The synthetic log's own cuts as the program's plan, shifted by 250 s.
std::vector<PlannedCut> PlanFrom(const TalcLog& log) {
  std::vector<PlannedCut> p;
  for (const auto& c : log.cuts) {
    p.push_back(
        {c.feature, 0, c.t_s - 250 - 15, c.t_s - 250, c.c_rad * 180 / M_PI});
  }
  return p;
}

void ExpectScheduleError(const TalcLog& log,
                         const std::vector<PlannedCut>& plan,
                         const std::string& field, const std::string& words) {
  try {
    CheckLogAgainstSchedule(log, plan);
    FAIL() << "accepted: " << words;
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), field) << e.what();
    EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
  }
}

TEST(CheckSchedule, AcceptsAMatchingLog) {
  Fixture fx;
  const ScheduleCheck s = CheckLogAgainstSchedule(fx.log, PlanFrom(fx.log));
  EXPECT_NEAR(s.offset_s, 250, 1e-9);
  EXPECT_NEAR(s.max_deviation_s, 0, 1e-9);
  EXPECT_EQ(s.matched, 45);
}

TEST(CheckSchedule, NamesEachMismatch) {
  Fixture fx;
  const auto plan = PlanFrom(fx.log);
  // A cut the program does not make.
  auto fewer = plan;
  fewer.erase(fewer.begin() + 7);
  ExpectScheduleError(fx.log, fewer, "feature", "not a feature of the program");
  // Order: the program cuts X2-1 before X1-1.
  auto swapped = plan;
  std::swap(swapped[6].feature, swapped[7].feature);
  ExpectScheduleError(fx.log, swapped, "feature", "out of the program's order");
  // A cut an hour late.
  TalcLog late = fx.log;
  auto shifted = plan;
  for (size_t i = 10; i < shifted.size(); ++i) shifted[i].end_s -= 3600;
  ExpectScheduleError(fx.log, shifted, "t_s", "more than the tolerance");
  // Table angle.
  auto angle = plan;
  angle[3].c_deg += 6;
  ExpectScheduleError(fx.log, angle, "c_deg", "table angle");
  // A cut the log lacks.
  TalcLog missing = fx.log;
  missing.cuts.erase(missing.cuts.begin() + 12);
  ExpectScheduleError(missing, plan, "feature", "has no cut row");
  // The log ends before the program's last cut.
  auto longer = plan;
  longer.push_back(plan.back());
  longer.back().feature = FeatureId::Strip(99);
  longer.back().end_s += 3600;
  longer.back().start_s += 3600;
  ExpectScheduleError(fx.log, longer, "t_s", "ends at");
  // The log starts after the program's first cut.
  auto earlier = plan;
  earlier.front().start_s = -1000;
  ExpectScheduleError(fx.log, earlier, "t_s", "starts at");
  // No R-test before the first cut: nothing anchors its machine error.
  TalcLog no_before = fx.log;
  while (!no_before.rtests.empty() &&
         no_before.rtests.front().t_ref_s <= no_before.cuts.front().t_s)
    no_before.rtests.erase(no_before.rtests.begin());
  ExpectScheduleError(no_before, plan, "rtest", "no R-test before");
}

// A production log may end before an R-test follows the last cuts: that is
// no mismatch (the simulation extrapolates and warns: SimulateTest).
TEST(CheckSchedule, AcceptsCutsAfterTheLastRTest) {
  Fixture fx;
  TalcLog no_after = fx.log;
  while (no_after.rtests.back().t_ref_s > no_after.cuts.back().t_s)
    no_after.rtests.pop_back();
  ASSERT_GT(fx.log.rtests.size(), no_after.rtests.size());
  EXPECT_EQ(CheckLogAgainstSchedule(no_after, PlanFrom(fx.log)).matched, 45);
}

}  // namespace
}  // namespace ttp::thermal
