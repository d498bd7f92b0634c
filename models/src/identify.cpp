#include "ttp/models/identify.h"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <set>

#include "ttp/geometry/error.h"

namespace ttp::models {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kGapPeriods = 10.0;

bool IsSpeed(const std::string& name) { return name.rfind("n_", 0) == 0; }

// The inputs as they act at once: n and n^2 for speeds, T for temperatures.
std::vector<Regressor> BaseRegressors(const TimeSeries& ts) {
  std::vector<Regressor> out;
  for (const auto& name : ts.input_names) {
    if (IsSpeed(name)) {
      out.push_back({name, 1, 0, {}});
      out.push_back({name, 2, 0, {}});
    }
  }
  for (const auto& name : ts.input_names)
    if (!IsSpeed(name)) out.push_back({name, 1, 0, {}});
  return out;
}

// `joint`: every temperature directly and through one lag (a direct and a
// slower path), n and n^2 through a lag at every time constant (the spindle's
// heat a n + b n^2 with its spectrum of time constants).
std::vector<Regressor> JointRegressors(const TimeSeries& ts,
                                       const FitOptions& o) {
  std::vector<Regressor> out;
  for (const auto& name : ts.input_names)
    if (IsSpeed(name))
      for (double tau : o.taus_s) {
        out.push_back({name, 1, 0, {tau}});
        out.push_back({name, 2, 0, {tau}});
      }
  for (const auto& name : ts.input_names)
    if (!IsSpeed(name)) {
      out.push_back({name, 1, 0, {}});
      out.push_back({name, 1, 0, {o.temperature_lag_s}});
    }
  return out;
}

// A candidate pool: regressors, and the groups forward selection may add in
// one step (a group enters whole; a single regressor is a group of one).
struct Pool {
  std::vector<Regressor> regs;
  std::vector<std::vector<int>> groups;
  std::string label;
  int Add(const Regressor& r) {
    for (size_t k = 0; k < regs.size(); ++k)
      if (regs[k] == r) return static_cast<int>(k);
    regs.push_back(r);
    return static_cast<int>(regs.size()) - 1;
  }
  void Single(const Regressor& r) { groups.push_back({Add(r)}); }
  void Group(const std::vector<Regressor>& rs) {
    std::vector<int> g;
    for (const auto& r : rs) g.push_back(Add(r));
    groups.push_back(g);
  }
};

Regressor Lagged(Regressor r, std::vector<double> taus) {
  r.taus_s = std::move(taus);
  return r;
}

// Candidate pools; `arx` gives one pool per pole configuration. Groups carry
// the physics: a temperature acts directly and through a first-order lag
// (b0 + b1 / (1 + tau s): a direct path and a slower one, the two that a
// greedy search adding one regressor at a time cannot find one by one); the
// spindle's heat a n + b n^2 passes through one lag.
std::vector<Pool> CandidatePools(const TimeSeries& ts, Structure s,
                                 const FitOptions& o) {
  const std::vector<Regressor> base = BaseRegressors(ts);
  std::vector<Pool> pools(1);
  Pool& pool = pools[0];
  pool.label = StructureName(s);
  switch (s) {
    case Structure::kStatic:
      for (const auto& r : base) pool.Single(r);
      break;
    case Structure::kFir:
      for (const auto& r : base)
        for (int l = 0; l < o.fir_taps; ++l) {
          Regressor t = r;
          t.delay_s = l * o.fir_step_s;
          pool.Single(t);
        }
      break;
    case Structure::kLag:
      for (const auto& name : ts.input_names)
        if (IsSpeed(name))
          for (double tau : o.taus_s) {
            pool.Single({name, 1, 0, {tau}});
            pool.Single({name, 2, 0, {tau}});
            pool.Group({{name, 1, 0, {tau}}, {name, 2, 0, {tau}}});
          }
      break;
    case Structure::kArx: {
      pools.clear();
      std::vector<std::vector<double>> poles;
      for (double t1 : o.taus_s) {
        poles.push_back({t1});
        for (double t2 : o.taus_s)
          if (t2 < t1) poles.push_back({t1, t2});
      }
      for (const auto& p : poles) {
        Pool cfg;
        cfg.label = "poles";
        for (double t : p) cfg.label += fmt::format(" {:g} s", t);
        // B(q)/A(q) per input: b0 (direct) + the lagged path through the
        // shared poles; speeds as heat (n and n^2 together).
        for (const auto& name : ts.input_names) {
          if (IsSpeed(name)) {
            cfg.Group(
                {Lagged({name, 1, 0, {}}, p), Lagged({name, 2, 0, {}}, p)});
            cfg.Single(Lagged({name, 1, 0, {}}, p));
          } else {
            cfg.Single(Lagged({name, 1, 0, {}}, p));
            cfg.Group({{name, 1, 0, {}}, Lagged({name, 1, 0, {}}, p)});
          }
        }
        pools.push_back(cfg);
      }
      break;
    }
    case Structure::kCombined:
      for (const auto& r : base) pool.Single(r);
      for (const auto& name : ts.input_names)
        for (double tau : o.taus_s) {
          if (IsSpeed(name)) {
            pool.Single({name, 1, 0, {tau}});
            pool.Single({name, 2, 0, {tau}});
            pool.Group({{name, 1, 0, {tau}}, {name, 2, 0, {tau}}});
          } else {
            pool.Single({name, 1, 0, {tau}});
            pool.Group({{name, 1, 0, {}}, {name, 1, 0, {tau}}});
          }
        }
      break;
    case Structure::kJoint:  // no selection: FitOutput fits it whole
      break;
  }
  return pools;
}

// Weighted Gram matrices of [1, Z, y] per chronological block.
struct Grams {
  int p = 0;                           // regressors
  std::vector<Eigen::MatrixXd> train;  // weighted, cumulative: blocks [0, k)
  std::vector<Eigen::MatrixXd> valid;  // unweighted, block k
  std::vector<Eigen::MatrixXd> after;  // unweighted, blocks [k, end)
  Eigen::MatrixXd all;                 // weighted, every block
  int n = 0;
};

struct Data {
  Eigen::MatrixXd z;  // standardised regressors (valid rows)
  Eigen::VectorXd y;  // centred output
  Eigen::VectorXd w;
  std::vector<int> block;
  Eigen::VectorXd mean, scale;
  double y_mean = 0;
};

Data PrepareData(const TimeSeries& fit, int output,
                 const Eigen::MatrixXd& features, const FitOptions& o) {
  std::vector<Eigen::Index> rows;
  for (Eigen::Index i = 0; i < fit.outputs_um.rows(); ++i)
    if (std::isfinite(fit.outputs_um(i, output))) rows.push_back(i);
  if (rows.size() < 10) {
    throw InputError(fit.source, 0, fit.output_names[output],
                     fmt::format("only {} measured values in the fitted span "
                                 "(at least 10 needed)",
                                 rows.size()));
  }
  Data d;
  const Eigen::Index n = static_cast<Eigen::Index>(rows.size());
  const Eigen::Index p = features.cols();
  d.z.resize(n, p);
  d.y.resize(n);
  d.w.resize(n);
  d.block.resize(n);
  const double t0 = fit.t_s[rows.front()], t1 = fit.t_s[rows.back()];
  for (Eigen::Index k = 0; k < n; ++k) {
    const Eigen::Index i = rows[k];
    d.z.row(k) = features.row(i);
    d.y(k) = fit.outputs_um(i, output);
    d.w(k) = o.weight_half_life_s > 0
                 ? std::exp2(-(t1 - fit.t_s[i]) / o.weight_half_life_s)
                 : 1.0;
    const double f = t1 > t0 ? (fit.t_s[i] - t0) / (t1 - t0) : 0.0;
    d.block[k] = std::min(o.cv_blocks - 1, static_cast<int>(f * o.cv_blocks));
  }
  d.mean = d.z.colwise().mean().transpose();
  d.scale.resize(p);
  for (Eigen::Index j = 0; j < p; ++j) {
    const double sd =
        std::sqrt((d.z.col(j).array() - d.mean(j)).square().mean());
    d.scale(j) = sd > 1e-12 ? sd : 1.0;
    d.z.col(j) = (d.z.col(j).array() - d.mean(j)) / d.scale(j);
  }
  d.y_mean = d.y.mean();
  d.y.array() -= d.y_mean;
  return d;
}

Grams BuildGrams(const Data& d, const FitOptions& o) {
  Grams g;
  g.p = static_cast<int>(d.z.cols());
  g.n = static_cast<int>(d.z.rows());
  const int m = g.p + 2;
  std::vector<Eigen::MatrixXd> wblock(o.cv_blocks, Eigen::MatrixXd::Zero(m, m));
  g.valid.assign(o.cv_blocks, Eigen::MatrixXd::Zero(m, m));
  for (int b = 0; b < o.cv_blocks; ++b) {
    std::vector<Eigen::Index> idx;
    for (Eigen::Index k = 0; k < d.z.rows(); ++k)
      if (d.block[k] == b) idx.push_back(k);
    if (idx.empty()) continue;
    Eigen::MatrixXd x(static_cast<Eigen::Index>(idx.size()), m);
    Eigen::VectorXd w(x.rows());
    for (Eigen::Index r = 0; r < x.rows(); ++r) {
      x(r, 0) = 1.0;
      x.row(r).segment(1, g.p) = d.z.row(idx[r]);
      x(r, m - 1) = d.y(idx[r]);
      w(r) = d.w(idx[r]);
    }
    g.valid[b].noalias() = x.transpose() * x;
    wblock[b].noalias() = x.transpose() * w.asDiagonal() * x;
  }
  g.train.assign(o.cv_blocks + 1, Eigen::MatrixXd::Zero(m, m));
  for (int b = 0; b < o.cv_blocks; ++b) g.train[b + 1] = g.train[b] + wblock[b];
  g.all = g.train[o.cv_blocks];
  g.after.assign(o.cv_blocks + 1, Eigen::MatrixXd::Zero(m, m));
  for (int b = o.cv_blocks - 1; b >= 0; --b)
    g.after[b] = g.after[b + 1] + g.valid[b];
  return g;
}

// Ridge solution on the regressors `idx` (0 = intercept, j+1 = regressor j)
// from Gram matrix `a`; lambda scaled by the sum of weights.
bool Solve(const Eigen::MatrixXd& a, const std::vector<int>& idx, double lambda,
           Eigen::VectorXd* theta) {
  const int k = static_cast<int>(idx.size());
  const int yi = static_cast<int>(a.rows()) - 1;
  Eigen::MatrixXd m(k, k);
  Eigen::VectorXd rhs(k);
  for (int r = 0; r < k; ++r) {
    rhs(r) = a(idx[r], yi);
    for (int c = 0; c < k; ++c) m(r, c) = a(idx[r], idx[c]);
  }
  const double n = a(0, 0);
  if (n <= 0) return false;
  // The penalty is on the regressors standardised by this Gram's own data
  // (lambda n var_j on the diagonal): a CV fold is scaled by what its
  // training blocks saw, not by the whole span. A tiny floor keeps collinear
  // candidates (e.g. lags of one input at neighbouring time constants)
  // solvable; it is far below any ridge tried.
  for (int r = 1; r < k; ++r) {
    const double mean = a(idx[r], 0) / n;
    const double var = std::max(a(idx[r], idx[r]) / n - mean * mean, 1e-12);
    m(r, r) += (lambda + 1e-9) * n * var;
  }
  Eigen::LDLT<Eigen::MatrixXd> ldlt(m);
  if (ldlt.info() != Eigen::Success) return false;
  *theta = ldlt.solve(rhs);
  return theta->allFinite();
}

double Sse(const Eigen::MatrixXd& v, const std::vector<int>& idx,
           const Eigen::VectorXd& theta) {
  const int yi = static_cast<int>(v.rows()) - 1;
  double sse = v(yi, yi);
  for (size_t r = 0; r < idx.size(); ++r) {
    sse -= 2 * theta(r) * v(idx[r], yi);
    for (size_t c = 0; c < idx.size(); ++c)
      sse += theta(r) * theta(c) * v(idx[r], idx[c]);
  }
  return std::max(0.0, sse);
}

struct Score {
  double score = std::numeric_limits<double>::infinity();
  double cv_rms = kNaN;
  double fit_rms = kNaN;
  double lambda = 0;
};

// Chronological CV (pooled RMS over the validation blocks) and in-sample RMS.
Score Evaluate(const Grams& g, const std::vector<int>& idx, double lambda,
               const FitOptions& o) {
  Score s;
  s.lambda = lambda;
  double sse = 0, count = 0;
  Eigen::VectorXd theta;
  for (int k = o.cv_first_validation_block; k < o.cv_blocks; ++k) {
    const Eigen::MatrixXd& v = g.after[k];
    const double nv = v(0, 0);
    if (nv <= 0) continue;
    if (g.train[k](0, 0) < idx.size() + 1) continue;
    if (!Solve(g.train[k], idx, lambda, &theta)) return s;
    const double fold = Sse(v, idx, theta);
    sse += fold;
    count += nv;
  }
  if (count > 0) s.cv_rms = std::sqrt(sse / count);
  if (!Solve(g.all, idx, lambda, &theta)) return s;
  // In-sample RMS unweighted: the sum of the validation-style Grams.
  Eigen::MatrixXd u = Eigen::MatrixXd::Zero(g.all.rows(), g.all.cols());
  for (const auto& v : g.valid) u += v;
  s.fit_rms = std::sqrt(Sse(u, idx, theta) / std::max(1.0, u(0, 0)));
  const double n = g.n;
  const double mdl = 1.0 + static_cast<double>(idx.size()) * std::log(n) / n;
  const double base = o.criterion == "mdl" ? s.fit_rms : s.cv_rms;
  s.score = std::isfinite(base) ? base * mdl
                                : std::numeric_limits<double>::infinity();
  return s;
}

Score BestRidge(const Grams& g, const std::vector<int>& idx,
                const FitOptions& o) {
  Score best;
  for (double lambda : o.ridge) {
    const Score s = Evaluate(g, idx, lambda, o);
    if (s.score < best.score) best = s;
  }
  return best;
}

struct Selection {
  std::vector<int> chosen;  // regressor indices into the pool
  Score score;
  std::vector<std::string> log;
};

Selection ForwardSelect(const Grams& g, const Pool& pool, const FitOptions& o) {
  Selection sel;
  std::vector<int> idx = {0};
  sel.score = BestRidge(g, idx, o);
  sel.log.push_back(
      fmt::format("intercept only: score {:.4g}, CV RMS {:.3f} um",
                  sel.score.score, sel.score.cv_rms));
  std::vector<bool> used(pool.regs.size(), false);
  while (static_cast<int>(sel.chosen.size()) < o.max_terms) {
    int best_g = -1;
    Score best;
    for (size_t c = 0; c < pool.groups.size(); ++c) {
      std::vector<int> trial = idx;
      for (int r : pool.groups[c])
        if (!used[r]) trial.push_back(r + 1);
      if (trial.size() == idx.size()) continue;
      if (static_cast<int>(trial.size()) - 1 > o.max_terms) continue;
      const Score s = BestRidge(g, trial, o);
      if (s.score < best.score) {
        best = s;
        best_g = static_cast<int>(c);
      }
    }
    if (best_g < 0 || !(best.score < sel.score.score * (1 - o.min_gain))) break;
    std::string names;
    for (int r : pool.groups[best_g]) {
      if (used[r]) continue;
      used[r] = true;
      idx.push_back(r + 1);
      sel.chosen.push_back(r);
      names += (names.empty() ? "" : " + ") + pool.regs[r].Name();
    }
    sel.score = best;
    sel.log.push_back(
        fmt::format("+ {}: score {:.4g}, CV RMS {:.3f} um, ridge {:g}", names,
                    best.score, best.cv_rms, best.lambda));
  }
  return sel;
}

OutputModel Finish(const Data& d, const Grams& g,
                   const std::vector<Regressor>& pool,
                   const std::vector<int>& chosen, const Score& score,
                   const std::string& output, Structure structure) {
  std::vector<int> idx = {0};
  for (int c : chosen) idx.push_back(c + 1);
  Eigen::VectorXd theta;
  if (!Solve(g.all, idx, score.lambda, &theta)) {
    throw std::runtime_error("least-squares solve failed for " + output);
  }
  OutputModel m;
  m.output = output;
  m.structure = structure;
  m.ridge = score.lambda;
  m.cv_score = score.score;
  m.cv_rms_um = score.cv_rms;
  m.fit_rms_um = score.fit_rms;
  m.n_fit = g.n;
  const int k = static_cast<int>(chosen.size());
  m.coef.resize(k);
  m.mean.resize(k);
  m.scale.resize(k);
  m.intercept_um = d.y_mean + theta(0);
  for (int j = 0; j < k; ++j) {
    m.regressors.push_back(pool[chosen[j]]);
    m.mean(j) = d.mean(chosen[j]);
    m.scale(j) = d.scale(chosen[j]);
    m.coef(j) = theta(j + 1) / m.scale(j);
    m.intercept_um -= m.coef(j) * m.mean(j);
  }
  return m;
}

double MedianStep(const TimeSeries& ts) {
  if (ts.rows() < 2) return 0;
  std::vector<double> steps;
  for (size_t i = 1; i < ts.rows(); ++i)
    steps.push_back(ts.t_s[i] - ts.t_s[i - 1]);
  std::nth_element(steps.begin(), steps.begin() + steps.size() / 2,
                   steps.end());
  return steps[steps.size() / 2];
}

void CheckOptions(const FitOptions& o) {
  std::string error;
  if (!o.IsValid(&error)) throw InputError("options", 0, "", error);
}

}  // namespace

