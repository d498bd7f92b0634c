// Grids, Pareto fronts and best sets checked by brute force, and the
// sharded workflow against the in-process run (byte for byte).
#include "ttp/talc/sweep.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <fstream>
#include <functional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "synthetic_series.h"
#include "test_dir.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/file_io.h"

namespace ttp::talc {
namespace {

Grid SmallGrid() {
  return GridFromJson(nlohmann::json::parse(R"({
      "base": {"calibration_s": 21600, "temperatures": ["T_air"]},
      "grid": {"interval_s": [1800, 3600, 7200, 14400],
               "forgetting_per_h": [1.0, 0.95],
               "speed_lags_s": [[3600], [1800, 7200]]},
      "limit_p99_um": 3})"),
                      "grid.json");
}

TEST(Grid, IndexesEveryCombinationLastKeyFastest) {
  const Grid g = SmallGrid();
  ASSERT_EQ(g.size(), 16u);
  // Keys sorted: forgetting_per_h, interval_s, speed_lags_s.
  EXPECT_EQ(g.keys, (std::vector<std::string>{"forgetting_per_h", "interval_s",
                                              "speed_lags_s"}));
  EXPECT_EQ(g.Params(0)["interval_s"], 1800.0);
  EXPECT_EQ(g.Params(1)["speed_lags_s"], nlohmann::json({1800, 7200}));
  EXPECT_EQ(g.Params(2)["interval_s"], 3600.0);
  EXPECT_EQ(g.Params(8)["forgetting_per_h"], 0.95);
  EXPECT_EQ(g.At(15).interval_s, 14400);
  EXPECT_EQ(g.At(15).calibration_s, 21600);
  std::set<std::string> seen;
  for (size_t i = 0; i < g.size(); ++i) seen.insert(g.Params(i).dump());
  EXPECT_EQ(seen.size(), g.size());
}

TEST(Grid, ABadFieldIsNamed) {
  auto field_of = [](const char* text) {
    try {
      GridFromJson(nlohmann::json::parse(text), "g.json");
    } catch (const InputError& e) {
      return e.field();
    }
    return std::string("(accepted)");
  };
  EXPECT_EQ(field_of(R"({"grid": {"interval_s": [60, -1]}})"),
            "grid.interval_s[1]");
  EXPECT_EQ(field_of(R"({"grid": {"interval_s": 60}})"), "grid.interval_s");
  EXPECT_EQ(field_of(R"({"grid": {"no_such": [1]}})"), "grid.no_such[0]");
  EXPECT_EQ(field_of(R"({"base": {"ridge": -1}})"), "base.ridge");
  EXPECT_EQ(field_of(R"({"limit_p99_um": "low"})"), "limit_p99_um");
  EXPECT_EQ(field_of(R"({"grids": {}})"), "grids");
  // Points are ranked by their outputs' figures: the outputs cannot vary.
  EXPECT_EQ(field_of(R"({"grid": {"outputs": [["d_a"], ["d_a", "d_b"]]}})"),
            "grid.outputs");
  // A combination that is invalid only together is named as well.
  EXPECT_EQ(field_of(R"({"base": {"mode": "adaptive"},
                         "grid": {"min_interval_s": [600, 9000],
                                  "max_interval_s": [3600, 18000]}})"),
            "max_interval_s");
  EXPECT_EQ(field_of(R"({"grid": {"interval_s": [60]}})"), "(accepted)");
  // Ten values of each of seven fields: 1e7 points, past the limit of 1e6,
  // refused at the field that crosses it (keys in alphabetical order).
  nlohmann::json big = {{"grid", nlohmann::json::object()}};
  for (const char* field :
       {"calibration_s", "forgetting_per_h", "interval_s", "max_interval_s",
        "measuring_time_s", "ridge", "threshold_um"}) {
    nlohmann::json values = nlohmann::json::array();
    for (int i = 1; i <= 10; ++i)
      values.push_back(std::string(field) == "forgetting_per_h" ? 1.0 - 0.01 * i
                                                                : 1000.0 * i);
    big["grid"][field] = values;
  }
  EXPECT_EQ(field_of(big.dump().c_str()), "grid.threshold_um");
  big["grid"].erase("threshold_um");
  EXPECT_EQ(GridFromJson(big, "g.json").size(), 1000000u);
}

