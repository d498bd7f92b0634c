// TALC replay and sweep timings, and the P99-against-interval curve on the
// real FL thermal data (docs/TALC.md quotes these figures).
//   bench_talc [--quick]
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "ttp/models/time_series.h"
#include "ttp/talc/replay.h"
#include "ttp/talc/sweep.h"

namespace {

using Clock = std::chrono::steady_clock;
double Seconds(Clock::time_point a) {
  return std::chrono::duration<double>(Clock::now() - a).count();
}
// CPU time of the whole process (all threads): on a shared machine the wall
// time alone does not show whether threads or shards scale.
double CpuSeconds() { return double(std::clock()) / CLOCKS_PER_SEC; }
double ThreadCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

// 46 h from the 23 h of real data: the first half followed by itself run
// backwards in time, so every signal continues without a jump at the join.
ttp::models::TimeSeries Continue(const ttp::models::TimeSeries& s) {
  ttp::models::TimeSeries o = s;
  const size_t n = s.rows();
  const double end = s.t_s.back();
  o.t_s.resize(2 * n - 1);
  o.inputs.resize(Eigen::Index(2 * n - 1), s.inputs.cols());
  o.outputs_um.resize(Eigen::Index(2 * n - 1), s.outputs_um.cols());
  o.inputs.topRows(Eigen::Index(n)) = s.inputs;
  o.outputs_um.topRows(Eigen::Index(n)) = s.outputs_um;
  for (size_t k = 1; k < n; ++k) {
    const size_t src = n - 1 - k;
    o.t_s[n - 1 + k] = end + (end - s.t_s[src]);
    o.inputs.row(Eigen::Index(n - 1 + k)) = s.inputs.row(Eigen::Index(src));
    o.outputs_um.row(Eigen::Index(n - 1 + k)) =
        s.outputs_um.row(Eigen::Index(src));
  }
  o.gap_rows.clear();
  return o;
}

}  // namespace