const char* StructureName(Structure s) {
  switch (s) {
    case Structure::kStatic:
      return "static";
    case Structure::kFir:
      return "fir";
    case Structure::kLag:
      return "lag";
    case Structure::kArx:
      return "arx";
    case Structure::kCombined:
      return "combined";
    case Structure::kJoint:
      return "joint";
  }
  return "?";
}

bool ParseStructure(const std::string& name, Structure* s) {
  for (Structure c : AllStructures())
    if (name == StructureName(c)) {
      *s = c;
      return true;
    }
  return false;
}

std::vector<Structure> AllStructures() {
  return {Structure::kStatic, Structure::kFir,      Structure::kLag,
          Structure::kArx,    Structure::kCombined, Structure::kJoint};
}

bool FitOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  Structure s;
  if (model != "auto" && !ParseStructure(model, &s))
    return fail("model: '" + model +
                "' is not auto, static, fir, lag, arx, combined or joint");
  if (taus_s.empty()) return fail("taus_s: at least one time constant");
  for (double t : taus_s)
    if (!(t > 0)) return fail("taus_s: time constants must be > 0");
  if (!(temperature_lag_s > 0)) return fail("temperature_lag_s: must be > 0");
  if (!(fir_step_s > 0)) return fail("fir_step_s: must be > 0");
  if (fir_taps < 1 || fir_taps > 50) return fail("fir_taps: 1..50");
  if (max_terms < 1 || max_terms > 40) return fail("max_terms: 1..40");
  if (cv_blocks < 2 || cv_blocks > 100) return fail("cv_blocks: 2..100");
  if (cv_first_validation_block < 1 || cv_first_validation_block >= cv_blocks)
    return fail("cv_first_validation_block: 1..cv_blocks-1");
  if (ridge.empty()) return fail("ridge: at least one value");
  for (double r : ridge)
    if (!(r >= 0)) return fail("ridge: values must be >= 0");
  if (criterion != "cv" && criterion != "mdl")
    return fail("criterion: 'cv' or 'mdl'");
  if (!(min_gain >= 0 && min_gain < 1)) return fail("min_gain: 0..1");
  if (!(weight_half_life_s >= 0)) return fail("weight_half_life_s: >= 0");
  return true;
}

