#include "ttp/talc/sweep.h"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <thread>

#include "ttp/geometry/error.h"
#include "ttp/geometry/file_io.h"
#include "ttp/geometry/json_text.h"
#include "ttp/geometry/limits.h"
#include "ttp/talc/regressors.h"
#include "ttp/talc/replay.h"

namespace ttp::talc {

namespace fs = std::filesystem;

std::size_t Grid::size() const {
  std::size_t n = 1;
  for (const auto& v : values) n *= v.size();
  return n;
}

nlohmann::json Grid::Params(std::size_t index) const {
  nlohmann::json p = nlohmann::json::object();
  for (std::size_t k = keys.size(); k-- > 0;) {
    const std::size_t r = values[k].size();
    p[keys[k]] = values[k][index % r];
    index /= r;
  }
  return p;
}

Strategy Grid::At(std::size_t index) const {
  nlohmann::json j = base;
  const nlohmann::json params = Params(index);
  for (auto it = params.begin(); it != params.end(); ++it) j[it.key()] = *it;
  return StrategyFromJson(j, source);
}

Grid GridFromJson(const nlohmann::json& j, const std::string& source) {
  if (!j.is_object()) throw InputError(source, 0, "", "expected a table");
  Grid g;
  g.source = source;
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string& k = it.key();
    const auto& v = it.value();
    if (k == "base") {
      g.base = v;
      StrategyFromJson(v, source, "base.");  // validates
    } else if (k == "grid") {
      if (!v.is_object())
        throw InputError(source, 0, "grid", "expected a table of lists");
      for (auto g_it = v.begin(); g_it != v.end(); ++g_it) {
        const std::string f = "grid." + g_it.key();
        if (!g_it.value().is_array() || g_it.value().empty())
          throw InputError(source, 0, f, "expected a non-empty list");
        // The points are ranked against each other by their outputs'
        // figures: every point judges the same outputs.
        if (g_it.key() == "outputs")
          throw InputError(source, 0, f,
                           "the outputs cannot vary over the grid (points "
                           "judged on other outputs do not compare): give "
                           "them in base, one sweep per set");
        for (std::size_t i = 0; i < g_it.value().size(); ++i) {
          nlohmann::json one = g.base;
          one[g_it.key()] = g_it.value()[i];
          try {
            StrategyFromJson(one, source, "");
          } catch (const InputError& e) {
            throw InputError(source, 0, fmt::format("{}[{}]", f, i),
                             e.field() + ": " + e.problem());
          }
        }
        g.keys.push_back(g_it.key());
        g.values.push_back(g_it.value());
        // Checked as it grows: the product of the list lengths neither
        // overflows nor sends the validation below through billions of
        // points.
        if (g.size() > static_cast<std::size_t>(limits::kMaxGridPoints))
          throw InputError(
              source, 0, f,
              fmt::format("the grid has more than {} points (the product of "
                          "its list lengths): split it into several sweeps",
                          limits::kMaxGridPoints));
      }
    } else if (k == "limit_p99_um") {
      if (!v.is_number() || !(v.get<double>() > 0))
        throw InputError(source, 0, k, "expected a number > 0");
      g.limit_p99_um = v.get<double>();
    } else if (k == "limits_p99_um") {
      if (!v.is_array()) throw InputError(source, 0, k, "expected a list");
      g.limits_p99_um.clear();
      for (std::size_t i = 0; i < v.size(); ++i) {
        if (!v[i].is_number() || !(v[i].get<double>() > 0))
          throw InputError(source, 0, fmt::format("{}[{}]", k, i),
                           "expected a number > 0");
        g.limits_p99_um.push_back(v[i].get<double>());
      }
    } else {
      throw InputError(source, 0, k, "unknown field");
    }
  }
  // Validation of each value alone names the field; a combination can
  // still be invalid (min_interval_s > max_interval_s): check them all.
  for (std::size_t i = 0; i < g.size(); ++i) {
    try {
      g.At(i);
    } catch (const InputError& e) {
      throw InputError(source, 0, e.field(),
                       fmt::format("{} (grid point {}: {})", e.problem(), i,
                                   g.Params(i).dump()));
    }
  }
  return g;
}

