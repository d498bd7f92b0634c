#include "ttp/models/identify.h"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <exception>
#include <optional>
#include <set>

#include "ttp/geometry/constants.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/limits.h"

namespace ttp::models {
namespace {

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
  // WLSE: a half-life short against the span leaves only the newest
  // samples with weight; below 10 effective samples nothing can be fitted.
  const double effective = d.w.sum() * d.w.sum() / d.w.squaredNorm();
  if (!(effective >= 10)) {
    throw InputError(
        fit.source, 0, "--weight-half-life-s",
        fmt::format("a half-life of {:g} s leaves {:.1f} effective samples "
                    "of {} in the fitted span of {:g} s for {} (at least 10 "
                    "needed): give a longer half-life",
                    o.weight_half_life_s, effective, n, t1 - t0,
                    fit.output_names[output]));
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
  std::vector<Eigen::MatrixXd> valid(o.cv_blocks, Eigen::MatrixXd::Zero(m, m));
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
    valid[b].noalias() = x.transpose() * x;
    wblock[b].noalias() = x.transpose() * w.asDiagonal() * x;
  }
  g.train.assign(o.cv_blocks + 1, Eigen::MatrixXd::Zero(m, m));
  for (int b = 0; b < o.cv_blocks; ++b) g.train[b + 1] = g.train[b] + wblock[b];
  g.all = g.train[o.cv_blocks];
  g.after.assign(o.cv_blocks + 1, Eigen::MatrixXd::Zero(m, m));
  for (int b = o.cv_blocks - 1; b >= 0; --b)
    g.after[b] = g.after[b + 1] + valid[b];
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

// A fold is scored only when at least this many measured values lie
// before it: an intercept and a penalised slope, and one value to spare.
constexpr double kMinFoldRows = 3;

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
  // Without a ridge, a fit needs more values than parameters; with one, the
  // penalty determines what the values do not (outputs measured every 30
  // min leave fewer values before a fold than the joint model's 42
  // regressors). Which folds count does not depend on lambda, so every
  // ridge value is scored on the same folds.
  const double parameters = static_cast<double>(idx.size());
  const bool unpenalised = !(lambda > 0);
  if (unpenalised && g.n < parameters + 1) return s;
  bool cv_determined = true;
  for (int k = o.cv_first_validation_block; k < o.cv_blocks; ++k) {
    const Eigen::MatrixXd& v = g.after[k];
    const double nv = v(0, 0);
    if (nv <= 0) continue;
    const double rows_before = g.after[0](0, 0) - nv;  // unweighted
    if (rows_before < kMinFoldRows) continue;
    if ((unpenalised && rows_before < parameters + 1) ||
        !Solve(g.train[k], idx, lambda, &theta)) {
      cv_determined = false;
      break;
    }
    const double fold = Sse(v, idx, theta);
    sse += fold;
    count += nv;
  }
  if (cv_determined && count > 0) s.cv_rms = std::sqrt(sse / count);
  if (!Solve(g.all, idx, lambda, &theta)) return s;
  // In-sample RMS unweighted: the unweighted Gram of every block, read on
  // the chosen regressors only.
  const Eigen::MatrixXd& u = g.after[0];
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
                   const TimeSeries& fit, int output, Structure structure,
                   const FitOptions& o) {
  std::vector<int> idx = {0};
  for (int c : chosen) idx.push_back(c + 1);
  if (!std::isfinite(score.score)) {
    throw InputError(
        fit.source, 0, fit.output_names[output],
        fmt::format(
            "{} measured values: the chronological CV scores no ridge value "
            "of the grid for {} regressors ({} blocks, validation from block "
            "{}: a fold needs {} values before it, and a ridge of 0 more "
            "values than parameters); give more measured values or ridge "
            "values above 0",
            g.n, idx.size() - 1, o.cv_blocks, o.cv_first_validation_block,
            kMinFoldRows));
  }
  const std::string& output_name = fit.output_names[output];
  Eigen::VectorXd theta;
  if (!Solve(g.all, idx, score.lambda, &theta)) {
    throw std::runtime_error("least-squares solve failed for " + output_name);
  }
  OutputModel m;
  m.output = output_name;
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

// The upper median (the middle value; of two, the larger), of a non-empty
// list.
double UpperMedian(std::vector<double> v) {
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
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
  if (model != "auto" && model != "select" && !ParseStructure(model, &s))
    return fail("model: '" + model +
                "' is not auto, select, static, fir, lag, arx, combined or "
                "joint");
  if (taus_s.empty()) return fail("taus_s: at least one time constant");
  for (double t : taus_s)
    if (!(t > 0)) return fail("taus_s: time constants must be > 0");
  // (a lag beyond any log's time is no lag a log can show)
  if (!(temperature_lag_s > 0 && temperature_lag_s <= limits::kMaxLogTimeS))
    return fail("temperature_lag_s: must be > 0 and at most 1e9 s");
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
    best = Finish(d, g, pool.regs, sel.chosen, sel.score, fit, output,
                  structure, o);
    best.selection_log = sel.log;
    if (structure == Structure::kArx)
      best.selection_log.insert(best.selection_log.begin(), pool.label);
    have = true;
  }
  return best;
}

namespace {

// Block boundaries of the chronological CV over the rows where `output` is
// measured (as PrepareData assigns them): fold k trains on t < bound[k].
std::vector<double> CvBounds(const TimeSeries& fit, int output,
                             const FitOptions& o) {
  double t0 = kNaN, t1 = kNaN;
  for (size_t i = 0; i < fit.rows(); ++i)
    if (std::isfinite(fit.outputs_um(static_cast<Eigen::Index>(i), output))) {
      if (!std::isfinite(t0)) t0 = fit.t_s[i];
      t1 = fit.t_s[i];
    }
  std::vector<double> b;
  for (int k = 0; k <= o.cv_blocks; ++k)
    b.push_back(t0 + (t1 - t0) * k / o.cv_blocks);
  return b;
}

// Nested chronological CV of a forward-selected structure: in fold k the
// whole selection (regressors, ridge, poles) is redone on blocks [0, k)
// alone, with its own inner CV, and the result predicts blocks k.. from
// the inputs. A selection scored on the very folds that chose it would
// look better than it is; this score does not see the validated blocks.
double NestedCvRms(const TimeSeries& fit, int output, Structure s,
                   const FitOptions& o) {
  const std::vector<double> bound = CvBounds(fit, output, o);
  double sse = 0, count = 0;
  for (int k = o.cv_first_validation_block; k < o.cv_blocks; ++k) {
    const TimeSeries head = HeadOf(fit, bound[k]);
    OutputModel m;
    try {
      m = FitOutput(head, output, s, o);
    } catch (const InputError&) {
      continue;  // too few rows before this fold
    }
    const Eigen::VectorXd p = PredictOutput(m, fit);
    for (size_t i = 0; i < fit.rows(); ++i) {
      const double y = fit.outputs_um(static_cast<Eigen::Index>(i), output);
      if (!std::isfinite(y) || fit.t_s[i] < bound[k]) continue;
      const double r = y - p(static_cast<Eigen::Index>(i));
      sse += r * r;
      count += 1;
    }
  }
  return count > 0 ? std::sqrt(sse / count) : kNaN;
}

}  // namespace

std::vector<Regressor> AllTemperatureRegressors(const TimeSeries& ts) {
  std::vector<Regressor> out;
  for (const auto& name : ts.input_names)
    if (!IsSpeed(name)) out.push_back({name, 1, 0, {}});
  return out;
}

std::vector<Regressor> SpeedLagRegressors(const TimeSeries& ts,
                                          const std::vector<double>& taus_s) {
  std::vector<Regressor> out;
  for (const auto& name : ts.input_names)
    if (IsSpeed(name))
      for (double tau : taus_s) {
        out.push_back({name, 1, 0, {tau}});
        out.push_back({name, 2, 0, {tau}});
      }
  return out;
}

OutputModel FitAuto(const TimeSeries& fit, int output, const FitOptions& o) {
  CheckOptions(o);
  struct Candidate {
    std::string label;
    OutputModel model;
    double score = std::numeric_limits<double>::infinity();
    double cv_rms = kNaN;
  };
  std::vector<Candidate> cands;
  std::exception_ptr first_error;
  const int n_rows = [&] {
    int n = 0;
    for (Eigen::Index i = 0; i < fit.outputs_um.rows(); ++i)
      if (std::isfinite(fit.outputs_um(i, output))) ++n;
    return n;
  }();
  auto mdl = [&](size_t p) {
    const double n = std::max(2, n_rows);
    return 1.0 + static_cast<double>(p) * std::log(n) / n;
  };
  auto fixed = [&](const std::string& label, std::vector<Regressor> regs,
                   Structure s) {
    if (regs.empty()) return;
    Candidate c;
    c.label = label;
    try {
      c.model = FitFixed(fit, output, regs, s, o);
    } catch (const InputError&) {
      // Too few measured values for this many regressors: the smaller
      // candidates may still be scored; if none is, the first error says
      // why.
      if (!first_error) first_error = std::current_exception();
      return;
    }
    c.score = c.model.cv_score;
    c.cv_rms = c.model.cv_rms_um;
    cands.push_back(std::move(c));
  };
  const std::vector<Regressor> temps = AllTemperatureRegressors(fit);
  const std::vector<Regressor> speed = SpeedLagRegressors(fit, o.taus_s);
  // Fixed regressor sets: only the ridge (and the temperature lag) is tuned,
  // so their CV score is close to honest.
  fixed("static on all temperatures", temps, Structure::kStatic);
  fixed("lags of n and n^2 (every time constant)", speed, Structure::kLag);
  {
    std::vector<Regressor> r = temps;
    r.insert(r.end(), speed.begin(), speed.end());
    fixed("all temperatures + lags of n and n^2", r, Structure::kCombined);
  }
  if (!temps.empty())
    for (double tau : o.taus_s) {
      FitOptions oj = o;
      oj.temperature_lag_s = tau;
      fixed(fmt::format("joint, temperature lag {:g} s", tau),
            JointRegressors(fit, oj), Structure::kJoint);
    }
  // Forward-selected structures, scored by nested CV.
  if (o.auto_selected)
    for (Structure s : {Structure::kStatic, Structure::kFir, Structure::kLag,
                        Structure::kArx, Structure::kCombined}) {
      Candidate c;
      c.label = std::string(StructureName(s)) + " (forward-selected)";
      try {
        c.model = FitOutput(fit, output, s, o);
      } catch (const InputError&) {
        if (!first_error) first_error = std::current_exception();
        continue;
      }
      c.cv_rms = NestedCvRms(fit, output, s, o);
      if (!std::isfinite(c.cv_rms)) continue;
      const double base = o.criterion == "mdl" ? c.model.fit_rms_um : c.cv_rms;
      c.score = base * mdl(c.model.regressors.size());
      cands.push_back(std::move(c));
    }
  if (cands.empty() && first_error) std::rethrow_exception(first_error);
  if (cands.empty())
    throw InputError(fit.source, 0, fit.output_names[output],
                     "no model structure applies to the log's inputs");
  size_t best = 0;
  for (size_t k = 1; k < cands.size(); ++k)
    if (cands[k].score < cands[best].score) best = k;
  OutputModel m = cands[best].model;
  m.cv_score = cands[best].score;
  m.cv_rms_um = cands[best].cv_rms;
  m.label = cands[best].label;
  std::vector<std::string> log;
  for (size_t k = 0; k < cands.size(); ++k)
    log.push_back(fmt::format("{} {}: score {:.4g}, CV RMS {:.3f} um",
                              k == best ? "*" : " ", cands[k].label,
                              cands[k].score, cands[k].cv_rms));
  log.push_back("chosen: " + m.label + " -- its own steps:");
  log.insert(log.end(), m.selection_log.begin(), m.selection_log.end());
  m.selection_log = log;
  return m;
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
  return Finish(d, g, regressors, chosen, s, fit, output, structure, o);
}

namespace {
std::vector<InputRange> InputRanges(const TimeSeries& ts);

// The rule for a sensor that jumps (identify.h: FittedJump).
constexpr double kJumpMinK = 0.3;           // as PredictOptions::jump_min
constexpr double kJumpMedianFactor = 20.0;  // times the median |step|
constexpr double kJumpWindowS = 600.0;      // level before / after, gaps
// A speed step larger than this share of the speed's range is the
// program's (the machine changes state there).
constexpr double kSpeedChangeShare = 0.05;

bool IsTemperature(const std::string& name) { return name.rfind("T_", 0) == 0; }

double MedianOfRange(const Eigen::VectorXd& x, size_t from, size_t to) {
  return UpperMedian(std::vector<double>(x.data() + from, x.data() + to));
}

// Rows within `w` rows of a gap or of a speed change.
std::vector<char> RowsNearStateChanges(const TimeSeries& ts, size_t w) {
  const size_t n = ts.rows();
  std::vector<char> near(n, 0);
  auto mark = [&](size_t i) {
    const size_t a = i > w ? i - w : 0, b = std::min(n, i + w + 1);
    std::fill(near.begin() + static_cast<std::ptrdiff_t>(a),
              near.begin() + static_cast<std::ptrdiff_t>(b), 1);
  };
  for (size_t g : ts.gap_rows)
    if (g < n) mark(g);
  for (size_t j = 0; j < ts.input_names.size(); ++j) {
    if (!IsSpeed(ts.input_names[j])) continue;
    const auto col = ts.inputs.col(static_cast<Eigen::Index>(j));
    const double range = col.maxCoeff() - col.minCoeff();
    for (Eigen::Index i = 1; i < col.size(); ++i)
      if (std::abs(col(i) - col(i - 1)) > kSpeedChangeShare * range)
        mark(static_cast<size_t>(i));
  }
  return near;
}

}  // namespace

std::vector<FittedJump> FindFittedJumps(const TimeSeries& span) {
  std::vector<FittedJump> out;
  const size_t n = span.rows();
  const double dt = MedianStepS(span);
  if (n < 8 || !(dt > 0)) return out;
  const size_t w =
      std::max<size_t>(4, static_cast<size_t>(std::lround(kJumpWindowS / dt)));
  if (n < 2 * w + 1) return out;
  const std::vector<char> near = RowsNearStateChanges(span, w);
  for (size_t j = 0; j < span.input_names.size(); ++j) {
    if (!IsTemperature(span.input_names[j])) continue;
    Eigen::VectorXd x = span.inputs.col(static_cast<Eigen::Index>(j));
    std::vector<double> steps;
    steps.reserve(n);
    for (size_t i = 1; i < n; ++i) steps.push_back(std::abs(x(i) - x(i - 1)));
    // A sensor read to 0.1 K has a median step of 0: the floor keeps the
    // factor meaningful, kJumpMinK decides there.
    const double limit =
        std::max(kJumpMinK, kJumpMedianFactor *
                                std::max(UpperMedian(std::move(steps)), 1e-3));
    for (size_t i = w; i + w <= n; ++i) {
      const double step = x(i) - x(i - 1);
      if (std::abs(step) < limit || near[i]) continue;
      const double level =
          MedianOfRange(x, i, i + w) - MedianOfRange(x, i - w, i);
      if (level * step <= 0 || std::abs(level) < 0.5 * std::abs(step) ||
          std::abs(level) > 2.0 * std::abs(step))
        continue;
      // The row's step less the sensor's own change over one row there
      // (the median step around it): the fault alone.
      std::vector<double> around;
      for (size_t q = i - w + 1; q < i + w; ++q)
        if (q != i) around.push_back(x(q) - x(q - 1));
      const double fault = step - UpperMedian(std::move(around));
      out.push_back({span.input_names[j], span.t_s[i], fault});
      x.tail(static_cast<Eigen::Index>(n - i)).array() -= fault;
    }
  }
  return out;
}

size_t ShiftJumps(const std::vector<FittedJump>& jumps, double t_offset_s,
                  TimeSeries* ts) {
  size_t shifted = 0;
  for (const auto& jmp : jumps) {
    const int j = ts->InputIndex(jmp.input);
    if (j < 0) continue;
    for (size_t i = 0; i < ts->rows(); ++i) {
      // 1 ms: the two logs' start headers place the rows in one time up to
      // rounding; rows are seconds apart.
      if (ts->t_s[i] + t_offset_s < jmp.t_s - 1e-3) continue;
      ts->inputs(static_cast<Eigen::Index>(i), j) -= jmp.step;
      ++shifted;
    }
  }
  return shifted;
}

SensorFaults RepairSensorFaults(const TimeSeries& span, bool repair,
                                TimeSeries* series) {
  SensorFaults f;
  f.jumps = FindFittedJumps(span);
  for (const auto& jmp : f.jumps)
    f.warnings.push_back(fmt::format(
        "{} jumps by {:+.2f} K at t = {:g} s in the fitted span and stays "
        "shifted: a sensor fault (re-seated or re-connected), not the "
        "machine; {}",
        jmp.input, jmp.step, jmp.t_s,
        repair ? "its values from there on are shifted back by the step, in "
                 "the fit and in every prediction after that time"
               : "not repaired (--keep-jumps): the model learns the step"));
  if (repair) ShiftJumps(f.jumps, 0.0, series);
  return f;
}

ThermalModel FitThermalModel(const TimeSeries& ts,
                             const std::vector<std::string>& outputs,
                             const FitOptions& o, double fit_until_s) {
  CheckOptions(o);
  TimeSeries fit = HeadOf(ts, fit_until_s);
  if (fit.rows() < 10)
    throw InputError(ts.source, 0, "t_s",
                     "fewer than 10 rows in the fitted span");
  // Found before anything is fitted: every structure, the input ranges and
  // the filters' end state see the sensor as it would have read.
  SensorFaults faults = RepairSensorFaults(fit, o.repair_jumps, &fit);
  std::vector<int> which;
  std::vector<std::string> unmeasured;
  if (outputs.empty()) {
    // Every output the fitted span measures; one it never measures (a
    // channel not connected) is left out and said, not a reason to refuse
    // the others. Named with --outputs, it is refused (PrepareData).
    for (size_t j = 0; j < fit.output_names.size(); ++j) {
      if (fit.outputs_um.col(static_cast<Eigen::Index>(j))
              .array()
              .isFinite()
              .any())
        which.push_back(static_cast<int>(j));
      else
        unmeasured.push_back(fmt::format(
            "{} is never measured in the fitted span: no model for it",
            fit.output_names[j]));
    }
    if (which.empty() && !fit.output_names.empty())
      throw InputError(ts.source, 0, "d_*",
                       "no output column holds a measured value in the "
                       "fitted span");
  } else {
    for (const auto& name : outputs) {
      if (std::count(outputs.begin(), outputs.end(), name) > 1)
        throw InputError(ts.source, 0, name, "output asked for more than once");
      const int j = fit.OutputIndex(name);
      if (j < 0)
        throw InputError(
            ts.source, 0, name,
            fit.InputIndex(name) >= 0
                ? "is an input of the log (n_ or T_), not an output: "
                  "--outputs takes d_ columns"
                : "output column is not in the log");
      which.push_back(j);
    }
  }
  if (which.empty())
    throw InputError(ts.source, 0, "d_*", "the log has no output column");
  ThermalModel model;
  model.source = ts.source;
  model.options = o;
  if (o.repair_jumps) model.fitted_jumps = faults.jumps;
  model.fit_warnings = std::move(faults.warnings);
  model.fit_warnings.insert(model.fit_warnings.end(), unmeasured.begin(),
                            unmeasured.end());
  model.fit_t_begin_s = fit.t_s.front();
  model.fit_t_end_s = fit.t_s.back();
  if (StartEpochS(ts)) model.fit_start = ts.header.at("start");
  model.median_step_s = MedianStepS(fit);
  model.input_ranges = InputRanges(fit);
  std::set<std::string> needed;
  for (int j : which) {
    OutputModel best;
    if (o.model == "select") {
      best = FitAuto(fit, j, o);
    } else if (o.model == "auto") {
      best = FitOutput(fit, j, Structure::kJoint, o);
      best.label = fmt::format("joint, temperature lag {:g} s (auto)",
                               o.temperature_lag_s);
    } else {
      Structure s = Structure::kJoint;
      ParseStructure(o.model, &s);
      best = FitOutput(fit, j, s, o);
    }
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

bool PredictOptions::IsValid(std::string* error) const {
  if (!(jump_factor > 1)) {
    if (error) *error = "jump_factor: must be > 1";
    return false;
  }
  if (!(jump_min >= 0)) {
    if (error) *error = "jump_min: must be >= 0";
    return false;
  }
  return true;
}

namespace {

std::vector<InputRange> InputRanges(const TimeSeries& ts) {
  std::vector<char> gap(ts.rows(), 0);
  for (size_t g : ts.gap_rows)
    if (g < ts.rows()) gap[g] = 1;
  std::vector<InputRange> out;
  for (size_t j = 0; j < ts.input_names.size(); ++j) {
    InputRange r;
    r.input = ts.input_names[j];
    const auto col = ts.inputs.col(static_cast<Eigen::Index>(j));
    r.min = col.minCoeff();
    r.max = col.maxCoeff();
    for (Eigen::Index i = 1; i < col.size(); ++i)
      if (!gap[static_cast<size_t>(i)])
        r.max_step = std::max(r.max_step, std::abs(col(i) - col(i - 1)));
    out.push_back(r);
  }
  return out;
}

// Temperature sensors that jump (see SensorJump); with `repair`, the values
// from the jump on are shifted back by the step in `ts`.
std::vector<SensorJump> FindJumps(const ThermalModel& model, TimeSeries* ts,
                                  const PredictOptions& o) {
  std::vector<SensorJump> out;
  std::vector<char> gap(ts->rows(), 0);
  for (size_t g : ts->gap_rows)
    if (g < ts->rows()) gap[g] = 1;
  for (const auto& r : model.input_ranges) {
    if (IsSpeed(r.input)) continue;  // a speed may step: the program says so
    const int j = ts->InputIndex(r.input);
    if (j < 0) continue;
    const double limit = std::max(o.jump_min, o.jump_factor * r.max_step);
    for (Eigen::Index i = 1; i < ts->inputs.rows(); ++i) {
      if (gap[static_cast<size_t>(i)]) continue;
      const double step = ts->inputs(i, j) - ts->inputs(i - 1, j);
      if (std::abs(step) <= limit) continue;
      out.push_back(
          {r.input, ts->t_s[static_cast<size_t>(i)], step, o.repair_jumps});
      if (o.repair_jumps)
        ts->inputs.col(j).tail(ts->inputs.rows() - i).array() -= step;
    }
  }
  return out;
}

std::vector<Extrapolation> FindExtrapolations(const ThermalModel& model,
                                              const TimeSeries& ts) {
  std::vector<Extrapolation> out;
  for (const auto& r : model.input_ranges) {
    const int j = ts.InputIndex(r.input);
    if (j < 0 || ts.rows() == 0) continue;
    if (std::find(model.inputs.begin(), model.inputs.end(), r.input) ==
        model.inputs.end())
      continue;
    const auto col = ts.inputs.col(j);
    const double span = std::max(r.max - r.min, 1e-9);
    Extrapolation e;
    e.input = r.input;
    e.fitted_min = r.min;
    e.fitted_max = r.max;
    e.seen_min = col.minCoeff();
    e.seen_max = col.maxCoeff();
    // A tolerance of 2 % of the range: sensor noise at the range's edge is
    // not extrapolation.
    const double tol = 0.02 * span;
    int outside = 0;
    for (Eigen::Index i = 0; i < col.size(); ++i) {
      const double d = std::max(r.min - col(i), col(i) - r.max);
      if (d > tol) ++outside;
      e.excess = std::max(e.excess, d);
    }
    if (outside == 0) continue;
    e.share_outside = static_cast<double>(outside) / col.size();
    e.severe = e.excess > 0.1 * span;
    out.push_back(e);
  }
  return out;
}

}  // namespace

nlohmann::json PredictionSummaryJson(const Prediction& p) {
  nlohmann::json j;
  j["rows"] = p.t_s.size();
  j["continued"] = p.continued;
  nlohmann::json outs = nlohmann::json::array();
  for (size_t k = 0; k < p.outputs.size(); ++k)
    outs.push_back({{"output", p.outputs[k]},
                    {"cv_rms_um", std::isfinite(p.cv_rms_um[k])
                                      ? nlohmann::json(p.cv_rms_um[k])
                                      : nlohmann::json()}});
  j["outputs"] = outs;
  nlohmann::json ex = nlohmann::json::array();
  for (const auto& e : p.extrapolations)
    ex.push_back({{"input", e.input},
                  {"fitted_range", {e.fitted_min, e.fitted_max}},
                  {"seen_range", {e.seen_min, e.seen_max}},
                  {"share_outside", e.share_outside},
                  {"excess", e.excess},
                  {"severe", e.severe}});
  j["extrapolations"] = ex;
  nlohmann::json jumps = nlohmann::json::array();
  for (const auto& s : p.jumps)
    jumps.push_back({{"input", s.input},
                     {"t_s", s.t_s},
                     {"step", s.step},
                     {"repaired", s.repaired}});
  j["sensor_jumps"] = jumps;
  j["warnings"] = p.warnings;
  return j;
}

Prediction Predict(const ThermalModel& model, const TimeSeries& input_ts,
                   const PredictOptions& po) {
  std::string why;
  if (!po.IsValid(&why)) throw InputError("predict options", 0, "", why);
  for (const auto& name : model.inputs) {
    if (input_ts.InputIndex(name) < 0) {
      throw InputError(input_ts.source, 0, name,
                       "column needed by the model is missing from the log");
    }
  }
  if (input_ts.rows() == 0)
    throw InputError(input_ts.source, 0, "t_s", "the log has no data row");
  TimeSeries ts = input_ts;
  Prediction p;
  p.t_s = ts.t_s;
  // Both logs' `start` headers place them in one time (a continuation may
  // count its t_s from its own start); without them, t_s alone.
  const std::optional<double> fit_start =
      model.fit_start.empty() ? std::nullopt : Iso8601EpochS(model.fit_start);
  const std::optional<double> log_start = StartEpochS(ts);
  const bool absolute = fit_start && log_start;
  // A jump the fit shifted out stays in the sensor's later values.
  for (const auto& jmp : model.fitted_jumps)
    if (ShiftJumps({jmp}, absolute ? *log_start - *fit_start : 0.0, &ts) > 0)
      p.warnings.push_back(fmt::format(
          "{}: shifted back by {:+.2f} K from t = {:g} s of the fitted log "
          "on, as in the fit (a jump of the fitted span)",
          jmp.input, jmp.step, jmp.t_s));
  p.jumps = FindJumps(model, &ts, po);
  for (const auto& jmp : p.jumps)
    p.warnings.push_back(fmt::format(
        "{} jumps by {:+.2f} K at t = {:g} s (the fitted span's largest step "
        "was {:.3g} K): a sensor fault, not the machine; {}",
        jmp.input, jmp.step, jmp.t_s,
        [&] {
          for (const auto& r : model.input_ranges)
            if (r.input == jmp.input) return r.max_step;
          return 0.0;
        }(),
        jmp.repaired ? "its later values are shifted back by the step"
                     : "not repaired: the prediction follows the jump"));
  p.extrapolations = FindExtrapolations(model, ts);
  for (const auto& e : p.extrapolations)
    p.warnings.push_back(fmt::format(
        "{} leaves the fitted range {:.4g}..{:.4g} on {:.0f}% of the rows "
        "(seen {:.4g}..{:.4g}){}",
        e.input, e.fitted_min, e.fitted_max, 100 * e.share_outside, e.seen_min,
        e.seen_max,
        e.severe ? ": the model extrapolates, its CV RMS does not describe "
                   "those rows"
                 : ""));
  for (const auto& m : model.outputs) p.cv_rms_um.push_back(m.cv_rms_um);
  p.values_um.resize(static_cast<Eigen::Index>(ts.rows()),
                     static_cast<Eigen::Index>(model.outputs.size()));
  const double step = absolute ? (*log_start + ts.t_s.front()) -
                                     (*fit_start + model.fit_t_end_s)
                               : ts.t_s.front() - model.fit_t_end_s;
  p.continued = step > 0 && step <= kGapPeriods * model.median_step_s;
  // The filters' stored state is at the fitted log's t_s: a continuation
  // counted from its own start is read in that time.
  if (p.continued && absolute && *log_start != *fit_start)
    for (double& t : ts.t_s) t += *log_start - *fit_start;
  if (step > kGapPeriods * model.median_step_s) {
    p.warnings.push_back(fmt::format(
        "the log starts {:g} s after the fitted log's end{}: filters start in "
        "the steady state of its first row",
        step, absolute ? " (by the two logs' start headers)" : ""));
  } else if (step <= 0) {
    p.warnings.push_back(fmt::format(
        "the log starts {:g} s before the fitted log's end{}: it is not "
        "taken as its continuation; filters start in the steady state of "
        "its first row",
        -step, absolute ? " (by the two logs' start headers)" : ""));
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
  if (!model.fit_start.empty()) j["fit_start"] = model.fit_start;
  j["median_step_s"] = model.median_step_s;
  j["inputs"] = model.inputs;
  nlohmann::json ranges = nlohmann::json::array();
  for (const auto& r : model.input_ranges)
    ranges.push_back({{"input", r.input},
                      {"min", r.min},
                      {"max", r.max},
                      {"max_step", r.max_step}});
  j["input_ranges"] = ranges;
  nlohmann::json jumps = nlohmann::json::array();
  for (const auto& jmp : model.fitted_jumps)
    jumps.push_back(
        {{"input", jmp.input}, {"t_s", jmp.t_s}, {"step_k", jmp.step}});
  j["fitted_jumps"] = jumps;
  j["fit_warnings"] = model.fit_warnings;
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
                  {"weight_half_life_s", o.weight_half_life_s},
                  {"auto_selected", o.auto_selected},
                  {"repair_jumps", o.repair_jumps}};
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
         {"candidate", m.label},
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
    // Numbers read as double first: 3e106 does not fit an int.
    if (j.value("thermal_model", 0.0) != 1.0)
      throw InputError(source, 0, "thermal_model",
                       "not a thermal model file (version 1)");
    model.source = j.value("fitted_log", "");
    model.fit_t_begin_s = j.at("fit_t_begin_s").get<double>();
    model.fit_t_end_s = j.at("fit_t_end_s").get<double>();
    if (j.contains("fit_start")) {
      model.fit_start = j.at("fit_start").get<std::string>();
      if (const std::string why = Iso8601Problem(model.fit_start); !why.empty())
        throw InputError(source, 0, "fit_start",
                         fmt::format("'{}': {}", model.fit_start, why));
    }
    model.median_step_s = j.at("median_step_s").get<double>();
    model.inputs = j.at("inputs").get<std::vector<std::string>>();
    if (j.contains("input_ranges"))
      for (const auto& r : j.at("input_ranges"))
        model.input_ranges.push_back(
            {r.at("input").get<std::string>(), r.at("min").get<double>(),
             r.at("max").get<double>(), r.at("max_step").get<double>()});
    if (j.contains("fitted_jumps"))
      for (const auto& r : j.at("fitted_jumps")) {
        FittedJump jmp{r.at("input").get<std::string>(),
                       r.at("t_s").get<double>(), r.at("step_k").get<double>()};
        if (!std::isfinite(jmp.t_s) || !std::isfinite(jmp.step))
          throw InputError(source, 0, "fitted_jumps",
                           "t_s and step_k must be finite numbers");
        model.fitted_jumps.push_back(std::move(jmp));
      }
    if (j.contains("fit_warnings"))
      model.fit_warnings = j.at("fit_warnings").get<std::vector<std::string>>();
    const auto& o = j.at("options");
    model.options.model = o.value("model", "auto");
    model.options.taus_s = o.value("taus_s", model.options.taus_s);
    model.options.temperature_lag_s =
        o.value("temperature_lag_s", model.options.temperature_lag_s);
    model.options.criterion = o.value("criterion", "cv");
    model.options.weight_half_life_s = o.value("weight_half_life_s", 0.0);
    model.options.auto_selected = o.value("auto_selected", false);
    model.options.repair_jumps = o.value("repair_jumps", true);
    for (const auto& oj : j.at("outputs")) {
      OutputModel m;
      m.output = oj.at("output").get<std::string>();
      if (!ParseStructure(oj.at("structure").get<std::string>(), &m.structure))
        throw InputError(source, 0, "structure", "unknown structure");
      m.label = oj.value("candidate", "");
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
      if (oj.contains("cv_rms_um") && oj.at("cv_rms_um").is_number())
        m.cv_rms_um = oj.at("cv_rms_um").get<double>();
      const double n_fit = oj.value("n_fit", 0.0);
      m.n_fit = n_fit >= 0 && n_fit <= 1e9 ? static_cast<int>(n_fit) : 0;
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