TimeSeries HeadOf(const TimeSeries& ts, double t_end_s) {
  TimeSeries h = ts;
  size_t n = 0;
  while (n < ts.rows() && ts.t_s[n] < t_end_s) ++n;
  h.t_s.resize(n);
  h.inputs = ts.inputs.topRows(static_cast<Eigen::Index>(n)).eval();
  h.outputs_um = ts.outputs_um.topRows(static_cast<Eigen::Index>(n)).eval();
  h.gap_rows.clear();
  for (size_t g : ts.gap_rows)
    if (g < n) h.gap_rows.push_back(g);
  return h;
}

OutputModel FitOutput(const TimeSeries& fit, int output, Structure structure,
                      const FitOptions& o) {
  CheckOptions(o);
  if (structure == Structure::kJoint) {
    OutputModel m =
        FitFixed(fit, output, JointRegressors(fit, o), Structure::kJoint, o);
    m.selection_log.push_back(fmt::format(
        "{} regressors, ridge {:g} by CV: score {:.4g}, CV RMS {:.3f} um",
        m.regressors.size(), m.ridge, m.cv_score, m.cv_rms_um));
    return m;
  }
  const auto pools = CandidatePools(fit, structure, o);
  OutputModel best;
  best.cv_score = std::numeric_limits<double>::infinity();
  bool have = false;
  for (const auto& pool : pools) {
    const Eigen::MatrixXd f = ComputeFeatures(fit, pool.regs);
    const Data d = PrepareData(fit, output, f, o);
    const Grams g = BuildGrams(d, o);
    const Selection sel = ForwardSelect(g, pool, o);
    if (have && !(sel.score.score < best.cv_score)) continue;
    best = Finish(d, g, pool.regs, sel.chosen, sel.score,
                  fit.output_names[output], structure);
    best.selection_log = sel.log;
    if (structure == Structure::kArx)
      best.selection_log.insert(best.selection_log.begin(), pool.label);
    have = true;
  }
  return best;
}