Grid ReadGrid(const fs::path& path) {
  return GridFromJson(ReadTomlOrJson(path), path.string());
}

nlohmann::json GridToJson(const Grid& g) {
  nlohmann::json j;
  j["base"] = g.base;
  nlohmann::json grid = nlohmann::json::object();
  for (std::size_t k = 0; k < g.keys.size(); ++k) grid[g.keys[k]] = g.values[k];
  j["grid"] = grid;
  j["limit_p99_um"] = g.limit_p99_um;
  j["limits_p99_um"] = g.limits_p99_um;
  return j;
}

namespace {

nlohmann::json PointJson(std::size_t index, const nlohmann::json& params,
                         const ReplayResult& r) {
  nlohmann::json p;
  p["index"] = index;
  p["params"] = params;
  p["measurements"] = r.measurements;
  p["q_prod_percent"] = 100.0 * r.q_prod;
  p["status"] = r.status == ReplayStatus::kOk ? "ok" : "no evaluated samples";
  double sum_p99 = 0.0, sum_rms = 0.0;
  nlohmann::json outs = nlohmann::json::array();
  for (const auto& o : r.outputs) {
    outs.push_back({{"name", o.name},
                    {"rms_um", o.talc.rms_um},
                    {"p99_um", o.talc.p99_um},
                    {"ptv_um", o.talc.ptv_um}});
    sum_p99 += o.talc.p99_um;
    sum_rms += o.talc.rms_um;
  }
  const double m = double(std::max<std::size_t>(1, r.outputs.size()));
  p["p99_mean_um"] = sum_p99 / m;
  p["rms_mean_um"] = sum_rms / m;
  p["outputs"] = outs;
  return p;
}

}  // namespace

std::vector<nlohmann::json> RunPoints(const models::TimeSeries& series,
                                      const Grid& grid,
                                      const std::vector<std::size_t>& indices,
                                      int threads) {
  // Regressors shared by every point with the same regressor fields.
  std::vector<Strategy> strategies;
  std::map<std::string, std::shared_ptr<const Regressors>> cache;
  std::vector<std::shared_ptr<const Regressors>> regs;
  for (std::size_t idx : indices) {
    strategies.push_back(grid.At(idx));
    const auto& s = strategies.back().regressors;
    const std::string key = nlohmann::json{
        {"l", s.speed_lags_s},
        {"q", s.speed_squared},
        {"t", s.temperatures},
        {"tl",
         s.temperature_lag_s}}.dump();
    auto& slot = cache[key];
    if (!slot) slot = std::make_shared<Regressors>(BuildRegressors(series, s));
    regs.push_back(slot);
  }
  std::vector<nlohmann::json> out(indices.size());
  std::atomic<std::size_t> next{0};
  std::exception_ptr error;
  std::mutex error_mutex;
  auto work = [&] {
    for (;;) {
      const std::size_t k = next.fetch_add(1);
      if (k >= indices.size()) return;
      try {
        ReplayOptions opt;
        opt.baselines = false;
        const ReplayResult r = Replay(series, *regs[k], strategies[k], opt);
        out[k] = PointJson(indices[k], grid.Params(indices[k]), r);
      } catch (...) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (!error) error = std::current_exception();
        next = indices.size();
      }
    }
  };
  if (threads <= 0)
    threads = int(std::max(1u, std::thread::hardware_concurrency()));
  threads = int(std::min<std::size_t>(
      std::size_t(threads), std::max<std::size_t>(1, indices.size())));
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(work);
  work();
  for (auto& t : pool) t.join();
  if (error) std::rethrow_exception(error);
  return out;
}

