// Sweeps: the replay over a grid of strategies (every combination of the
// listed values), P99 against Q_Prod per output (Pareto fronts) and the
// best set per criterion. In one process (threads) or sharded: a plan
// folder with shard files, a Slurm job-array script and a GNU parallel
// command; each shard writes its result atomically; the merge is the same
// function the in-process run uses, so the result is byte-identical for any
// number of shards.
#pragma once

#include <cstddef>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "ttp/models/time_series.h"
#include "ttp/talc/strategy.h"

namespace ttp::talc {

struct Grid {
  std::string source;
  nlohmann::json base = nlohmann::json::object();  // fields of every point
  std::vector<std::string> keys;                   // varied fields, sorted
  std::vector<nlohmann::json> values;              // per key: its values
  double limit_p99_um = 5.0;  // criterion: max Q_Prod with mean P99 below
  std::vector<double> limits_p99_um = {2, 3, 4, 5, 6, 8, 10, 15, 20};

  std::size_t size() const;
  // Point `index` (mixed radix, the last key varying fastest).
  nlohmann::json Params(std::size_t index) const;
  Strategy At(std::size_t index) const;
};

// {"limit_p99_um": 5, "limits_p99_um": [...], "base": {...},
//  "grid": {"interval_s": [900, 3600], ...}}; every point is validated
// (a bad value throws InputError naming "grid.<field>[i]").
Grid GridFromJson(const nlohmann::json& j, const std::string& source);
Grid ReadGrid(const std::filesystem::path& path);  // TOML or JSON
nlohmann::json GridToJson(const Grid& g);

// Replays the given points (threads workers, 0 = hardware); results in the
// order of `indices`, each a JSON object (see docs/TALC.md).
std::vector<nlohmann::json> RunPoints(const models::TimeSeries& series,
                                      const Grid& grid,
                                      const std::vector<std::size_t>& indices,
                                      int threads);

// Every point's result (any order, each index exactly once) into the sweep
// document: points by index, Pareto fronts, best sets. Throws
// std::runtime_error on a missing or duplicated index.
nlohmann::json MergeSweep(const Grid& grid, const std::string& log_name,
                          std::vector<nlohmann::json> points);
std::string SweepText(const nlohmann::json& sweep);

// The whole grid in this process.
nlohmann::json RunSweep(const models::TimeSeries& series, const Grid& grid,
                        const std::string& log_name, int threads);

// Sharded workflow. `ttp` is the program path written into the scripts.
struct ShardPlan {
  std::filesystem::path dir;
  int shards = 0;
  std::string slurm_command;     // sbatch ... (runs every shard)
  std::string parallel_command;  // GNU parallel ... (the same, one box)
};
ShardPlan PlanShards(const Grid& grid, const std::filesystem::path& log,
                     int shards, const std::filesystem::path& dir,
                     const std::filesystem::path& ttp);
using LogReader =
    std::function<models::TimeSeries(const std::filesystem::path&)>;
// Runs shard k of the plan in `dir`; writes dir/result-k.json atomically.
void RunShard(const std::filesystem::path& dir, int k, int threads,
              const LogReader& read_log);
// Merges dir/result-*.json; throws InputError naming a missing shard.
nlohmann::json MergeShards(const std::filesystem::path& dir);

}  // namespace ttp::talc