OutputModel FitFixed(const TimeSeries& fit, int output,
                     const std::vector<Regressor>& regressors,
                     Structure structure, const FitOptions& o) {
  CheckOptions(o);
  const Eigen::MatrixXd f = ComputeFeatures(fit, regressors);
  const Data d = PrepareData(fit, output, f, o);
  const Grams g = BuildGrams(d, o);
  std::vector<int> idx = {0}, chosen;
  for (size_t j = 0; j < regressors.size(); ++j) {
    idx.push_back(static_cast<int>(j) + 1);
    chosen.push_back(static_cast<int>(j));
  }
  const Score s = BestRidge(g, idx, o);
  return Finish(d, g, regressors, chosen, s, fit.output_names[output],
                structure);
}

ThermalModel FitThermalModel(const TimeSeries& ts,
                             const std::vector<std::string>& outputs,
                             const FitOptions& o, double fit_until_s) {
  CheckOptions(o);
  const TimeSeries fit = HeadOf(ts, fit_until_s);
  if (fit.rows() < 10)
    throw InputError(ts.source, 0, "t_s",
                     "fewer than 10 rows in the fitted span");
  std::vector<int> which;
  if (outputs.empty()) {
    for (size_t j = 0; j < fit.output_names.size(); ++j)
      which.push_back(static_cast<int>(j));
  } else {
    for (const auto& name : outputs) {
      const int j = fit.OutputIndex(name);
      if (j < 0)
        throw InputError(ts.source, 0, name, "output column is not in the log");
      which.push_back(j);
    }
  }
  if (which.empty())
    throw InputError(ts.source, 0, "d_*", "the log has no output column");
  ThermalModel model;
  model.source = ts.source;
  model.options = o;
  model.fit_t_begin_s = fit.t_s.front();
  model.fit_t_end_s = fit.t_s.back();
  model.median_step_s = MedianStep(fit);
  std::set<std::string> needed;
  for (int j : which) {
    Structure s = Structure::kJoint;  // auto
    if (o.model != "auto") ParseStructure(o.model, &s);
    OutputModel best = FitOutput(fit, j, s, o);
    ComputeFeatures(fit, best.regressors, nullptr, &best.end_state);
    for (const auto& r : best.regressors) needed.insert(r.input);
    model.outputs.push_back(std::move(best));
  }
  for (const auto& name : fit.input_names)
    if (needed.count(name)) model.inputs.push_back(name);
  return model;
}