namespace {

// Points not dominated in (lower P99, higher Q_Prod); by Q_Prod descending.
nlohmann::json Pareto(const std::vector<nlohmann::json>& pts,
                      const std::function<double(const nlohmann::json&)>& p99) {
  std::vector<std::size_t> order(pts.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  auto q = [&](std::size_t i) {
    return pts[i]["q_prod_percent"].get<double>();
  };
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    if (q(a) != q(b)) return q(a) > q(b);
    if (p99(pts[a]) != p99(pts[b])) return p99(pts[a]) < p99(pts[b]);
    return a < b;
  });
  nlohmann::json front = nlohmann::json::array();
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i : order) {
    const double v = p99(pts[i]);
    if (v < best) {
      best = v;
      front.push_back({{"index", pts[i]["index"]},
                       {"q_prod_percent", pts[i]["q_prod_percent"]},
                       {"p99_um", v}});
    }
  }
  return front;
}

}  // namespace

nlohmann::json MergeSweep(const Grid& grid, const std::string& log_name,
                          std::vector<nlohmann::json> points) {
  const std::size_t n = grid.size();
  std::vector<nlohmann::json> by_index(n);
  std::vector<char> seen(n, 0);
  for (auto& p : points) {
    const std::size_t i = p.at("index").get<std::size_t>();
    if (i >= n || seen[i])
      throw std::runtime_error(
          fmt::format("sweep point {} out of range or "
                      "given twice",
                      i));
    seen[i] = 1;
    by_index[i] = std::move(p);
  }
  for (std::size_t i = 0; i < n; ++i)
    if (!seen[i])
      throw std::runtime_error(fmt::format("sweep point {} is missing", i));
  std::vector<nlohmann::json> ok;
  for (const auto& p : by_index)
    if (p["status"] == "ok") ok.push_back(p);

  nlohmann::json doc;
  doc["log"] = log_name;
  doc["grid"] = GridToJson(grid);
  doc["points"] = by_index;
  nlohmann::json pareto;
  pareto["mean"] = Pareto(ok, [](const nlohmann::json& p) {
    return p["p99_mean_um"].get<double>();
  });
  std::vector<std::string> names;
  if (!ok.empty())
    for (const auto& o : ok.front()["outputs"]) names.push_back(o["name"]);
  for (std::size_t o = 0; o < names.size(); ++o)
    pareto[names[o]] = Pareto(ok, [o](const nlohmann::json& p) {
      return p["outputs"][o]["p99_um"].get<double>();
    });
  doc["pareto"] = pareto;

  // Best sets (thesis table 6.3 and figure 6.10). Ties: the lower index.
  auto pick = [&](auto better) {
    const nlohmann::json* best = nullptr;
    for (const auto& p : ok)
      if (best == nullptr || better(p, *best)) best = &p;
    return best ? (*best)["index"] : nlohmann::json();
  };
  auto p99m = [](const nlohmann::json& p) {
    return p["p99_mean_um"].get<double>();
  };
  auto qp = [](const nlohmann::json& p) {
    return p["q_prod_percent"].get<double>();
  };
  nlohmann::json best;
  best["min_p99_mean"] =
      pick([&](const auto& a, const auto& b) { return p99m(a) < p99m(b); });
  best["min_rms_mean"] = pick([&](const auto& a, const auto& b) {
    return a["rms_mean_um"].template get<double>() <
           b["rms_mean_um"].template get<double>();
  });
  auto max_q_below = [&](double limit) {
    return pick([&](const auto& a, const auto& b) {
      const bool ia = p99m(a) < limit, ib = p99m(b) < limit;
      if (ia != ib) return ia;
      if (!ia) return false;
      if (qp(a) != qp(b)) return qp(a) > qp(b);
      return p99m(a) < p99m(b);
    });
  };
  auto below = [&](const nlohmann::json& idx, double limit) {
    return !idx.is_null() && p99m(by_index[idx.get<std::size_t>()]) < limit;
  };
  {
    const auto idx = max_q_below(grid.limit_p99_um);
    best["max_q_prod_p99_below_limit"] =
        below(idx, grid.limit_p99_um) ? idx : nlohmann::json();
  }
  for (std::size_t o = 0; o < names.size(); ++o)
    best["min_p99_" + names[o]] = pick([o](const auto& a, const auto& b) {
      return a["outputs"][o]["p99_um"].template get<double>() <
             b["outputs"][o]["p99_um"].template get<double>();
    });
  doc["best"] = best;
  nlohmann::json curve = nlohmann::json::array();
  for (double limit : grid.limits_p99_um) {
    const auto idx = max_q_below(limit);
    if (!below(idx, limit)) {
      curve.push_back({{"limit_p99_um", limit}, {"index", nullptr}});
    } else {
      curve.push_back({{"limit_p99_um", limit},
                       {"index", idx},
                       {"q_prod_percent",
                        by_index[idx.get<std::size_t>()]["q_prod_percent"]}});
    }
  }
  doc["max_q_prod_by_limit"] = curve;
  return doc;
}