TEST(Sweep, ParetoFrontAndBestSetsMatchABruteForce) {
  const auto s = test::TwoNodePlant{}.Make(30 * 3600, 30);
  const Grid g = SmallGrid();
  const nlohmann::json d = RunSweep(s, g, "plant.csv", 2);
  const auto& pts = d["points"];
  ASSERT_EQ(pts.size(), g.size());
  auto q = [&](size_t i) { return pts[i]["q_prod_percent"].get<double>(); };
  auto p = [&](size_t i) { return pts[i]["p99_mean_um"].get<double>(); };
  auto dominated = [&](size_t i) {
    for (size_t j = 0; j < pts.size(); ++j)
      if (q(j) >= q(i) && p(j) <= p(i) && (q(j) > q(i) || p(j) < p(i)))
        return true;
    return false;
  };
  std::set<size_t> front;
  for (const auto& f : d["pareto"]["mean"])
    front.insert(f["index"].get<size_t>());
  for (size_t i = 0; i < pts.size(); ++i) {
    EXPECT_EQ(pts[i]["index"], i);
    if (front.count(i)) {
      EXPECT_FALSE(dominated(i)) << i;
    }
    // Not on the front: dominated, or a duplicate of a front point.
    if (!front.count(i)) {
      bool dup = false;
      for (size_t f : front) dup |= q(f) == q(i) && p(f) == p(i);
      EXPECT_TRUE(dominated(i) || dup) << i;
    }
  }
  size_t best_p = 0;
  for (size_t i = 1; i < pts.size(); ++i)
    if (p(i) < p(best_p)) best_p = i;
  EXPECT_EQ(d["best"]["min_p99_mean"], best_p);
  const double limit = 3.0;
  nlohmann::json best_q;
  for (size_t i = 0; i < pts.size(); ++i)
    if (p(i) < limit && (best_q.is_null() || q(i) > q(best_q) ||
                         (q(i) == q(best_q) && p(i) < p(best_q))))
      best_q = i;
  EXPECT_EQ(d["best"]["max_q_prod_p99_below_limit"], best_q);
  // Longer intervals measure less: Q_Prod rises with the interval.
  EXPECT_LT(q(0), q(6));
}

TEST(Sweep, ShardedRunsMergeToTheInProcessResultByteForByte) {
  const auto s = test::TwoNodePlant{}.Make(24 * 3600, 60);
  const auto dir = ttp::test::TestDir("talc");
  // The shards read the log from a file: write the series as a thermal log.
  std::string csv = "# thermal-log: 1\n# start: 2024-01-01T00:00:00+00:00\nt_s";
  for (const auto& n : s.input_names) csv += "," + n;
  for (const auto& n : s.output_names) csv += "," + n;
  csv += "\n";
  for (size_t i = 0; i < s.rows(); ++i) {
    csv += fmt::format("{}", s.t_s[i]);
    for (Eigen::Index c = 0; c < s.inputs.cols(); ++c)
      csv += fmt::format(",{}", s.inputs(Eigen::Index(i), c));
    for (Eigen::Index c = 0; c < s.outputs_um.cols(); ++c)
      csv += fmt::format(",{}", s.outputs_um(Eigen::Index(i), c));
    csv += "\n";
  }
  const auto log = dir / "plant.csv";
  WriteFileAtomic(log, csv);
  const auto series = models::ReadThermalLog(log);
  const Grid g = SmallGrid();
  const std::string in_process = RunSweep(series, g, "plant.csv", 2).dump(2);
  EXPECT_EQ(RunSweep(series, g, "plant.csv", 1).dump(2), in_process);
  // More shards than points: refused by the plan, not after the cluster ran
  // the empty ones.
  EXPECT_THROW(PlanShards(g, log, int(g.size()) + 1, dir / "plan_many", "ttp"),
               InputError);
  for (int shards : {1, 3, 16}) {
    const auto plan_dir = dir / fmt::format("plan{}", shards);
    const ShardPlan plan = PlanShards(g, log, shards, plan_dir, "ttp");
    EXPECT_NE(plan.slurm_command.find(fmt::format("--array=0-{}", shards - 1)),
              std::string::npos);
    EXPECT_THROW(MergeShards(plan_dir), InputError);  // nothing run yet
    // Shards in reverse order, each with a different thread count.
    for (int k = shards; k-- > 0;)
      RunShard(plan_dir, k, 1 + k % 2, [](const std::filesystem::path& p) {
        return models::ReadThermalLog(p);
      });
    EXPECT_EQ(MergeShards(plan_dir).dump(2), in_process) << shards;
  }
  // A shard's result damaged or from another plan: bad input naming the
  // file and the point, never a merged result (nor an internal error).
  const auto plan_dir = dir / "plan3";
  const auto result = plan_dir / "result-0.json";
  const nlohmann::json good = nlohmann::json::parse(ReadTextFile(result));
  ASSERT_EQ(good["points"][0]["status"], "ok");
  const std::vector<
      std::pair<std::function<void(nlohmann::json&)>, std::string>>
      damage = {
          {[](nlohmann::json& d) { d["points"][0]["index"] = "x"; },
           "points[0].index"},
          {[](nlohmann::json& d) { d["points"][0]["index"] = 1000000; },
           "points[0].index"},
          {[](nlohmann::json& d) { d["points"][0].erase("p99_mean_um"); },
           "points[0].p99_mean_um"},
          {[](nlohmann::json& d) {
             d["points"][0]["outputs"][0].erase("name");
           },
           "points[0].outputs"},
          {[](nlohmann::json& d) { d["points"].push_back(d["points"][0]); },
           "points[" + std::to_string(good["points"].size()) + "].index"},
          {[](nlohmann::json& d) { d["points"].erase(0); }, "points"},
          {[](nlohmann::json& d) { d["shard"] = 2; }, "shard"},
      };
  for (const auto& [change, field] : damage) {
    nlohmann::json bad = good;
    change(bad);
    WriteFileAtomic(result, bad.dump());
    try {
      MergeShards(plan_dir);
      ADD_FAILURE() << "merged with " << field << " damaged";
    } catch (const InputError& e) {
      EXPECT_EQ(e.field(), field);
    }
  }
  WriteFileAtomic(result, good.dump());
  EXPECT_EQ(MergeShards(plan_dir).dump(2), in_process);
}

}  // namespace
}  // namespace ttp::talc