Eigen::VectorXd PredictOutput(const OutputModel& m, const TimeSeries& ts) {
  const Eigen::MatrixXd f = ComputeFeatures(ts, m.regressors);
  Eigen::VectorXd y = Eigen::VectorXd::Constant(f.rows(), m.intercept_um);
  if (m.coef.size() > 0) y += f * m.coef;
  return y;
}

Prediction Predict(const ThermalModel& model, const TimeSeries& ts) {
  for (const auto& name : model.inputs) {
    if (ts.InputIndex(name) < 0) {
      throw InputError(ts.source, 0, name,
                       "column needed by the model is missing from the log");
    }
  }
  Prediction p;
  p.t_s = ts.t_s;
  p.values_um.resize(static_cast<Eigen::Index>(ts.rows()),
                     static_cast<Eigen::Index>(model.outputs.size()));
  const double step = ts.t_s.front() - model.fit_t_end_s;
  p.continued = step > 0 && step <= kGapPeriods * model.median_step_s;
  if (step > kGapPeriods * model.median_step_s) {
    p.warnings.push_back(fmt::format(
        "the log starts {:g} s after the fitted log's end: filters start from "
        "its first row",
        step));
  }
  for (size_t k = 0; k < model.outputs.size(); ++k) {
    const OutputModel& m = model.outputs[k];
    p.outputs.push_back(m.output);
    const nlohmann::json* state =
        p.continued && !m.end_state.is_null() ? &m.end_state : nullptr;
    const Eigen::MatrixXd f = ComputeFeatures(ts, m.regressors, state);
    Eigen::VectorXd y = Eigen::VectorXd::Constant(f.rows(), m.intercept_um);
    if (m.coef.size() > 0) y += f * m.coef;
    p.values_um.col(static_cast<Eigen::Index>(k)) = y;
  }
  p.warnings.insert(p.warnings.end(), ts.warnings.begin(), ts.warnings.end());
  return p;
}