std::string SweepText(const nlohmann::json& d) {
  const auto& pts = d["points"];
  std::string t = fmt::format("TALC sweep on {}: {} strategies\n",
                              d["log"].get<std::string>(), pts.size());
  auto describe = [&](const nlohmann::json& idx) {
    if (idx.is_null()) return std::string("none");
    const auto& p = pts[idx.get<std::size_t>()];
    return fmt::format(
        "#{} {} -> P99 mean {:.2f} um, RMS mean {:.2f} um, "
        "Q_Prod {:.2f} %",
        idx.get<std::size_t>(), p["params"].dump(),
        p["p99_mean_um"].get<double>(), p["rms_mean_um"].get<double>(),
        p["q_prod_percent"].get<double>());
  };
  std::string skipped;
  int n_skipped = 0;
  for (const auto& p : pts)
    if (p["status"] != "ok") {
      if (++n_skipped <= 5)
        skipped += fmt::format(" #{} {}", p["index"].get<std::size_t>(),
                               p["params"].dump());
    }
  if (n_skipped > 0)
    t += fmt::format(
        "warning: {} of {} points compensate nothing that is measured (the "
        "calibration reaches past the log's end, or no output is measured "
        "after it): ranked nowhere, their figures 0:{}{}\n",
        n_skipped, pts.size(), skipped, n_skipped > 5 ? " ..." : "");
  t += "best sets:\n";
  for (auto& [k, v] : d["best"].items())
    t += fmt::format("  {:<28} {}\n", k, describe(v));
  t += "Pareto front, P99 (um) against Q_Prod (%):\n";
  for (auto& [k, front] : d["pareto"].items()) {
    t += fmt::format("  {:<8}", k);
    for (const auto& f : front)
      t += fmt::format(" {:.2f}%:{:.2f}", f["q_prod_percent"].get<double>(),
                       f["p99_um"].get<double>());
    t += "\n";
  }
  t += "max Q_Prod with mean P99 below a limit:\n";
  for (const auto& c : d["max_q_prod_by_limit"]) {
    t += fmt::format("  P99 < {:g} um: ", c["limit_p99_um"].get<double>());
    t += c["index"].is_null() ? std::string("none\n")
                              : fmt::format("{:.2f} % (#{})\n",
                                            c["q_prod_percent"].get<double>(),
                                            c["index"].get<std::size_t>());
  }
  return t;
}

nlohmann::json RunSweep(const models::TimeSeries& series, const Grid& grid,
                        const std::string& log_name, int threads) {
  std::vector<std::size_t> all(grid.size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = i;
  return MergeSweep(grid, log_name, RunPoints(series, grid, all, threads));
}

namespace {
std::string Quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}
}  // namespace