int main(int argc, char** argv) {
  const bool quick = argc > 1 && std::string(argv[1]) == "--quick";
  const std::string train =
      std::string(TTP_BENCH_DATA_DIR) + "/reference/fl-thermal/train.csv";
  const auto real = ttp::models::ReadThermalLog(train);
  const auto long_series = Continue(real);
  fmt::print("series: {} rows, {:.1f} h at 15 s (real data, continued)\n",
             long_series.rows(), long_series.t_s.back() / 3600.0);

  // 1. One replay over 46 h.
  {
    ttp::talc::Strategy st;
    st.interval_s = 3600;
    std::vector<double> times;
    for (int i = 0; i < (quick ? 3 : 15); ++i) {
      const auto t0 = Clock::now();
      const auto r = ttp::talc::Replay(long_series, st);
      times.push_back(Seconds(t0));
      if (r.outputs.empty()) return 3;
    }
    std::sort(times.begin(), times.end());
    fmt::print(
        "replay 46 h, hourly, with regressors and baselines: median "
        "{:.1f} ms (budget 50 ms)\n",
        1e3 * times[times.size() / 2]);
  }

  // 2. 2,000 strategies in one process.
  ttp::talc::Grid grid =
      ttp::talc::GridFromJson(nlohmann::json::parse(R"({"grid": {
        "interval_s": [900, 1800, 2700, 3600, 5400, 7200, 9000, 10800, 12600, 14400],
        "forgetting_per_h": [1.0, 0.98, 0.95, 0.9],
        "speed_lags_s": [[], [1800], [3600], [7200], [1800, 7200]],
        "calibration_s": [21600, 30600, 43200, 57600, 72000],
        "ridge": [0.1, 1.0]}})"),
                              "bench");
  fmt::print("grid: {} strategies\n", grid.size());
  for (int threads : {1, 2}) {
    if (quick && threads == 1) continue;
    const auto t0 = Clock::now();
    const double c0 = CpuSeconds();
    const auto d = ttp::talc::RunSweep(long_series, grid, "long", threads);
    fmt::print(
        "sweep {} strategies on 46 h, {} thread(s): {:.2f} s wall, "
        "{:.2f} s CPU (budget 60 s on 2 cores)\n",
        d["points"].size(), threads, Seconds(t0), CpuSeconds() - c0);
  }

  // 3. Sharded: N shards run side by side (one thread each), then merged.
  {
    const auto dir = std::filesystem::temp_directory_path() /
                     fmt::format("bench_talc_{}", ::getpid());
    ttp::talc::Grid small = grid;
    small.keys.resize(4);  // drops "speed_lags_s" -> 400 strategies
    small.values.resize(4);
    // (keys are sorted: calibration_s, forgetting_per_h, interval_s, ridge)
    std::string reference;
    const auto log = std::filesystem::path(train);
    for (int shards : {1, 2, 4}) {
      const auto plan_dir = dir / fmt::format("p{}", shards);
      ttp::talc::PlanShards(small, log, shards, plan_dir, "ttp");
      const auto t0 = Clock::now();
      const double c0 = CpuSeconds();
      std::vector<std::thread> workers;
      std::vector<double> shard_cpu(size_t(shards), 0.0);
      for (int k = 0; k < shards; ++k)
        workers.emplace_back([&, k] {
          ttp::talc::RunShard(plan_dir, k, 1, [](const auto& p) {
            return ttp::models::ReadThermalLog(p);
          });
          shard_cpu[size_t(k)] = ThreadCpuSeconds();
        });
      for (auto& w : workers) w.join();
      // The critical path on N free cores: the slowest shard's CPU time.
      const double slowest =
          *std::max_element(shard_cpu.begin(), shard_cpu.end());
      const std::string merged = ttp::talc::MergeShards(plan_dir).dump();
      if (reference.empty()) reference = merged;
      fmt::print(
          "sharded {} strategies (23 h log), {} shard(s) side by side: "
          "{:.2f} s wall, {:.2f} s CPU in all, slowest shard {:.2f} s CPU, "
          "merged result {}\n",
          small.size(), shards, Seconds(t0), CpuSeconds() - c0, slowest,
          merged == reference ? "identical" : "DIFFERENT");
    }
    std::filesystem::remove_all(dir);
  }

  // 4. P99 against the interval on the real data (defaults otherwise).
  fmt::print(
      "\nP99 of |residual| (um) on train.csv after 8.5 h calibration, "
      "TALC / holding the last measurement / static on all temperatures "
      "updated at the same measurements:\n");
  fmt::print("{:>10} {:>8}", "interval", "Q_Prod");
  for (const auto& n : real.output_names) fmt::print(" {:>24}", n);
  fmt::print("\n");
  for (double minutes : {15, 30, 60, 120, 180, 240}) {
    ttp::talc::Strategy st;
    st.interval_s = minutes * 60;
    const auto r = ttp::talc::Replay(real, st);
    fmt::print("{:>8g} m {:>7.2f}%", minutes, 100 * r.q_prod);
    for (const auto& o : r.outputs)
      fmt::print(" {:>6.2f} / {:>6.2f} / {:>6.2f}", o.talc.p99_um,
                 o.hold.p99_um, o.static_model.p99_um);
    fmt::print("\n");
  }
  {
    ttp::talc::Strategy st;
    const auto r = ttp::talc::Replay(real, st);
    fmt::print("{:>10} {:>8}", "none", "");
    for (const auto& o : r.outputs) fmt::print(" {:>15.2f}", o.none.p99_um);
    fmt::print("\n{:>10} {:>8}", "frozen", "");
    for (const auto& o : r.outputs)
      fmt::print(" {:>15.2f}", o.static_frozen.p99_um);
    fmt::print("\n{:>10} {:>8}", "in-sample", "");
    for (const auto& o : r.outputs)
      fmt::print(" {:>15.2f}", o.static_window.p99_um);
    fmt::print("  (static fitted on the whole log: optimistic)\n");
  }
  return 0;
}