nlohmann::json ModelToJson(const ThermalModel& model) {
  nlohmann::json j;
  j["thermal_model"] = 1;
  j["fitted_log"] = model.source;
  j["fit_t_begin_s"] = model.fit_t_begin_s;
  j["fit_t_end_s"] = model.fit_t_end_s;
  j["median_step_s"] = model.median_step_s;
  j["inputs"] = model.inputs;
  const FitOptions& o = model.options;
  j["options"] = {{"model", o.model},
                  {"taus_s", o.taus_s},
                  {"temperature_lag_s", o.temperature_lag_s},
                  {"fir_step_s", o.fir_step_s},
                  {"fir_taps", o.fir_taps},
                  {"max_terms", o.max_terms},
                  {"cv_blocks", o.cv_blocks},
                  {"cv_first_validation_block", o.cv_first_validation_block},
                  {"ridge", o.ridge},
                  {"criterion", o.criterion},
                  {"min_gain", o.min_gain},
                  {"weight_half_life_s", o.weight_half_life_s}};
  nlohmann::json outs = nlohmann::json::array();
  for (const auto& m : model.outputs) {
    nlohmann::json regs = nlohmann::json::array();
    for (Eigen::Index k = 0; k < m.coef.size(); ++k) {
      nlohmann::json r = m.regressors[k].ToJson();
      r["coef_um"] = m.coef(k);
      r["mean"] = m.mean(k);
      r["scale"] = m.scale(k);
      regs.push_back(r);
    }
    outs.push_back(
        {{"output", m.output},
         {"structure", StructureName(m.structure)},
         {"intercept_um", m.intercept_um},
         {"regressors", regs},
         {"ridge", m.ridge},
         {"score", m.cv_score},
         {"cv_rms_um", std::isfinite(m.cv_rms_um) ? nlohmann::json(m.cv_rms_um)
                                                  : nlohmann::json()},
         {"fit_rms_um", m.fit_rms_um},
         {"n_fit", m.n_fit},
         {"selection", m.selection_log},
         {"end_state", m.end_state}});
  }
  j["outputs"] = outs;
  return j;
}