ShardPlan PlanShards(const Grid& grid, const fs::path& log, int shards,
                     const fs::path& dir_in, const fs::path& ttp) {
  if (shards < 1) throw InputError("--plan", 0, "N", "must be >= 1");
  const std::size_t n = grid.size();
  // Every shard runs at least one point (the merge refuses an empty one,
  // after the cluster's work; so does the plan, before it).
  if (static_cast<std::size_t>(shards) > n)
    throw InputError("--plan", 0, "N",
                     fmt::format("{} shards for a grid of {} points: at most "
                                 "one shard per point",
                                 shards, n));
  const fs::path dir = fs::absolute(dir_in).lexically_normal();
  nlohmann::json plan;
  plan["grid"] = GridToJson(grid);
  plan["grid_source"] = grid.source;
  plan["log"] = fs::absolute(log).lexically_normal().string();
  plan["log_name"] = log.filename().string();
  plan["shards"] = shards;
  plan["points"] = n;
  WriteFileAtomic(dir / "plan.json", JsonText(plan, 2) + "\n");
  // Contiguous blocks, sizes differing by at most one.
  for (int k = 0; k < shards; ++k) {
    const std::size_t lo = n * std::size_t(k) / std::size_t(shards);
    const std::size_t hi = n * std::size_t(k + 1) / std::size_t(shards);
    nlohmann::json s;
    s["shard"] = k;
    s["first_index"] = lo;
    s["end_index"] = hi;
    WriteFileAtomic(dir / fmt::format("shard-{}.json", k),
                    JsonText(s, 2) + "\n");
    fs::remove(dir / fmt::format("result-{}.json", k));
  }
  const std::string run =
      fmt::format("{} talc sweep --threads 1 --run-shard", Quote(ttp.string()));
  const std::string script = fmt::format(
      "#!/bin/sh\n"
      "# TALC sweep: {} strategies in {} shards. Submit with\n"
      "#   sbatch --wait {}\n"
      "# then merge with: ttp talc sweep --merge {}\n"
      "#SBATCH --job-name=ttp-talc-sweep\n"
      "#SBATCH --array=0-{}\n"
      "#SBATCH --ntasks=1\n"
      "#SBATCH --cpus-per-task=1\n"
      "#SBATCH --output={}/slurm-%A_%a.out\n"
      "exec {} \"$SLURM_ARRAY_TASK_ID\" {}\n",
      n, shards, Quote((dir / "talc-sweep.sbatch").string()),
      Quote(dir.string()), shards - 1, dir.string(), run, Quote(dir.string()));
  WriteFileAtomic(dir / "talc-sweep.sbatch", script);
  ShardPlan p;
  p.dir = dir;
  p.shards = shards;
  p.slurm_command = fmt::format("sbatch --array=0-{} --wait {}", shards - 1,
                                Quote((dir / "talc-sweep.sbatch").string()));
  p.parallel_command =
      fmt::format("parallel --halt now,fail=1 {} {{}} {} ::: {}", run,
                  Quote(dir.string()), [&] {
                    std::string ks;
                    for (int k = 0; k < shards; ++k)
                      ks += (k ? " " : "") + std::to_string(k);
                    return ks;
                  }());
  WriteFileAtomic(dir / "parallel.sh",
                  "#!/bin/sh\n# TALC sweep shards on one machine (GNU "
                  "parallel)\n" +
                      p.parallel_command + "\n");
  fs::permissions(dir / "parallel.sh",
                  fs::perms::owner_exec | fs::perms::group_exec,
                  fs::perm_options::add);
  fs::permissions(dir / "talc-sweep.sbatch",
                  fs::perms::owner_exec | fs::perms::group_exec,
                  fs::perm_options::add);
  return p;
}

void RunShard(const fs::path& dir, int k, int threads,
              const LogReader& read_log) {
  const nlohmann::json plan = ReadJsonFile(dir / "plan.json");
  const int shards = plan.at("shards").get<int>();
  if (k < 0 || k >= shards)
    throw InputError("--run-shard", 0, "K",
                     fmt::format("shard {} outside 0..{}", k, shards - 1));
  const nlohmann::json shard =
      ReadJsonFile(dir / fmt::format("shard-{}.json", k));
  const Grid grid =
      GridFromJson(plan.at("grid"), plan.at("grid_source").get<std::string>());
  const models::TimeSeries series = read_log(plan.at("log").get<std::string>());
  std::vector<std::size_t> idx;
  for (std::size_t i = shard.at("first_index").get<std::size_t>();
       i < shard.at("end_index").get<std::size_t>(); ++i)
    idx.push_back(i);
  nlohmann::json out;
  out["shard"] = k;
  out["points"] = RunPoints(series, grid, idx, threads);
  WriteFileAtomic(dir / fmt::format("result-{}.json", k), JsonText(out) + "\n");
}

