// `ttp talc replay LOG`: a TALC strategy replayed on a log with dense
// outputs (thesis chapter 6). `ttp talc sweep GRID --log LOG`: the replay
// over a grid of strategies, in this process or sharded (--plan N DIR,
// --run-shard K DIR, --merge DIR) for a Slurm job array or GNU parallel.
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "command.h"
#include "ttp/geometry/error.h"
#include "ttp/models/identify.h"
#include "ttp/models/time_series.h"
#include "ttp/talc/replay.h"
#include "ttp/talc/sweep.h"
#include "ttp/thermal/talc_log.h"
#include "ttp/thermal/time_series.h"

namespace ttp::app {
namespace {

namespace fs = std::filesystem;

models::TimeSeries ReadLog(const fs::path& path) {
  return thermal::ReadThermalOrTalcLog(path.string());
}

// A temperature that jumps and stays shifted (models::FindFittedJumps) is a
// sensor fault the replayed controller reads as logged, as a real one
// would: said, not repaired.
std::vector<std::string> SensorJumpWarnings(const models::TimeSeries& series) {
  std::vector<std::string> out;
  for (const auto& j : models::FindFittedJumps(series))
    out.push_back(fmt::format(
        "{} jumps by {:+.2f} K at t = {:g} s and stays shifted: a sensor "
        "fault, not the machine; the replayed controller reads it as logged",
        j.input, j.step, j.t_s));
  return out;
}

fs::path SelfPath() {
  std::error_code ec;
  const fs::path p = fs::read_symlink("/proc/self/exe", ec);
  return ec ? fs::path("ttp") : p;
}

void RegisterTalc(CLI::App& root, GlobalOptions& global) {
  auto* talc = root.add_subcommand(
      "talc", "TALC strategies replayed on a thermal log, and sweeps of them");
  talc->require_subcommand(1);
  {
    auto* cmd = talc->add_subcommand(
        "replay",
        "replay one strategy on a log with dense outputs: E_RMS, P99, PtV and "
        "Q_Prod per output against no compensation, holding the last "
        "measurement and a static model");
    auto log = std::make_shared<std::string>();
    auto strategy = std::make_shared<std::string>();
    auto interval = std::make_shared<double>(0.0);
    auto json_out = std::make_shared<std::string>();
    cmd->add_option("log", *log, "thermal log or TALC log (CSV)")->required();
    auto* s_opt = cmd->add_option("--strategy", *strategy,
                                  "strategy file (TOML or JSON)");
    auto* i_opt = cmd->add_option("--interval-s", *interval,
                                  "fixed measurement interval after the "
                                  "calibration phase (other fields default)")
                      ->check(FiniteRange(1e-3, 1e9));
    s_opt->excludes(i_opt);
    auto calibration = std::make_shared<double>(-1.0);
    auto* c_opt =
        cmd->add_option("--calibration-s", *calibration,
                        "with --interval-s: length of the calibration phase "
                        "from the log's start (s; default 30600, 8.5 h, or a "
                        "third of a log shorter than 12.75 h)")
            ->check(FiniteRange(0.0, 1e9));
    c_opt->excludes(s_opt);
    cmd->add_option("--json", *json_out, "also write the result as JSON");
    auto ro = std::make_shared<talc::ReplayOptions>();
    cmd->add_option("--static-from-s", ro->static_window_from_s,
                    "the `static window` baseline is fitted once on the "
                    "samples from this time (s; default: the log's start)");
    cmd->add_option("--static-to-s", ro->static_window_to_s,
                    "... up to this time (s; default: the log's end, i.e. "
                    "in-sample)");
    cmd->callback([&global, log, strategy, interval, calibration, json_out,
                   ro] {
      talc::Strategy s;
      if (!strategy->empty()) {
        s = talc::ReadStrategy(*strategy);
      } else if (*interval > 0) {
        s.interval_s = *interval;
        if (*calibration >= 0) s.calibration_s = *calibration;
      } else {
        throw InputError("talc replay", 0, "--strategy",
                         "give --strategy FILE or --interval-s N");
      }
      const models::TimeSeries series = ReadLog(*log);
      // The default calibration (8.5 h, thesis table 6.1) on a log too
      // short for it (an 8 h TALC log): shortened as the report's page
      // does, and said; one the user chose is kept (and refused below when
      // it leaves nothing compensated).
      std::string calibration_note;
      if (strategy->empty() && *calibration < 0 && series.rows() > 1) {
        const double default_s = s.calibration_s;
        if (talc::FitDefaultCalibration(series.t_s.back() - series.t_s.front(),
                                        &s))
          calibration_note = fmt::format(
              "calibration phase shortened to {:g} s, a third of the log (the "
              "default {:g} s would leave less than a third of it "
              "compensated); --calibration-s sets it",
              s.calibration_s, default_s);
      }
      if (!(ro->static_window_to_s > ro->static_window_from_s))
        throw InputError("talc replay", 0, "--static-to-s",
                         "must be after --static-from-s");
      // A replay that compensates nothing has no figures to report: say
      // why instead of printing zeros that read as perfect compensation.
      if (series.rows() > 0) {
        const double t0 = series.t_s.front(), t1 = series.t_s.back();
        if (t0 + s.calibration_s >= t1)
          throw InputError(
              strategy->empty() ? std::string("talc replay") : *strategy, 0,
              strategy->empty() ? "--calibration-s" : "calibration_s",
              fmt::format("the calibration phase ({:g} s from the log's "
                          "start) reaches past the log's end ({:g} s after "
                          "its start): no sample is compensated; shorten it",
                          s.calibration_s, t1 - t0));
        const bool window_has_sample =
            std::any_of(series.t_s.begin(), series.t_s.end(), [&](double t) {
              return t >= ro->static_window_from_s &&
                     t <= ro->static_window_to_s;
            });
        if (!window_has_sample)
          throw InputError("talc replay", 0, "--static-from-s",
                           fmt::format("the static window {:g} .. {:g} s "
                                       "holds no sample of {}",
                                       ro->static_window_from_s,
                                       ro->static_window_to_s, *log));
      }
      talc::ReplayResult r = talc::Replay(series, s, *ro);
      // Nothing compensated was measured: nothing to judge (the log's
      // measured outputs all lie in the calibration phase).
      if (r.status != talc::ReplayStatus::kOk)
        throw InputError(
            *log, 0, "d_",
            fmt::format("no output is measured after the calibration phase "
                        "(t_s >= {:g} s): no compensated sample to judge; "
                        "shorten the calibration or give a log measured "
                        "after it",
                        r.evaluated_from_s));
      if (!calibration_note.empty())
        r.warnings.insert(r.warnings.begin(), calibration_note);
      for (auto& w : SensorJumpWarnings(series))
        r.warnings.push_back(std::move(w));
      if (!global.quiet || json_out->empty())
        WriteText("-", talc::ReplayText(r, s));
      if (!json_out->empty()) WriteJson(*json_out, talc::ReplayToJson(r, s));
    });
  }
  {
    auto* cmd = talc->add_subcommand(
        "sweep",
        "replay a grid of strategies: P99 against Q_Prod (Pareto fronts) and "
        "the best set per criterion; --plan/--run-shard/--merge shard it for "
        "Slurm or GNU parallel");
    auto grid = std::make_shared<std::string>();
    auto log = std::make_shared<std::string>();
    auto json_out = std::make_shared<std::string>();
    auto threads = std::make_shared<int>(0);
    auto plan = std::make_shared<std::vector<std::string>>();
    auto run_shard = std::make_shared<std::vector<std::string>>();
    auto merge = std::make_shared<std::string>();
    cmd->add_option("grid", *grid, "grid file (TOML or JSON)");
    cmd->add_option("--log", *log, "thermal log or TALC log (CSV)");
    cmd->add_option("--json", *json_out, "also write the result as JSON");
    cmd->add_option("--threads", *threads, "worker threads (0 = one per core)");
    auto* o_plan = cmd->add_option("--plan", *plan,
                                   "N DIR: write N shards, a Slurm job-array "
                                   "script and a GNU parallel command")
                       ->expected(2);
    auto* o_run = cmd->add_option("--run-shard", *run_shard,
                                  "K DIR: run shard K of the plan in DIR")
                      ->expected(2);
    auto* o_merge =
        cmd->add_option("--merge", *merge, "DIR: merge the shard results");
    o_plan->excludes(o_run)->excludes(o_merge);
    o_run->excludes(o_merge);
    cmd->callback([&global, grid, log, json_out, threads, plan, run_shard,
                   merge] {
      auto to_int = [](const std::string& v, const char* opt) {
        try {
          size_t used = 0;
          const int k = std::stoi(v, &used);
          if (used == v.size() && k >= 0) return k;
        } catch (const std::exception&) {
        }
        throw InputError(opt, 0, "", "expected a whole number, got " + v);
      };
      auto emit = [&](const nlohmann::json& doc) {
        if (!global.quiet || json_out->empty())
          WriteText("-", talc::SweepText(doc));
        if (!json_out->empty()) WriteJson(*json_out, doc);
      };
      if (!run_shard->empty()) {
        const int k = to_int((*run_shard)[0], "--run-shard");
        talc::RunShard((*run_shard)[1], k, *threads, ReadLog);
        if (!global.quiet)
          WriteText("-", fmt::format("shard {} done: {}/result-{}.json\n", k,
                                     (*run_shard)[1], k));
        return;
      }
      if (!merge->empty()) {
        emit(talc::MergeShards(*merge));
        return;
      }
      if (grid->empty())
        throw InputError("talc sweep", 0, "GRID", "a grid file is required");
      if (log->empty())
        throw InputError("talc sweep", 0, "--log", "a log is required");
      const talc::Grid g = talc::ReadGrid(*grid);
      if (!plan->empty()) {
        const int n = to_int((*plan)[0], "--plan");
        if (n < 1) throw InputError("--plan", 0, "N", "must be >= 1");
        ReadLog(*log);  // bad input now rather than in every shard
        const auto p = talc::PlanShards(g, *log, n, (*plan)[1], SelfPath());
        WriteText("-", fmt::format("{} strategies in {} shards in {}\n"
                                   "Slurm:         {}\n"
                                   "GNU parallel:  {}\n"
                                   "then:          ttp talc sweep --merge {}\n",
                                   g.size(), n, p.dir.string(), p.slurm_command,
                                   p.parallel_command, (*plan)[1]));
        return;
      }
      const models::TimeSeries series = ReadLog(*log);
      if (!global.quiet)
        for (const auto& w : SensorJumpWarnings(series))
          std::fprintf(stderr, "warning: %s\n", w.c_str());
      emit(talc::RunSweep(series, g, fs::path(*log).filename().string(),
                          *threads));
    });
  }
}

}  // namespace
TTP_REGISTER_COMMANDS(45, RegisterTalc);
}  // namespace ttp::app