ThermalModel ModelFromJson(const nlohmann::json& j, const std::string& source) {
  ThermalModel model;
  try {
    if (j.value("thermal_model", 0) != 1)
      throw InputError(source, 0, "thermal_model",
                       "not a thermal model file (version 1)");
    model.source = j.value("fitted_log", "");
    model.fit_t_begin_s = j.at("fit_t_begin_s").get<double>();
    model.fit_t_end_s = j.at("fit_t_end_s").get<double>();
    model.median_step_s = j.at("median_step_s").get<double>();
    model.inputs = j.at("inputs").get<std::vector<std::string>>();
    const auto& o = j.at("options");
    model.options.model = o.value("model", "auto");
    model.options.taus_s = o.value("taus_s", model.options.taus_s);
    model.options.temperature_lag_s =
        o.value("temperature_lag_s", model.options.temperature_lag_s);
    model.options.criterion = o.value("criterion", "cv");
    model.options.weight_half_life_s = o.value("weight_half_life_s", 0.0);
    for (const auto& oj : j.at("outputs")) {
      OutputModel m;
      m.output = oj.at("output").get<std::string>();
      if (!ParseStructure(oj.at("structure").get<std::string>(), &m.structure))
        throw InputError(source, 0, "structure", "unknown structure");
      m.intercept_um = oj.at("intercept_um").get<double>();
      const auto& regs = oj.at("regressors");
      const Eigen::Index k = static_cast<Eigen::Index>(regs.size());
      m.coef.resize(k);
      m.mean.resize(k);
      m.scale.resize(k);
      for (Eigen::Index r = 0; r < k; ++r) {
        m.regressors.push_back(Regressor::FromJson(regs[r], source));
        m.coef(r) = regs[r].at("coef_um").get<double>();
        m.mean(r) = regs[r].value("mean", 0.0);
        m.scale(r) = regs[r].value("scale", 1.0);
        if (std::find(model.inputs.begin(), model.inputs.end(),
                      m.regressors.back().input) == model.inputs.end())
          throw InputError(
              source, 0, "inputs",
              m.regressors.back().input + " is used but not listed");
      }
      m.ridge = oj.value("ridge", 0.0);
      m.cv_score = oj.value("score", 0.0);
      m.fit_rms_um = oj.value("fit_rms_um", 0.0);
      m.n_fit = oj.value("n_fit", 0);
      m.end_state = oj.value("end_state", nlohmann::json());
      if (!m.end_state.is_null()) {
        FeatureBank probe(m.regressors, model.inputs, source);
        probe.SetState(m.end_state);  // throws when it does not match
      }
      model.outputs.push_back(std::move(m));
    }
  } catch (const nlohmann::json::exception& e) {
    throw InputError(source, 0, "", std::string("bad model file: ") + e.what());
  }
  return model;
}

}  // namespace ttp::models