namespace {

// A point of a shard's result file, as MergeSweep reads it: its index in
// the grid (whole, in range, not given before), its status and, for an
// evaluated point, the figures the Pareto fronts and best sets use, with
// the same outputs as every other evaluated point. A file edited by hand
// or from another plan is bad input, named with the point.
void CheckShardPoint(const nlohmann::json& p, const std::string& file,
                     std::size_t j, std::vector<char>& seen,
                     std::vector<std::string>& names) {
  const std::string where = fmt::format("points[{}]", j);
  const auto bad = [&](const std::string& field, const std::string& problem) {
    return InputError(file, 0, where + field, problem);
  };
  if (!p.is_object()) throw bad("", "not a sweep point (a JSON object)");
  if (!p.contains("index") || !p["index"].is_number_unsigned() ||
      p["index"].get<std::size_t>() >= seen.size())
    throw bad(".index", fmt::format("not a point of this grid (0 to {})",
                                    seen.size() - 1));
  const std::size_t i = p["index"].get<std::size_t>();
  if (seen[i]) throw bad(".index", fmt::format("point {} is given twice", i));
  seen[i] = 1;
  if (!p.contains("status") || !p["status"].is_string())
    throw bad(".status", "missing");
  if (p["status"] != "ok") return;
  for (const char* key : {"p99_mean_um", "rms_mean_um", "q_prod_percent"})
    if (!p.contains(key) || !p[key].is_number())
      throw bad(std::string(".") + key, "missing or not a number");
  if (!p.contains("outputs") || !p["outputs"].is_array() ||
      p["outputs"].empty())
    throw bad(".outputs", "missing or empty");
  std::vector<std::string> these;
  for (const auto& o : p["outputs"]) {
    if (!o.is_object() || !o.contains("name") || !o["name"].is_string() ||
        !o.contains("p99_um") || !o["p99_um"].is_number())
      throw bad(".outputs", "an output without its name or p99_um");
    these.push_back(o["name"].get<std::string>());
  }
  if (names.empty()) names = these;
  if (these != names)
    throw bad(".outputs", "other outputs than the other points (another log?)");
}

}  // namespace

nlohmann::json MergeShards(const fs::path& dir) {
  const fs::path plan_path = dir / "plan.json";
  const nlohmann::json plan = ReadJsonFile(plan_path);
  int shards = 0;
  Grid grid;
  std::string log_name;
  try {
    shards = plan.at("shards").get<int>();
    grid = GridFromJson(plan.at("grid"),
                        plan.at("grid_source").get<std::string>());
    log_name = plan.at("log_name").get<std::string>();
  } catch (const nlohmann::json::exception& e) {
    throw InputError(
        plan_path.string(), 0, "",
        std::string("not a sweep plan of ttp talc sweep --plan: ") + e.what());
  }
  if (shards < 1 || static_cast<std::size_t>(shards) > grid.size())
    throw InputError(
        plan_path.string(), 0, "shards",
        fmt::format("{} shards for a grid of {} points", shards, grid.size()));
  std::vector<nlohmann::json> points;
  std::vector<char> seen(grid.size(), 0);
  std::vector<std::string> names;
  for (int k = 0; k < shards; ++k) {
    const fs::path f = dir / fmt::format("result-{}.json", k);
    if (!fs::exists(f))
      throw InputError(f.string(), 0, "",
                       fmt::format("shard {} has no result yet (run `ttp talc "
                                   "sweep --run-shard {} {}`)",
                                   k, k, dir.string()));
    const nlohmann::json result = ReadJsonFile(f);
    if (!result.is_object() || !result.contains("shard") ||
        result["shard"] != k || !result.contains("points") ||
        !result["points"].is_array())
      throw InputError(
          f.string(), 0, "shard",
          fmt::format("not the result of shard {} of this plan", k));
    std::size_t j = 0;
    for (const auto& p : result["points"]) {
      CheckShardPoint(p, f.string(), j++, seen, names);
      points.push_back(p);
    }
  }
  for (std::size_t i = 0; i < seen.size(); ++i)
    if (!seen[i])
      throw InputError(dir.string(), 0, "points",
                       fmt::format("grid point {} is in no shard's result: a "
                                   "result file of another plan?",
                                   i));
  return MergeSweep(grid, log_name, std::move(points));
}

}  // namespace ttp::talc
