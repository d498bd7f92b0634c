#include "ttp/diagnosis/diagnose.h"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <numeric>
#include <optional>
#include <random>
#include <stdexcept>

#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/series.h"
#include "ttp/inspect/measurement.h"

namespace ttp::diagnosis {
namespace {

// Figure kinds 0..3 are the spec's figures; 4 is the piece's ovality per
// cycle, ((X1 + X2) - (Y1 + Y2)) / 4 of the facet distances against the
// reference facets: the combination the four facets of a cycle leave
// after E_X, E_Y and E_TTP. Every machine error the log records (a
// translation, a tilt, a radial growth) cancels in it, and so does every
// catalogue cause (a three-lobe pattern cancels between opposite facets):
// structure there is something no cause the toolkit knows.
constexpr int kFigureKinds = 5;
constexpr int kAngleGroup = 5;  // the facet angles' offset group
constexpr int kGroups = 6;
constexpr const char* kFigureNames[kFigureKinds] = {"E_X", "E_Y", "E_Z",
                                                    "E_TTP", "E_OV"};
constexpr double kInf = std::numeric_limits<double>::infinity();

double OvalityMm(const PartSpec& part, const FeatureResults& results,
                 int cycle, double* variance_mm2 = nullptr) {
  const int j = IndexForCycle(part, cycle), ref = part.reference_index;
  double value = 0, var = 0;
  for (Segment s : kSegments) {
    const double sign =
        s == Segment::kX1 || s == Segment::kX2 ? 0.25 : -0.25;
    for (int k : {j, ref}) {
      auto it = results.find(FeatureId::Facet(s, k));
      if (it == results.end() || !it->second.present ||
          !std::isfinite(it->second.d_mm))
        return std::numeric_limits<double>::quiet_NaN();
      value += (k == j ? sign : -sign) * it->second.d_mm;
      var += 0.0625 * it->second.var_d_mm2;
    }
  }
  if (variance_mm2) *variance_mm2 = var;
  return value;
}

double FigureValueMm(const CycleFigures& f, int kind) {
  switch (kind) {
    case 0:
      return f.e_x_mm;
    case 1:
      return f.e_y_mm;
    case 2:
      return f.e_z_mm;
    default:
      return f.e_ttp_mm;
  }
}
double FigureUncertaintyMm(const CycleFigures& f, int kind) {
  switch (kind) {
    case 0:
      return f.u_x_mm;
    case 1:
      return f.u_y_mm;
    case 2:
      return f.u_z_mm;
    default:
      return f.u_ttp_mm;
  }
}

double Rms(const std::vector<double>& v) {
  if (v.empty()) return 0;
  double s = 0;
  for (double x : v) s += x * x;
  return std::sqrt(s / v.size());
}

// A radial spring-back with `lobes` lobes, u(phi) = a cos(lobes phi) + b
// sin(lobes phi) (um), on the facets: each moves by u at its centre and
// turns about Z by -u'(phi)/R. The clamping distortion of the catalogue
// is the three-lobed one of the three bolts; other lobe counts (an oval
// from uneven clamping, four lobes) are effects outside the catalogue,
// used only as rivals of a name.
EffectDeltas LobeDeltas(int lobes, double a_um, double b_um,
                        const EffectContext& context) {
  EffectDeltas out;
  for (const CutState& s : context.cuts) {
    FeatureDelta d;
    if (s.is_facet) {
      const double c = std::cos(lobes * s.phi_w_rad),
                   sn = std::sin(lobes * s.phi_w_rad);
      d.d_mm = 1e-3 * (a_um * c + b_um * sn);
      d.angle_rad = -1e-3 * lobes * (-a_um * sn + b_um * c) / s.radius_mm;
    }
    out[s.id] = d;
  }
  return out;
}

// One column or base of a model over all observations (figures, then
// angles), in the observations' units.
using Column = Eigen::VectorXd;

Column Stack(const ObservationEffect& e) {
  Column c(e.figure_um.size() + e.angle_urad.size());
  for (size_t i = 0; i < e.figure_um.size(); ++i) c[i] = e.figure_um[i];
  for (size_t i = 0; i < e.angle_urad.size(); ++i)
    c[e.figure_um.size() + i] = e.angle_urad[i];
  return c;
}

// A candidate model: causes with, for c_axis_indexing, its harmonics.
struct ModelSpec {
  std::vector<Cause> causes;
  // The harmonics per turn of the C stop error (ascending, from 1..max):
  // a table's error is a sum of a few, not necessarily consecutive ones
  // (once from the encoder's eccentricity, four times from a bearing).
  std::vector<int> c_harmonics;
  // workpiece_expansion: the piece's temperature at the log's start free
  // (off the lagged table's by a term decaying with tau) instead of in
  // equilibrium with it.
  bool wp_initial_state = false;
  std::string Name() const {
    if (causes.empty()) return "none";
    std::vector<std::string> names;
    for (Cause c : causes) names.push_back(CauseName(c));
    std::sort(names.begin(), names.end());
    std::string s;
    for (const auto& n : names) s += (s.empty() ? "" : "+") + n;
    return s;
  }
};

// Columns of the linear causes on all observations, and the workpiece
// expansion's columns per time constant (cached).
class ColumnCache {
 public:
  ColumnCache(const Observations& obs, const EffectContext& context,
              const PartSpec& part, int max_harmonics)
      : obs_(obs), context_(context), part_(part), initial_context_(context) {
    // The table's history of a piece 1 K off its equilibrium at the log's
    // start: a unit step down at the first grid point.
    for (size_t i = 0; i < initial_context_.machine_dT_K.size(); ++i)
      initial_context_.machine_dT_K[i] = i == 0 ? 1.0 : 0.0;
    tool_wear_ = Stack(EffectOnObservations(Cause::kToolWear, {1.0}, obs,
                                            context, part));
    for (int k = 0; k < 2; ++k) {
      std::vector<double> p(2, 0.0);
      p[k] = 1.0;
      clamping_.push_back(Stack(EffectOnObservations(
          Cause::kClampingDistortion, p, obs, context, part)));
    }
    for (int k = 0; k < 2 * max_harmonics; ++k) {
      std::vector<double> p(2 * max_harmonics, 0.0);
      p[k] = 1.0;
      c_axis_.push_back(Stack(
          EffectOnObservations(Cause::kCAxisIndexing, p, obs, context, part)));
    }
    wp_base_ = Stack(EffectOnObservations(Cause::kWorkpieceExpansion,
                                          {1000.0, 0.0}, obs, context, part));
    observed_ = Column(obs.size());
    for (size_t i = 0; i < obs.figures(); ++i)
      observed_[i] = obs.figure_value_um[i];
    for (size_t i = 0; i < obs.angles(); ++i)
      observed_[obs.figures() + i] = obs.angle_value_urad[i];
  }
  const Column& ToolWear() const { return tool_wear_; }
  const std::vector<Column>& Clamping() const { return clamping_; }
  std::vector<Column> CAxis(const std::vector<int>& harmonics) const {
    std::vector<Column> out;
    for (int h : harmonics) {
      out.push_back(c_axis_[2 * (h - 1)]);
      out.push_back(c_axis_[2 * (h - 1) + 1]);
    }
    return out;
  }
  const Column& WorkpieceBase() const { return wp_base_; }
  // The machine of another run under this run's loads, on the rows of
  // each figure kind in `kinds` (E_X, E_Y, E_Z; zero on every other row):
  // per kind, the table's temperature change directly and through a
  // first-order lag tau_s at the cut, and the time in hours (the room, or a
  // start state of its own, the run's history does not show). Each minus
  // its value at the first cut (the reference cycle: every figure is a
  // difference to it). A column that is zero everywhere (a log whose E_R0T
  // never changes) is left out.
  std::vector<Column> OtherMachine(const std::vector<int>& kinds,
                                   double tau_s) const {
    std::vector<Column> out;
    if (context_.machine_dT_K.empty() || context_.cuts.empty()) return out;
    const std::vector<double> lagged =
        LagFilter(context_.machine_dT_K, context_.grid_step_s, tau_s);
    const auto values = [&](double t_s) {
      return std::array<double, 3>{
          InterpolateUniform(context_.machine_dT_K, context_.grid_t0_s,
                             context_.grid_step_s, t_s),
          InterpolateUniform(lagged, context_.grid_t0_s, context_.grid_step_s,
                             t_s),
          t_s / 3600.0};
    };
    const auto reference = values(context_.cuts.front().t_s);
    for (int g : kinds) {
      std::array<Column, 3> columns;
      columns.fill(Column::Zero(obs_.size()));
      for (size_t i = 0; i < obs_.figures(); ++i) {
        if (obs_.figure_kind[i] != g) continue;
        const auto v = values(obs_.figure_t_s[i]);
        for (size_t k = 0; k < v.size(); ++k)
          columns[k][i] = v[k] - reference[k];
      }
      for (Column& c : columns)
        if (c.squaredNorm() > 0) out.push_back(std::move(c));
    }
    return out;
  }
  // A spring-back of another lobe count than the bolts' three (a rival of
  // a name, never a cause): its cos and sin columns.
  std::vector<Column> Lobes(int lobes) const {
    return {Stack(DeltasOnObservations(LobeDeltas(lobes, 1.0, 0.0, context_),
                                       obs_, part_)),
            Stack(DeltasOnObservations(LobeDeltas(lobes, 0.0, 1.0, context_),
                                       obs_, part_))};
  }
  const Column& Observed() const { return observed_; }
  // The piece 1 K off its equilibrium with the (lagged) table at the
  // log's start, decaying with tau: a piece clamped warm or cold after
  // pre-machining, before the table's history the log holds.
  Column WorkpieceInitial(double tau_s) const {
    return Stack(EffectOnObservations(Cause::kWorkpieceExpansion, {tau_s, 1.0},
                                      obs_, initial_context_, part_)) -
           Stack(EffectOnObservations(Cause::kWorkpieceExpansion, {tau_s, 0.0},
                                      obs_, initial_context_, part_));
  }
  // Effect of gain 1 minus the base at tau.
  Column Workpiece(double tau_s) const {
    return Stack(EffectOnObservations(Cause::kWorkpieceExpansion,
                                      {tau_s, 1.0}, obs_, context_, part_)) -
           wp_base_;
  }

 private:
  const Observations& obs_;
  const EffectContext& context_;
  const PartSpec& part_;
  EffectContext initial_context_;
  Column tool_wear_, wp_base_, observed_;
  std::vector<Column> clamping_, c_axis_;
};

// The indicator of offset group g (a figure kind, or kAngleGroup) on
// every observation.
Column OffsetColumn(const Observations& obs, int g) {
  const size_t nf = obs.figures();
  Column c(obs.size());
  for (size_t i = 0; i < obs.size(); ++i)
    c[i] = (i < nf ? obs.figure_kind[i] : kAngleGroup) == g ? 1.0 : 0.0;
  return c;
}

// The columns of a model's causes on every observation (not whitened), in
// the order of its coefficients; `first` (when given) gets where each
// cause's columns start, and their count last.
std::vector<Column> CauseColumns(const ModelSpec& spec, double tau_s,
                                 const ColumnCache& cache,
                                 std::vector<int>* first = nullptr) {
  std::vector<Column> cols;
  for (Cause c : spec.causes) {
    if (first) first->push_back(static_cast<int>(cols.size()));
    switch (c) {
      case Cause::kWorkpieceExpansion:
        cols.push_back(cache.Workpiece(tau_s));
        if (spec.wp_initial_state)
          cols.push_back(cache.WorkpieceInitial(tau_s));
        break;
      case Cause::kToolWear:
        cols.push_back(cache.ToolWear());
        break;
      case Cause::kClampingDistortion:
        for (const Column& col : cache.Clamping()) cols.push_back(col);
        break;
      case Cause::kCAxisIndexing:
        for (const Column& col : cache.CAxis(spec.c_harmonics))
          cols.push_back(col);
        break;
      case Cause::kNone:
        break;
    }
  }
  if (first) first->push_back(static_cast<int>(cols.size()));
  return cols;
}

// Whether figure kind g carries a free offset: its reference cycle's
// variance is not known (Observations::figure_reference_var_um2).
bool FreeOffset(const Observations& obs, int g) {
  return g == kAngleGroup ||
         g >= static_cast<int>(obs.figure_reference_var_um2.size()) ||
         !std::isfinite(obs.figure_reference_var_um2[g]);
}

// The figures' covariance with the reference cycle's common part of each
// anchored kind added to every pair of its observations.
Eigen::MatrixXd AnchoredFigureCovariance(const Observations& obs) {
  Eigen::MatrixXd cov = obs.figure_covariance_um2;
  for (size_t i = 0; i < obs.figures(); ++i)
    for (size_t j = 0; j < obs.figures(); ++j) {
      const int g = obs.figure_kind[i];
      if (obs.figure_kind[j] == g && !FreeOffset(obs, g))
        cov(i, j) += obs.figure_reference_var_um2[g];
    }
  return cov;
}

// The generalised least-squares problem on a subset of the observations:
// rows whitened with the Cholesky factor of their covariance (with the
// reference cycle's common part), nuisance offsets for the angles and for
// figure kinds whose reference part is not known.
class Problem {
 public:
  Problem(const Observations& obs, const std::vector<bool>& use) : obs_(obs) {
    const int nf = static_cast<int>(obs.figures());
    for (int i = 0; i < static_cast<int>(obs.size()); ++i)
      if (use[i]) (i < nf ? fig_ : ang_).push_back(i);
    lf_ = Factor(AnchoredFigureCovariance(obs), fig_, 0);
    la_ = Factor(obs.angle_covariance_urad2, ang_, nf);
    bool kind_used[kGroups] = {};
    for (int i : fig_) kind_used[obs.figure_kind[i]] = true;
    if (!ang_.empty()) kind_used[kAngleGroup] = true;
    for (int g = 0; g < kGroups; ++g)
      if (kind_used[g] && FreeOffset(obs, g)) {
        nuisance_.push_back(Whiten(OffsetColumn(obs, g)));
        nuisance_kinds_.push_back(g);
      }
    Column y(obs.size());
    for (int i = 0; i < nf; ++i) y[i] = obs.figure_value_um[i];
    for (size_t i = 0; i < obs.angles(); ++i)
      y[nf + i] = obs.angle_value_urad[i];
    y_ = Whiten(y);
  }
  int Rows() const { return static_cast<int>(fig_.size() + ang_.size()); }
  // Figure kind (0..4) or kAngleGroup of each whitened row: the covariance
  // couples only rows of one kind, so whitened rows stay in their kind.
  std::vector<int> RowKinds() const {
    std::vector<int> out;
    for (int i : fig_) out.push_back(obs_.figure_kind[i]);
    for (size_t k = 0; k < ang_.size(); ++k) out.push_back(kAngleGroup);
    return out;
  }
  int Nuisance() const { return static_cast<int>(nuisance_.size()); }
  const std::vector<int>& NuisanceKinds() const { return nuisance_kinds_; }
  bool ok() const { return ok_; }
  const Observations& obs() const { return obs_; }

  Eigen::VectorXd Whiten(const Column& full) const {
    Eigen::VectorXd out(Rows());
    Eigen::VectorXd f(fig_.size()), a(ang_.size());
    for (size_t r = 0; r < fig_.size(); ++r) f[r] = full[fig_[r]];
    for (size_t r = 0; r < ang_.size(); ++r) a[r] = full[ang_[r]];
    if (f.size()) out.head(f.size()) = lf_.triangularView<Eigen::Lower>().solve(f);
    if (a.size()) out.tail(a.size()) = la_.triangularView<Eigen::Lower>().solve(a);
    return out;
  }

  struct Solution {
    bool ok = false;
    double chi2 = kInf;
    Eigen::VectorXd b;        // cause coefficients
    Eigen::MatrixXd cov;      // of b
    Eigen::MatrixXd cov_all;  // of b and the offsets (in that order)
    std::vector<double> offsets = std::vector<double>(kGroups, 0.0);
    Eigen::VectorXd residual;  // whitened
  };
  // y - base ~ sum_k b_k columns_k + offsets, all whitened.
  Solution Solve(const std::vector<Eigen::VectorXd>& columns,
                 const Eigen::VectorXd& base) const {
    const int nc = static_cast<int>(columns.size()), nn = Nuisance();
    Eigen::MatrixXd x(Rows(), nc + nn);
    for (int c = 0; c < nc; ++c) x.col(c) = columns[c];
    for (int g = 0; g < nn; ++g) x.col(nc + g) = nuisance_[g];
    const Eigen::VectorXd y = y_ - base;
    Solution s;
    const Eigen::MatrixXd n = x.transpose() * x;
    Eigen::LDLT<Eigen::MatrixXd> ldlt(n);
    if (ldlt.info() != Eigen::Success) return s;
    const Eigen::VectorXd beta = ldlt.solve(x.transpose() * y);
    if (!beta.allFinite()) return s;
    s.ok = true;
    s.residual = y - x * beta;
    s.chi2 = s.residual.squaredNorm();
    s.b = beta.head(nc);
    s.cov_all = ldlt.solve(Eigen::MatrixXd::Identity(nc + nn, nc + nn));
    s.cov = s.cov_all.topLeftCorner(nc, nc);
    for (int g = 0; g < nn; ++g) s.offsets[nuisance_kinds_[g]] = beta[nc + g];
    return s;
  }

 private:
  Eigen::MatrixXd Factor(const Eigen::MatrixXd& cov,
                         const std::vector<int>& rows, int first) {
    const int n = static_cast<int>(rows.size());
    Eigen::MatrixXd sub(n, n);
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b)
        sub(a, b) = cov(rows[a] - first, rows[b] - first);
    Eigen::LLT<Eigen::MatrixXd> llt(sub);
    if (llt.info() != Eigen::Success) {
      ok_ = false;
      Eigen::MatrixXd d = sub.diagonal().cwiseSqrt().asDiagonal();
      return d;
    }
    return llt.matrixL();
  }

  const Observations& obs_;
  std::vector<int> fig_, ang_;
  Eigen::MatrixXd lf_, la_;
  std::vector<Eigen::VectorXd> nuisance_;
  std::vector<int> nuisance_kinds_;
  Eigen::VectorXd y_;
  bool ok_ = true;
};

// A fitted candidate.
struct Fit {
  ModelSpec spec;
  bool ok = false;
  double chi2 = kInf;
  int parameters = 0;  // cause parameters + nuisance offsets
  std::vector<std::vector<double>> params;  // per cause
  std::vector<Eigen::MatrixXd> covariance;  // per cause
  std::vector<double> offsets = std::vector<double>(kGroups, 0.0);
  // The covariance of every coefficient (the causes' in the order of their
  // columns, a lag's time constant held, then the offsets of
  // `offset_kinds`): what the prediction's own uncertainty comes from.
  Eigen::MatrixXd covariance_all;
  std::vector<int> offset_kinds;
  std::string note;  // why the fit is no result (empty: it is one)
};

// The time constant a fit's columns are built at: its workpiece
// expansion's fitted lag, 0 without one.
double FittedTauS(const Fit& fit) {
  double tau_s = 0;
  for (size_t k = 0; k < fit.spec.causes.size(); ++k)
    if (fit.spec.causes[k] == Cause::kWorkpieceExpansion)
      tau_s = fit.params[k][0];
  return tau_s;
}

class Fitter {
 public:
  Fitter(const ColumnCache& cache, const Problem& problem,
         const DiagnosisOptions& options)
      : cache_(cache), problem_(problem), options_(options) {}

  Fit Run(const ModelSpec& spec) const {
    bool has_wp = false;
    for (Cause c : spec.causes) has_wp |= c == Cause::kWorkpieceExpansion;
    if (!has_wp) return Linear(spec, 0.0);
    // Profile over log tau: the grid, then golden-section refinement
    // between the best point's neighbours.
    const auto& grid = options_.tau_grid_s;
    int best = -1;
    Fit best_fit;
    for (int k = 0; k < static_cast<int>(grid.size()); ++k) {
      Fit f = Linear(spec, grid[k]);
      if (f.ok && f.chi2 < best_fit.chi2) {
        best_fit = f;
        best = k;
      }
    }
    if (best < 0) return best_fit;
    if (grid.size() >= 3) {
      double lo = std::log(grid[std::max(0, best - 1)]);
      double hi = std::log(grid[std::min<int>(grid.size() - 1, best + 1)]);
      const double g = (std::sqrt(5.0) - 1) / 2;
      double x1 = hi - g * (hi - lo), x2 = lo + g * (hi - lo);
      Fit f1 = Linear(spec, std::exp(x1)), f2 = Linear(spec, std::exp(x2));
      for (int it = 0; it < 14; ++it) {
        if (f1.chi2 < f2.chi2) {
          hi = x2;
          x2 = x1;
          f2 = f1;
          x1 = hi - g * (hi - lo);
          f1 = Linear(spec, std::exp(x1));
        } else {
          lo = x1;
          x1 = x2;
          f1 = f2;
          x2 = lo + g * (hi - lo);
          f2 = Linear(spec, std::exp(x2));
        }
      }
      for (const Fit* f : {&f1, &f2})
        if (f->ok && f->chi2 < best_fit.chi2) best_fit = *f;
    }
    // tau's uncertainty from the profile's curvature in log tau.
    for (size_t c = 0; c < spec.causes.size(); ++c) {
      if (spec.causes[c] != Cause::kWorkpieceExpansion || !best_fit.ok)
        continue;
      const double tau = best_fit.params[c][0], h = 0.05;
      const Fit lo = Linear(spec, tau * std::exp(-h)),
                hi = Linear(spec, tau * std::exp(h));
      const double d2 = (lo.chi2 - 2 * best_fit.chi2 + hi.chi2) / (h * h);
      best_fit.covariance[c](0, 0) =
          d2 > 0 ? tau * tau * 2.0 / d2 : tau * tau;
    }
    // A time constant at the end of the range searched is not a result: the
    // data want a lag outside it (or no lag-shaped effect at all).
    if (best == 0 || best == static_cast<int>(grid.size()) - 1) {
      for (size_t c = 0; c < spec.causes.size(); ++c)
        if (spec.causes[c] == Cause::kWorkpieceExpansion &&
            (best_fit.params[c][0] <= grid.front() * 1.2 ||
             best_fit.params[c][0] >= grid.back() / 1.2))
          best_fit.note = fmt::format(
              "tau_wp_s at the end of the range searched ({:.0f} s)",
              best_fit.params[c][0]);
    }
    // The piece's lag behind the machine is what the cause is (diagnosis.md
    // section 1): a time constant the data leave undetermined (its standard
    // uncertainty more than `max_tau_relative_uncertainty` of it: a lag
    // not told from none, or from one far longer) is no result either.
    for (size_t c = 0; c < spec.causes.size() && best_fit.note.empty(); ++c)
      if (spec.causes[c] == Cause::kWorkpieceExpansion && best_fit.ok) {
        const double tau = best_fit.params[c][0],
                     sd = std::sqrt(std::max(0.0, best_fit.covariance[c](0, 0)));
        if (sd > options_.max_tau_relative_uncertainty * tau)
          best_fit.note = fmt::format(
              "tau_wp_s not determined by the data ({:.0f} +- {:.0f} s)", tau,
              sd);
      }
    return best_fit;
  }

  // Every coefficient enters linearly once tau is fixed.
  // `extra`: further whitened columns fitted along (a structure test's
  // alternative); they add to chi2's fit but not to the parameters.
  // The model's whitened columns at tau (and its fixed part, `base`);
  // `first`: where each cause's columns start.
  void Columns(const ModelSpec& spec, double tau_s,
               std::vector<Eigen::VectorXd>* columns_out,
               Eigen::VectorXd* base_out, std::vector<int>* first_out) const {
    std::vector<Eigen::VectorXd>& columns = *columns_out;
    std::vector<int>& first = *first_out;
    Eigen::VectorXd& base = *base_out;
    base = Eigen::VectorXd::Zero(problem_.Rows());
    for (Cause c : spec.causes)
      if (c == Cause::kWorkpieceExpansion)
        base += problem_.Whiten(cache_.WorkpieceBase());
    for (const Column& col : CauseColumns(spec, tau_s, cache_, &first))
      columns.push_back(problem_.Whiten(col));
  }
  // A fitted model's whitened columns and base, at its fitted lag.
  void Columns(const Fit& fit, std::vector<Eigen::VectorXd>* columns_out,
               Eigen::VectorXd* base_out) const {
    std::vector<int> first;
    Columns(fit.spec, FittedTauS(fit), columns_out, base_out, &first);
  }

  Fit Linear(const ModelSpec& spec, double tau_s,
             const std::vector<Eigen::VectorXd>& extra = {}) const {
    Fit fit;
    fit.spec = spec;
    std::vector<Eigen::VectorXd> columns;
    std::vector<int> first;
    Eigen::VectorXd base;
    Columns(spec, tau_s, &columns, &base, &first);
    columns.insert(columns.end(), extra.begin(), extra.end());
    const Problem::Solution s = problem_.Solve(columns, base);
    if (!s.ok) return fit;
    fit.ok = true;
    fit.chi2 = s.chi2;
    fit.offsets = s.offsets;
    if (extra.empty()) {
      fit.covariance_all = s.cov_all;
      fit.offset_kinds = problem_.NuisanceKinds();
    }
    fit.parameters = static_cast<int>(columns.size() - extra.size()) +
                     problem_.Nuisance() + (tau_s > 0 ? 1 : 0);
    for (size_t k = 0; k < spec.causes.size(); ++k) {
      const int a = first[k], n = first[k + 1] - a;
      std::vector<double> p(s.b.data() + a, s.b.data() + a + n);
      Eigen::MatrixXd cov = s.cov.block(a, a, n, n);
      if (spec.causes[k] == Cause::kWorkpieceExpansion) {
        // [tau (its variance from the profile, below), gain, and the
        // initial state when it is free]
        p.insert(p.begin(), tau_s);
        Eigen::MatrixXd with_tau = Eigen::MatrixXd::Zero(n + 1, n + 1);
        with_tau.bottomRightCorner(n, n) = cov;
        cov = with_tau;
      }
      if (spec.causes[k] == Cause::kToolWear && p[0] < 0)
        fit.note = "wear_um_per_m < 0 (a cutter does not grow)";
      if (spec.causes[k] == Cause::kWorkpieceExpansion && p[1] < 0)
        fit.note =
            "gain_K_per_K < 0 (the piece does not cool while the machine "
            "warms)";
      fit.params.push_back(p);
      fit.covariance.push_back(cov);
    }
    return fit;
  }

 private:
  const ColumnCache& cache_;
  const Problem& problem_;
  const DiagnosisOptions& options_;
};

// The prediction of a fitted model on every observation: the causes'
// effects plus the nuisance offsets.
Column Prediction(const Fit& fit, const ColumnCache& cache,
                  const Observations& obs) {
  Column out = Column::Zero(obs.size());
  if (!fit.ok) return out;
  for (size_t k = 0; k < fit.spec.causes.size(); ++k) {
    const auto& p = fit.params[k];
    switch (fit.spec.causes[k]) {
      case Cause::kWorkpieceExpansion:
        out += cache.WorkpieceBase() + p[1] * cache.Workpiece(p[0]);
        if (fit.spec.wp_initial_state)
          out += p[2] * cache.WorkpieceInitial(p[0]);
        break;
      case Cause::kToolWear:
        out += p[0] * cache.ToolWear();
        break;
      case Cause::kClampingDistortion:
        out += p[0] * cache.Clamping()[0] + p[1] * cache.Clamping()[1];
        break;
      case Cause::kCAxisIndexing: {
        const auto cols = cache.CAxis(fit.spec.c_harmonics);
        for (size_t c = 0; c < cols.size(); ++c) out += p[c] * cols[c];
        break;
      }
      case Cause::kNone:
        break;
    }
  }
  const size_t nf = obs.figures();
  for (size_t i = 0; i < obs.size(); ++i)
    out[i] += fit.offsets[i < nf ? obs.figure_kind[i] : kAngleGroup];
  return out;
}

// The variance of a fitted model's prediction on every observation, from
// the covariance of its coefficients and offsets (a lag's time constant
// held at its value). Small where the data pin the cause down; large where
// the prediction extrapolates (a sum of C-axis harmonics beyond the angles
// it was fitted on, a lag past the cycles it saw).
Column PredictionVariance(const Fit& fit, const ColumnCache& cache,
                          const Observations& obs) {
  const int n = static_cast<int>(obs.size());
  if (!fit.ok || fit.covariance_all.rows() == 0) return Column::Zero(n);
  // (a workpiece expansion's columns at its fitted tau)
  std::vector<Column> cols = CauseColumns(fit.spec, FittedTauS(fit), cache);
  for (int g : fit.offset_kinds) cols.push_back(OffsetColumn(obs, g));
  const int p = static_cast<int>(cols.size());
  Eigen::MatrixXd g(n, p);
  for (int c = 0; c < p; ++c) g.col(c) = cols[c];
  return ((g * fit.covariance_all).array() * g.array())
      .rowwise()
      .sum()
      .matrix();
}

int part_cycles(const Observations& obs) {
  int m = 0;
  for (int c : obs.figure_cycle) m = std::max(m, c);
  return m;
}

double Bic(const Fit& f, int n) {
  return f.chi2 + f.parameters * std::log(static_cast<double>(std::max(n, 2)));
}

// A chi2 over k whitened residuals as a standard normal deviate
// (Wilson-Hilferty).
double ChiSquareDeviate(double chi2, int k) {
  return (std::cbrt(chi2 / k) - (1 - 2 / (9.0 * k))) / std::sqrt(2 / (9.0 * k));
}

// E_X, E_Y and E_Z pooled: their whitened chi2 as one standard normal
// deviate; -inf with fewer than three observations.
double MachinePooledZ(const Eigen::VectorXd& whitened_residual,
                      const std::vector<int>& row_kinds) {
  double chi2 = 0;
  int k = 0;
  for (size_t r = 0; r < row_kinds.size(); ++r)
    if (row_kinds[r] <= 2) {
      chi2 += whitened_residual[r] * whitened_residual[r];
      ++k;
    }
  return k < 3 ? -kInf : ChiSquareDeviate(chi2, k);
}

// E_X, E_Y and E_Z each alone as a chi2 deviate (-inf where fewer than
// three observations).
std::vector<double> MachineKindZ(const Eigen::VectorXd& whitened_residual,
                                 const std::vector<int>& row_kinds) {
  double chi2[3] = {};
  int count[3] = {};
  for (size_t r = 0; r < row_kinds.size(); ++r)
    if (row_kinds[r] <= 2) {
      chi2[row_kinds[r]] += whitened_residual[r] * whitened_residual[r];
      ++count[row_kinds[r]];
    }
  std::vector<double> z(3, -kInf);
  for (int g = 0; g < 3; ++g)
    if (count[g] >= 3) z[g] = ChiSquareDeviate(chi2[g], count[g]);
  return z;
}

// Every candidate fitted on one problem, and the decision on it.
struct Selection {
  std::vector<Fit> fits;  // [0] = none
  int chosen = 0;
  DiagnosisStatus status = DiagnosisStatus::kNone;
  double chi2_per_dof = 0;
  std::string reason;
  // The decision's statistics (what the thresholds are calibrated on).
  double best_evidence = -kInf;  // max over causes of none BIC - BIC
  double local_z = -kInf;        // largest per-group chi2 deviate
  int local_group = -1;
  double machine_z = -kInf;  // the same over E_X, E_Y, E_Z
  // E_X, E_Y and E_Z pooled: one deviate over their whitened chi2.
  double machine_pooled_z = -kInf;
  // The same with the best drift or step of one figure kind fitted along
  // (what an effect on one feature type leaves, not another machine).
  double machine_pooled_z_one_kind = -kInf;
  std::vector<double> machine_kind_z = std::vector<double>(3, -kInf);
  // The same pooled deviate with another run's machine fitted along
  // (DiagnosisReport::machine_pooled_z_other_machine).
  double machine_pooled_z_other_machine = kInf;
  double step_chi2 = 0;  // largest chi2 drop by a step in one figure kind
  int step_group = -1, step_from_cycle = 0;
  // BIC of the chosen cause minus the best step alternative's.
  double step_rival = -kInf;
  // The evidence threshold the chosen model was held to (against none).
  double threshold = 0;
  // Largest chi2 drop by a drift of one figure kind over the cycles, and
  // that drift over the cycles measured (um).
  double trend_chi2 = 0, trend_um = 0;
};

// A drift of one figure kind over the cycles (one feature type wearing or
// moving in a way no catalogue cause does: every cause moves several
// figures together or follows the machine's heat), fitted along with a
// model: the largest chi2 it explains, and in which kind.
struct TrendTest {
  double chi2_drop = 0;
  int group = -1;
  double drift_um = 0;  // over the cycles measured
  double machine_pooled_z = kInf;  // E_X, E_Y, E_Z pooled after the drift
};
TrendTest FigureTrend(const Fitter& fitter, const Fit& fit,
                      const Problem& problem) {
  TrendTest out;
  if (!fit.ok) return out;
  std::vector<Eigen::VectorXd> columns;
  Eigen::VectorXd base;
  fitter.Columns(fit, &columns, &base);
  const Observations& obs = problem.obs();
  const std::vector<int> kinds = problem.RowKinds();
  for (int g = 0; g < kFigureKinds; ++g) {
    if (std::count(kinds.begin(), kinds.end(), g) < 4) continue;
    Column trend = Column::Zero(obs.size()), level = Column::Zero(obs.size());
    for (size_t i = 0; i < obs.figures(); ++i)
      if (obs.figure_kind[i] == g) {
        trend[i] = obs.figure_cycle[i];
        level[i] = 1;
      }
    std::vector<Eigen::VectorXd> with_trend = columns;
    // A kind without a free offset gets the drift's own level: a drift
    // over the facets' positions (a pattern along the segment) passes
    // through zero at the reference facet, not at cycle 0.
    if (!FreeOffset(obs, g)) with_trend.push_back(problem.Whiten(level));
    with_trend.push_back(problem.Whiten(trend));
    const Problem::Solution with = problem.Solve(with_trend, base);
    if (with.ok && fit.chi2 - with.chi2 > out.chi2_drop) {
      out.chi2_drop = fit.chi2 - with.chi2;
      out.group = g;
      out.drift_um = with.b[with.b.size() - 1] * (part_cycles(obs) - 1);
      out.machine_pooled_z = MachinePooledZ(with.residual, kinds);
    }
  }
  return out;
}

// The C stop error's candidate harmonic sets: every set of up to
// kMaxCHarmonicTerms harmonics from 1..max_harmonics, ascending. A
// consecutive 1..K would make a table whose error is once and four times
// per turn pay for the twice and three times it does not have.
constexpr int kMaxCHarmonicTerms = 4;
std::vector<std::vector<int>> HarmonicSets(int max_harmonics) {
  std::vector<std::vector<int>> out;
  std::vector<int> set;
  const std::function<void(int)> extend = [&](int from) {
    for (int h = from; h <= max_harmonics; ++h) {
      set.push_back(h);
      out.push_back(set);
      if (static_cast<int>(set.size()) < kMaxCHarmonicTerms) extend(h + 1);
      set.pop_back();
    }
  };
  extend(1);
  return out;
}

// `tests`: false inside the held-out folds, where only the chosen model's
// prediction is used.
Selection Select(const ColumnCache& cache, const Problem& problem,
                 const DiagnosisOptions& options, bool tests = true) {
  const Fitter fitter(cache, problem, options);
  const int n = problem.Rows();
  Selection sel;
  sel.fits.push_back(fitter.Run(ModelSpec{}));
  // C-axis indexing: which harmonics, by evidence.
  Fit c_axis;
  double c_bic = kInf;
  for (const std::vector<int>& set : HarmonicSets(options.max_c_harmonics)) {
    const Fit f = fitter.Run(ModelSpec{{Cause::kCAxisIndexing}, set});
    if (f.ok && Bic(f, n) < c_bic) {
      c_bic = Bic(f, n);
      c_axis = f;
    }
  }
  const std::vector<int> harmonics =
      c_axis.ok ? c_axis.spec.c_harmonics : std::vector<int>{1};
  // Workpiece expansion: the piece's initial state free or in equilibrium,
  // by evidence (the free state costs a parameter) among the fits that are
  // a result (a free state that leaves the lag undetermined is none).
  Fit wp = fitter.Run(ModelSpec{{Cause::kWorkpieceExpansion}});
  {
    ModelSpec free_start{{Cause::kWorkpieceExpansion}};
    free_start.wp_initial_state = true;
    const Fit f = fitter.Run(free_start);
    // A result before no result, then the lower BIC.
    const auto rank = [n](const Fit& x) {
      return std::make_pair(!(x.ok && x.note.empty()), Bic(x, n));
    };
    if (f.ok && (!wp.ok || rank(f) < rank(wp))) wp = f;
  }
  const bool wp_initial_state = wp.ok && wp.spec.wp_initial_state;
  sel.fits.push_back(wp);
  sel.fits.push_back(fitter.Run(ModelSpec{{Cause::kToolWear}}));
  sel.fits.push_back(fitter.Run(ModelSpec{{Cause::kClampingDistortion}}));
  sel.fits.push_back(
      c_axis.ok ? c_axis : fitter.Run(ModelSpec{{Cause::kCAxisIndexing}, {1}}));
  const int singles = static_cast<int>(sel.fits.size());
  if (options.pairs) {
    const Cause all[4] = {Cause::kWorkpieceExpansion, Cause::kToolWear,
                          Cause::kClampingDistortion, Cause::kCAxisIndexing};
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b)
        sel.fits.push_back(fitter.Run(
            ModelSpec{{all[a], all[b]}, harmonics, wp_initial_state}));
  }
  // C indexing turns the facets and changes no distance: without measured
  // facet angles (a dial gauge) it cannot show, and its candidates are no
  // result.
  {
    const std::vector<int> row_kinds = problem.RowKinds();
    if (std::find(row_kinds.begin(), row_kinds.end(), kAngleGroup) ==
        row_kinds.end())
      for (Fit& f : sel.fits)
        if (std::find(f.spec.causes.begin(), f.spec.causes.end(),
                      Cause::kCAxisIndexing) != f.spec.causes.end())
          f.note = "no facet angles measured: c_axis_indexing shows only there";
  }
  // The evidence a model needs over the one it extends: the threshold of
  // the causes it adds (a cause seen only in the facet angles has its own,
  // DiagnosisOptions::angle_evidence_threshold).
  auto threshold_for = [&](const Fit& model, const Fit& reference) {
    double t = 0;
    for (Cause c : model.spec.causes)
      if (std::find(reference.spec.causes.begin(), reference.spec.causes.end(),
                    c) == reference.spec.causes.end())
        t = std::max(t, c == Cause::kCAxisIndexing
                            ? options.angle_evidence_threshold
                            : options.evidence_threshold);
    return t;
  };
  const double none_bic = Bic(sel.fits[0], n);
  // The single cause: the lowest BIC among those that beat the nominal
  // model by their threshold (the angle and figure channels are nearly
  // independent, so a cause seen in one stands on its own evidence).
  int chosen = 0;
  for (int k = 1; k < singles; ++k) {
    const Fit& f = sel.fits[k];
    if (!f.ok || !f.note.empty()) continue;
    if (Bic(f, n) >= none_bic - threshold_for(f, sel.fits[0])) continue;
    if (chosen == 0 || Bic(f, n) < Bic(sel.fits[chosen], n)) chosen = k;
  }
  // A pair: the best one, when it beats the single cause (or the nominal
  // model) by the threshold of what it adds.
  int best_pair = 0;
  for (int k = singles; k < static_cast<int>(sel.fits.size()); ++k) {
    const Fit& f = sel.fits[k];
    if (!f.ok || !f.note.empty()) continue;
    if (best_pair == 0 || Bic(f, n) < Bic(sel.fits[best_pair], n))
      best_pair = k;
  }
  if (best_pair > 0) {
    const Fit& reference = sel.fits[chosen];
    if (Bic(sel.fits[best_pair], n) <
        Bic(reference, n) - threshold_for(sel.fits[best_pair], reference))
      chosen = best_pair;
  }
  sel.chosen = chosen;
  sel.threshold = chosen > 0 ? threshold_for(sel.fits[chosen], sel.fits[0])
                             : options.evidence_threshold;
  if (!tests) return sel;
  const Fit& f = sel.fits[chosen];
  for (int k = 1; k < static_cast<int>(sel.fits.size()); ++k)
    if (sel.fits[k].ok && sel.fits[k].note.empty())
      sel.best_evidence =
          std::max(sel.best_evidence, none_bic - Bic(sel.fits[k], n));
  const int dof = std::max(1, n - f.parameters);
  sel.chi2_per_dof = f.chi2 / dof;
  const std::vector<int> kinds = problem.RowKinds();
  // Structure left in one figure kind (or the angles) that the global
  // chi2 dilutes: its whitened chi2 as a standard normal deviate
  // (Wilson-Hilferty).
  // The machine statistics (E_X, E_Y, E_Z pooled, each, their largest) of
  // one model's whitened residual.
  const auto set_machine = [&sel, &kinds](const Column& residual) {
    sel.machine_pooled_z = MachinePooledZ(residual, kinds);
    sel.machine_kind_z = MachineKindZ(residual, kinds);
    sel.machine_z =
        *std::max_element(sel.machine_kind_z.begin(), sel.machine_kind_z.end());
  };
  // The whitened observations, and what one model leaves of them.
  const Column observed = problem.Whiten(cache.Observed());
  const auto residual_of = [&](const Fit& fit) {
    return Column(observed -
                  problem.Whiten(Prediction(fit, cache, problem.obs())));
  };
  std::string local;
  {
    const Column residual = residual_of(f);
    double chi2[kGroups] = {};
    int count[kGroups] = {};
    for (size_t r = 0; r < kinds.size(); ++r) {
      chi2[kinds[r]] += residual[r] * residual[r];
      ++count[kinds[r]];
    }
    const char* names[kGroups] = {"E_X",   "E_Y",  "E_Z",
                                  "E_TTP", "E_OV", "facet angles"};
    set_machine(residual);
    for (int g = 0; g < kGroups; ++g) {
      if (count[g] < 3) continue;
      const double z = ChiSquareDeviate(chi2[g], count[g]);
      if (z > sel.local_z) {
        sel.local_z = z;
        sel.local_group = g;
      }
      if (z > options.local_z && local.empty())
        local = fmt::format(
            "{} keeps chi2 {:.1f} over {} observations ({:.1f} "
            "standard deviations, limit {:g})",
            names[g], chi2[g], count[g], z, options.local_z);
    }
  }
  // E_X, E_Y and E_Z as the nominal model leaves them, when that is closer
  // to the log than what the chosen cause leaves: they follow the
  // machine's location errors the log's R-tests measure, and a cause that
  // is wrong (an effect outside the catalogue taken for one) can move them
  // off a log they agree with. The machine statistics are those of the
  // model that fits E_X, E_Y and E_Z better, so that only a piece whose
  // machine errors disagree with the log under either is taken for
  // another run's.
  if (sel.chosen > 0 && sel.fits[0].ok) {
    const Column nominal = residual_of(sel.fits[0]);
    if (MachinePooledZ(nominal, kinds) < sel.machine_pooled_z)
      set_machine(nominal);
  }
  // A step in one figure kind from some cycle on, fitted along with the
  // chosen model: a cause that explains the data leaves nothing a step
  // explains better than chance (an effect that starts at one cycle, a
  // changed set-up, is no catalogue cause).
  double step_pooled_z = kInf, cycle_pooled_z = kInf;
  {
    const Observations& obs = problem.obs();
    int max_cycle = 0;
    for (size_t i = 0; i < obs.figures(); ++i)
      max_cycle = std::max(max_cycle, obs.figure_cycle[i]);
    std::vector<Eigen::VectorXd> columns;
    Eigen::VectorXd base;
    if (f.ok) fitter.Columns(f, &columns, &base);
    for (int g = 0; g < kFigureKinds && f.ok; ++g) {
      if (std::count(kinds.begin(), kinds.end(), g) < 4) continue;
      for (int from = 2; from <= max_cycle; ++from) {
        Column step = Column::Zero(obs.size());
        int on = 0;
        for (size_t i = 0; i < obs.figures(); ++i)
          if (obs.figure_kind[i] == g && obs.figure_cycle[i] >= from) {
            step[i] = 1;
            ++on;
          }
        if (on == 0) continue;
        std::vector<Eigen::VectorXd> with_step = columns;
        with_step.push_back(problem.Whiten(step));
        const Problem::Solution with = problem.Solve(with_step, base);
        if (!with.ok) continue;
        const double drop = f.chi2 - with.chi2;
        if (drop > sel.step_chi2) {
          sel.step_chi2 = drop;
          sel.step_group = g;
          sel.step_from_cycle = from;
          step_pooled_z = MachinePooledZ(with.residual, kinds);
        }
      }
    }
    // One cycle's figures off the rest, each freed along with every
    // candidate's fit (a gross error draws the chosen model to itself, a
    // pair where one cause fits the rest): a gross error in one measured
    // feature (a misread dial, a CMM glitch) or a defect of one cycle's cut
    // moves that cycle's E_X or E_Y (and E_TTP, E_OV) alone, one in the
    // reference cycle's features every cycle's alike (an offset per kind),
    // while another run's log misplaces the machine errors in every cycle
    // differently. The deviate of E_X, E_Y and E_Z after it counts the
    // freed parameters off its degrees of freedom.
    // Per cycle (0: the reference) the whitened columns it frees and how
    // many of them are E_X, E_Y or E_Z parameters; the same for every fit.
    struct Freed {
      std::vector<Eigen::VectorXd> columns;
      int machine = 0;
    };
    std::vector<Freed> freed(max_cycle + 1);
    for (int g = 0; g < kFigureKinds; ++g) {
      if (std::count(kinds.begin(), kinds.end(), g) == 0) continue;
      if (!FreeOffset(obs, g)) {
        freed[0].columns.push_back(problem.Whiten(OffsetColumn(obs, g)));
        if (g <= 2) ++freed[0].machine;
      }
      for (int cycle = 1; cycle <= max_cycle; ++cycle) {
        Column pulse = Column::Zero(obs.size());
        int on = 0;
        for (size_t i = 0; i < obs.figures(); ++i)
          if (obs.figure_kind[i] == g && obs.figure_cycle[i] == cycle) {
            pulse[i] = 1;
            ++on;
          }
        if (on == 0) continue;
        freed[cycle].columns.push_back(problem.Whiten(pulse));
        if (g <= 2) freed[cycle].machine += on;
      }
    }
    for (const Fit& fit : sel.fits) {
      if (!fit.ok) continue;
      std::vector<Eigen::VectorXd> fit_columns;
      Eigen::VectorXd fit_base;
      fitter.Columns(fit, &fit_columns, &fit_base);
      for (const Freed& cycle : freed) {
        if (cycle.machine == 0) continue;
        std::vector<Eigen::VectorXd> with_freed = fit_columns;
        with_freed.insert(with_freed.end(), cycle.columns.begin(),
                          cycle.columns.end());
        const Problem::Solution with = problem.Solve(with_freed, fit_base);
        if (!with.ok) continue;
        double chi2 = 0;
        int rows = -cycle.machine;
        for (size_t r = 0; r < kinds.size(); ++r)
          if (kinds[r] <= 2) {
            chi2 += with.residual[r] * with.residual[r];
            ++rows;
          }
        if (rows >= 3)
          cycle_pooled_z =
              std::min(cycle_pooled_z, ChiSquareDeviate(chi2, rows));
      }
    }
  }
  // Another run's machine: E_X, E_Y and E_Z each following the table's
  // temperature change of this run (its loads, as the log's R-tests show
  // them) directly and through one lag, and drifting in time, with gains
  // of their own (the thermal paths of a machine in another state, or
  // another machine, under the same program, in another room). What a
  // mismatched log leaves is smooth in time and such a machine explains
  // it; a piece-side effect that moves each cycle's features its own way
  // (a set-up or cutter change per cycle) is not explained by it, and is
  // no reason to refuse the log.
  {
    std::vector<int> machine_kinds;
    for (int g = 0; g < 3; ++g)
      if (std::count(kinds.begin(), kinds.end(), g) >= 3)
        machine_kinds.push_back(g);
    int machine_rows = 0;
    for (int k : kinds) machine_rows += k <= 2;
    const auto machine_chi2 = [&kinds](const Column& residual) {
      double chi2 = 0;
      for (size_t r = 0; r < kinds.size(); ++r)
        if (kinds[r] <= 2) chi2 += residual[r] * residual[r];
      return chi2;
    };
    // The machine's whitened columns per lag: the same for both fits.
    std::vector<std::vector<Eigen::VectorXd>> machine_columns;
    if (!machine_kinds.empty())
      for (double tau_s : options.other_machine_tau_s) {
        machine_columns.emplace_back();
        for (const Column& c : cache.OtherMachine(machine_kinds, tau_s))
          machine_columns.back().push_back(problem.Whiten(c));
      }
    for (const Fit* fit : std::initializer_list<const Fit*>{&f, &sel.fits[0]}) {
      if (!fit->ok) continue;
      std::vector<Eigen::VectorXd> fit_columns;
      Eigen::VectorXd fit_base;
      fitter.Columns(*fit, &fit_columns, &fit_base);
      for (const std::vector<Eigen::VectorXd>& machine : machine_columns) {
        std::vector<Eigen::VectorXd> with = fit_columns;
        with.insert(with.end(), machine.begin(), machine.end());
        const Problem::Solution solved = problem.Solve(with, fit_base);
        if (!solved.ok) continue;
        // Its columns and the lag chosen among those tried.
        const int rows = machine_rows - static_cast<int>(machine.size()) - 1;
        if (rows < 3) continue;
        sel.machine_pooled_z_other_machine =
            std::min(sel.machine_pooled_z_other_machine,
                     ChiSquareDeviate(machine_chi2(solved.residual), rows));
      }
    }
  }
  // The same step as an alternative to the chosen cause (the step's
  // height and the cycle it starts at are its two parameters): a cause
  // that explains the data no better than a step at some cycle is not
  // named.
  std::string rival;
  if (chosen > 0) {
    const Fit& none = sel.fits[0];
    double best_drop = 0;
    int best_g = -1, best_from = 0;
    const Observations& obs = problem.obs();
    for (int g = 0; g < kFigureKinds; ++g) {
      if (std::count(kinds.begin(), kinds.end(), g) < 4) continue;
      for (int from = 2; from <= part_cycles(obs); ++from) {
        Column step = Column::Zero(obs.size());
        for (size_t i = 0; i < obs.figures(); ++i)
          if (obs.figure_kind[i] == g && obs.figure_cycle[i] >= from)
            step[i] = 1;
        const Fit with = fitter.Linear(ModelSpec{}, 0.0, {problem.Whiten(step)});
        if (with.ok && none.chi2 - with.chi2 > best_drop) {
          best_drop = none.chi2 - with.chi2;
          best_g = g;
          best_from = from;
        }
      }
    }
    // A rival of the name: the nominal model plus a shape of two
    // parameters (a step's height and first cycle; a spring-back's cos and
    // sin amplitudes) leaving chi2.
    const auto rival_bic = [&](double chi2) {
      return chi2 + (none.parameters + 2) *
                        std::log(static_cast<double>(std::max(n, 2)));
    };
    sel.step_rival = Bic(f, n) - rival_bic(none.chi2 - best_drop);
    if (best_g >= 0 && sel.step_rival > -options.step_rival_margin)
      rival = fmt::format(
          "a step of {} from cycle {} on explains the data as well as {} "
          "(delta BIC {:.1f})",
          kFigureNames[best_g], best_from, f.spec.Name(), sel.step_rival);
    // A spring-back of another lobe count than the three bolts' (two: an
    // oval; four) turns the facets much as a C stop error does (facets cut
    // at one table angle alike) and moves their distances much as the
    // three lobes do: when it explains the data as well as the cause, the
    // data cannot tell the cause from it (two parameters, like the step).
    for (int lobes : {2, 4}) {
      if (!rival.empty()) break;
      std::vector<Eigen::VectorXd> cols;
      for (const Column& c : cache.Lobes(lobes))
        cols.push_back(problem.Whiten(c));
      const Fit with = fitter.Linear(ModelSpec{}, 0.0, cols);
      if (!with.ok) continue;
      const double delta = Bic(f, n) - rival_bic(with.chi2);
      if (delta > -options.step_rival_margin)
        rival = fmt::format(
            "a {}-lobed spring-back explains the data as well as {} (delta "
            "BIC {:.1f})",
            lobes, f.spec.Name(), delta);
    }
    // Every facet angle turned alike, drifting over the cycles or stepping
    // from one on (the piece turning on its fixture, a C offset the R-tests
    // do not see). Each cycle cuts its four facets at table angles a few
    // degrees from the segments' centres, 60 deg apart from one another in
    // pairs, where the C stop error's harmonics twice and four times per
    // turn take alike values and slopes: such a rotation fits them closely
    // and is not a C stop error. Counted as two parameters, like the step.
    if (rival.empty() && obs.angles() >= 4) {
      const size_t nf = obs.figures();
      std::vector<std::pair<std::string, Column>> turns;
      Column drift = Column::Zero(obs.size());
      for (size_t i = 0; i < obs.angles(); ++i)
        drift[nf + i] = obs.angle_cycle[i];
      turns.emplace_back("a drift of every facet angle over the cycles", drift);
      for (int from = 2; from <= part_cycles(obs); ++from) {
        Column step = Column::Zero(obs.size());
        for (size_t i = 0; i < obs.angles(); ++i)
          if (obs.angle_cycle[i] >= from) step[nf + i] = 1;
        turns.emplace_back(
            fmt::format("a step of every facet angle from cycle {} on", from),
            step);
      }
      for (const auto& turn : turns) {
        const Fit with =
            fitter.Linear(ModelSpec{}, 0.0, {problem.Whiten(turn.second)});
        if (!with.ok) continue;
        const double delta = Bic(f, n) - rival_bic(with.chi2);
        if (delta > -options.step_rival_margin) {
          rival = fmt::format(
              "{} explains the data as well as {} (delta "
              "BIC {:.1f})",
              turn.first, f.spec.Name(), delta);
          break;
        }
      }
    }
  }
  std::string step;
  if (sel.step_chi2 > options.step_chi2)
    step = fmt::format(
        "a step of {} from cycle {} on explains chi2 {:.1f} more (limit {:g})",
        kFigureNames[sel.step_group], sel.step_from_cycle, sel.step_chi2,
        options.step_chi2);
  std::string trend;
  {
    const TrendTest t = FigureTrend(fitter, f, problem);
    sel.trend_chi2 = t.chi2_drop;
    sel.trend_um = t.drift_um;
    // E_X, E_Y and E_Z pooled under the least of the alternatives to
    // another run's log: the best drift or step of one figure kind fitted
    // along, one cycle's figures freed, or any candidate's fit, its
    // parameters a result or not (an
    // effect whose fit ends at a bound, a piece's lag at the shortest time
    // constant tried, still shows that the piece's E_X, E_Y and E_Z can
    // follow this log's machine errors).
    sel.machine_pooled_z_one_kind =
        std::min({sel.machine_pooled_z, t.machine_pooled_z, step_pooled_z,
                  cycle_pooled_z});
    for (const Fit& candidate : sel.fits)
      if (candidate.ok)
        sel.machine_pooled_z_one_kind =
            std::min(sel.machine_pooled_z_one_kind,
                     MachinePooledZ(residual_of(candidate), kinds));
    if (t.chi2_drop > options.trend_chi2 &&
        std::abs(t.drift_um) > options.trend_min_um)
      trend = fmt::format(
          "a drift of {} over the cycles ({:+.2f} um) explains chi2 {:.1f} "
          "more (limit {:g})",
          kFigureNames[t.group], t.drift_um, t.chi2_drop, options.trend_chi2);
  }
  if (sel.chi2_per_dof > options.max_chi2_per_dof || !local.empty() ||
      !step.empty() || !rival.empty() || !trend.empty()) {
    sel.status = DiagnosisStatus::kUnexplained;
    std::string where = local;
    if (!step.empty()) where += (where.empty() ? "" : "; ") + step;
    if (!trend.empty()) where += (where.empty() ? "" : "; ") + trend;
    if (!rival.empty()) where += (where.empty() ? "" : "; ") + rival;
    sel.reason = fmt::format(
        "{} leaves chi2 per degree of freedom {:.2f} (limit {:.2f}){}: the "
        "residual holds structure that no known cause explains",
        chosen == 0 ? "the nominal model" : "the best model, " + f.spec.Name(),
        sel.chi2_per_dof, options.max_chi2_per_dof,
        where.empty() ? "" : "; " + where);
  } else if (chosen == 0) {
    sel.status = DiagnosisStatus::kNone;
    sel.reason = fmt::format(
        "no cause beats the nominal model by the evidence threshold (delta "
        "BIC < -{:g}, -{:g} for a cause seen only in the facet angles) and "
        "the nominal model leaves what the error budget predicts (chi2 per "
        "degree of freedom {:.2f})",
        options.evidence_threshold, options.angle_evidence_threshold,
        sel.chi2_per_dof);
  } else {
    sel.status = DiagnosisStatus::kNamed;
    sel.reason = fmt::format(
        "{} beats the nominal model by delta BIC {:.1f} (threshold {:g}) and "
        "leaves chi2 per degree of freedom {:.2f}",
        f.spec.Name(), Bic(f, n) - none_bic, sel.threshold, sel.chi2_per_dof);
  }
  return sel;
}

// `wear_path_rel`: DiagnosisOptions::wear_path_relative_uncertainty, added
// in quadrature to the wear's statistical uncertainty.
std::vector<ParamEstimate> ReportParams(const Fit& fit, double wear_path_rel) {
  std::vector<ParamEstimate> out;
  for (size_t k = 0; k < fit.spec.causes.size(); ++k) {
    const Cause cause = fit.spec.causes[k];
    const auto& p = fit.params[k];
    const Eigen::MatrixXd& cov = fit.covariance[k];
    auto sd = [&](int i) {
      return i < cov.rows() ? std::sqrt(std::max(0.0, cov(i, i))) : 0.0;
    };
    const std::vector<std::string> names =
        cause == Cause::kCAxisIndexing
            ? CAxisParameterNames(fit.spec.c_harmonics)
            : CauseParameterNames(cause);
    if (cause == Cause::kClampingDistortion || cause == Cause::kCAxisIndexing) {
      // Amplitude and phase of a cos + b sin = A cos(x - phase) per harmonic.
      const bool clamp = cause == Cause::kClampingDistortion;
      for (size_t h = 0; h + 1 < p.size(); h += 2) {
        const double a = p[h], b = p[h + 1];
        const double amp = std::hypot(a, b);
        const double s = std::max(sd(h), sd(h + 1));
        const std::string tag =
            clamp ? "" : std::to_string(fit.spec.c_harmonics[h / 2]);
        out.push_back({"amplitude" + tag + (clamp ? "_um" : "_urad"), amp, s});
        out.push_back({"phase" + tag + "_deg", std::atan2(b, a) * 180 / M_PI,
                       amp > 0 ? s / amp * 180 / M_PI : 180.0});
      }
      if (!clamp)
        out.push_back({"harmonics",
                       static_cast<double>(fit.spec.c_harmonics.size()), 0.0});
    }
    for (size_t i = 0; i < names.size() && i < p.size(); ++i) {
      double u = sd(static_cast<int>(i));
      if (cause == Cause::kToolWear) u = std::hypot(u, wear_path_rel * p[i]);
      out.push_back({names[i], p[i], u});
    }
    if (cause == Cause::kWorkpieceExpansion && fit.spec.wp_initial_state)
      out.push_back({"initial_dT_K", p[2], sd(2)});
  }
  return out;
}

}  // namespace

std::string Observations::FigureLabel(size_t i) const {
  return fmt::format("{}@{}", kFigureNames[figure_kind[i]], figure_cycle[i]);
}
std::string Observations::AngleLabel(size_t i) const {
  return "angle " + angle_feature[i].ToString();
}

bool DiagnosisOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  if (!(evidence_threshold >= 0))
    return fail("evidence_threshold: must be >= 0");
  if (!(angle_evidence_threshold >= 0))
    return fail("angle_evidence_threshold: must be >= 0");
  if (!(max_chi2_per_dof > 0)) return fail("max_chi2_per_dof: must be > 0");
  if (!(local_z > 0)) return fail("local_z: must be > 0");
  if (!(refuse_z > 0)) return fail("refuse_z: must be > 0");
  if (!(step_chi2 > 0)) return fail("step_chi2: must be > 0");
  if (!(min_sigma_um > 0)) return fail("min_sigma_um: must be > 0");
  if (!(min_sigma_urad > 0)) return fail("min_sigma_urad: must be > 0");
  if (!(estimator_sigma_scale >= 0))
    return fail("estimator_sigma_scale: must be >= 0");
  if (!(form_fraction >= 0)) return fail("form_fraction: must be >= 0");
  if (max_c_harmonics < 1 || max_c_harmonics > 12)
    return fail("max_c_harmonics: must be 1..12");
  if (!(named_machine_z > 0)) return fail("named_machine_z: must be > 0");
  if (!(refuse_machine_pooled_z > 0))
    return fail("refuse_machine_pooled_z: must be > 0");
  if (!std::isfinite(refuse_after_one_kind_z))
    return fail("refuse_after_one_kind_z: must be finite");
  if (!(refuse_other_machine_z > 0))
    return fail("refuse_other_machine_z: must be > 0");
  if (other_machine_tau_s.empty()) return fail("other_machine_tau_s: empty");
  for (double tau_s : other_machine_tau_s)
    if (!(tau_s > 0) || !std::isfinite(tau_s))
      return fail(
          "other_machine_tau_s: every time constant must be > 0 and finite");
  if (!(wear_path_relative_uncertainty >= 0 &&
        wear_path_relative_uncertainty < 1))
    return fail("wear_path_relative_uncertainty: must be in [0, 1)");
  if (!(min_heldout_gain_pct < 100))
    return fail("min_heldout_gain_pct: must be < 100");
  if (!(trend_chi2 > 0)) return fail("trend_chi2: must be > 0");
  if (!(trend_min_um >= 0)) return fail("trend_min_um: must be >= 0");
  if (!(implausible_rival_margin >= 0))
    return fail("implausible_rival_margin: must be >= 0");
  if (!(max_tau_relative_uncertainty > 0))
    return fail("max_tau_relative_uncertainty: must be > 0");
  if (!(mismatch_slope_limit > 0))
    return fail("mismatch_slope_limit: must be > 0");
  if (tau_grid_s.empty()) return fail("tau_grid_s: empty");
  for (size_t k = 0; k < tau_grid_s.size(); ++k) {
    if (!(tau_grid_s[k] > 0) || !std::isfinite(tau_grid_s[k]))
      return fail("tau_grid_s: every time constant must be > 0 and finite");
    if (k > 0 && !(tau_grid_s[k] > tau_grid_s[k - 1]))
      return fail("tau_grid_s: must be increasing");
  }
  return true;
}

const char* StatusName(DiagnosisStatus status) {
  switch (status) {
    case DiagnosisStatus::kNamed:
      return "named";
    case DiagnosisStatus::kNone:
      return "none";
    case DiagnosisStatus::kUnexplained:
      return "unexplained";
    case DiagnosisStatus::kRefused:
      return "refused";
  }
  return "?";
}

ObservationEffect EffectOnObservations(Cause cause,
                                       const std::vector<double>& params,
                                       const Observations& obs,
                                       const EffectContext& context,
                                       const PartSpec& part) {
  if (cause == Cause::kNone) {
    ObservationEffect out;
    out.figure_um.assign(obs.figures(), 0.0);
    out.angle_urad.assign(obs.angles(), 0.0);
    return out;
  }
  return DeltasOnObservations(PredictEffect(cause, params, context), obs, part);
}

ObservationEffect DeltasOnObservations(const EffectDeltas& deltas,
                                       const Observations& obs,
                                       const PartSpec& part) {
  ObservationEffect out;
  out.figure_um.assign(obs.figures(), 0.0);
  out.angle_urad.assign(obs.angles(), 0.0);
  FeatureResults results;
  for (const auto& [id, d] : deltas) {
    FeatureResult r;
    r.present = true;
    r.d_mm = d.d_mm;
    r.angle_rad = d.angle_rad;
    results[id] = r;
  }
  const std::vector<CycleFigures> figures = ComputeFigures(part, results);
  for (size_t i = 0; i < obs.figures(); ++i) {
    const int c = obs.figure_cycle[i];
    if (c >= 1 && c <= static_cast<int>(figures.size())) {
      const double v =
          (obs.figure_kind[i] == 4
               ? OvalityMm(part, results, c)
               : FigureValueMm(figures[c - 1], obs.figure_kind[i])) *
          1e3;
      out.figure_um[i] = std::isfinite(v) ? v : 0.0;
    }
  }
  for (size_t i = 0; i < obs.angles(); ++i) {
    auto it = deltas.find(obs.angle_feature[i]);
    if (it != deltas.end()) out.angle_urad[i] = it->second.angle_rad * 1e6;
  }
  return out;
}

namespace {

// Where the residual after a model is largest, relative to its sigma.
std::vector<StructureLocation> LocateStructure(const Observations& obs,
                                               const Column& residual,
                                               int cycles) {
  std::vector<StructureLocation> out;
  const size_t nf = obs.figures();
  auto add = [&](const std::string& where, const std::string& unit,
                 auto select) {
    std::vector<double> r;
    double chi2 = 0;
    for (size_t i = 0; i < obs.size(); ++i) {
      if (!select(i)) continue;
      const double sigma =
          i < nf ? obs.figure_sigma_um[i] : obs.angle_sigma_urad[i - nf];
      r.push_back(residual[i]);
      chi2 += std::pow(residual[i] / sigma, 2);
    }
    if (r.empty()) return;
    out.push_back({where, Rms(r), unit, chi2 / r.size()});
  };
  for (int g = 0; g < kFigureKinds; ++g)
    add(kFigureNames[g], "um",
        [&](size_t i) { return i < nf && obs.figure_kind[i] == g; });
  add("facet angles", "urad", [&](size_t i) { return i >= nf; });
  for (Segment seg :
       {Segment::kX1, Segment::kX2, Segment::kY1, Segment::kY2})
    add(fmt::format("facet angles {}", SegmentName(seg)), "urad",
        [&](size_t i) {
          return i >= nf && obs.angle_feature[i - nf].segment == seg;
        });
  for (int c = 1; c <= cycles; ++c)
    add(fmt::format("figures of cycle {}", c), "um", [&](size_t i) {
      return i < nf && obs.figure_cycle[i] == c;
    });
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) {
    return a.chi2_per_observation > b.chi2_per_observation;
  });
  return out;
}

// Whether a name chosen on all cycles holds (diagnosis.md section 3: an
// effect outside the catalogue is `unexplained`, never the nearest name).
// BIC against the nominal model only says that the cause's shape lowers
// chi2; an effect outside the catalogue (a step between cycles, another
// lobe count, one feature type drifting) also projects onto some cause's
// shape, most easily when few observations are left (a dial gauge: no
// angles, 8 cycles). Two things a real cause leaves and a projection
// does not: its fit predicts cycles it did not see (the selection
// repeated without each cycle), and no physically implausible fit of a
// catalogue shape (the residual wants a cutter that grows or a lag
// outside the physical range) explains the data better than it does.
// Returns an empty string when the name holds, else why not.
// `heldout_*_chi2`: the held-out cycles' residuals (nominal model and the
// fold's chosen one) summed over figures and angles, so that a cause seen
// in the angles is judged there too: a figure's squared over its sigma, a
// facet angle's deviance under the fold's prediction (its variance
// added).
// A name withdrawn after the selection: the report becomes `unexplained`
// with `reason`, without the cause's parameters or gain, its residual
// that of the nominal model.
void WithdrawName(DiagnosisReport* report, std::string reason) {
  report->status = DiagnosisStatus::kUnexplained;
  report->cause = StatusName(report->status);
  report->reason = std::move(reason);
  report->params.clear();
  report->gain_pct = 0;
  report->extended_rms_um = report->baseline_rms_um;
  report->extended_rms_urad = report->baseline_rms_urad;
}

std::string NamedCauseHolds(const DiagnosisReport& report, int chosen,
                            double heldout_base_chi2, double heldout_ext_chi2,
                            const DiagnosisOptions& options) {
  const CandidateResult& named = report.candidates[chosen];
  // A rival that holds the named causes and adds an implausible one only
  // describes what is left after them (the goodness-of-fit tests judge
  // that); a rival of another shape competes with the name.
  const auto contains_named = [&named](const CandidateResult& c) {
    for (Cause cause : named.causes)
      if (std::find(c.causes.begin(), c.causes.end(), cause) == c.causes.end())
        return false;
    return true;
  };
  for (const CandidateResult& c : report.candidates)
    if (!c.note.empty() && !contains_named(c) &&
        c.bic < named.bic - options.implausible_rival_margin)
      return fmt::format(
          "{} fits better (delta BIC {:.1f} against {:.1f} for {}) but is "
          "no result ({}): the residual has a shape no known cause gives, "
          "or one the data cannot pin down",
          c.name, c.delta_bic, named.delta_bic, named.name, c.note);
  // The gain as an RMS of normalised residuals (1 - sqrt of the chi2
  // ratio), the same measure as gain_pct on one kind of observation.
  const double gain_pct =
      heldout_base_chi2 > 0
          ? 100.0 * (1.0 - std::sqrt(heldout_ext_chi2 / heldout_base_chi2))
          : 0.0;
  if (!(gain_pct > options.min_heldout_gain_pct))
    return fmt::format(
        "{} fitted without each cycle does not predict it better than the "
        "nominal model (held-out figures over their sigma and facet angles "
        "over their predicted spread: gain {:.1f} %, needs > {:g} %): its "
        "fit follows structure of another shape",
        named.name, gain_pct, options.min_heldout_gain_pct);
  return "";
}

// The workpiece expansion's regressor is the table temperature estimated
// from the R-tests' E_R0T, lagged: the estimator's error between R-tests
// enters the cause's columns as well as the observations, and the fit's
// covariance holds only the second. Its share of the parameters'
// uncertainty, measured: the fit repeated on temperature histories
// perturbed by draws of that error (standard uncertainty per grid point,
// correlated over the estimator's correlation time as the budget has it),
// the covariance of the refitted parameters added to the fit's. Fixed
// seed: the same input gives the same report.
constexpr int kRegressorDraws = 24;
Fit WithRegressorUncertainty(const Fit& chosen, const Observations& obs,
                             const EffectContext& context, const PartSpec& part,
                             const Problem& problem,
                             const DiagnosisOptions& options) {
  Fit out = chosen;
  const size_t grid = context.machine_dT_K.size();
  if (!chosen.ok || context.machine_dT_sigma_K.size() != grid || grid < 2)
    return out;
  const double rho =
      std::exp(-context.grid_step_s /
               std::max(context.machine_dT_correlation_s, context.grid_step_s));
  const double innovation = std::sqrt(std::max(0.0, 1 - rho * rho));
  // Each refit profiles tau on a grid about the chosen one (a factor of
  // three either way, then the golden-section search between neighbours)
  // and builds the C stop error's columns only up to the harmonics the
  // chosen model holds: the draws add about 0.03 s to sample run-a's
  // diagnosis (0.12 s in all, bench_diagnosis).
  DiagnosisOptions local = options;
  const double tau_s = FittedTauS(chosen);
  if (tau_s > 0) {
    local.tau_grid_s.clear();
    for (double f : {1 / 3.0, 1 / 1.7, 1.0, 1.7, 3.0})
      local.tau_grid_s.push_back(tau_s * f);
  }
  local.max_c_harmonics = 1;
  for (int h : chosen.spec.c_harmonics)
    local.max_c_harmonics = std::max(local.max_c_harmonics, h);
  std::mt19937_64 rng(20261202);
  std::normal_distribution<double> normal;
  std::vector<std::vector<std::vector<double>>> draws;  // draw, cause, param
  for (int d = 0; d < kRegressorDraws; ++d) {
    EffectContext perturbed = context;
    double a = normal(rng);
    for (size_t i = 0; i < grid; ++i) {
      if (i > 0) a = rho * a + innovation * normal(rng);
      perturbed.machine_dT_K[i] += a * context.machine_dT_sigma_K[i];
    }
    const ColumnCache cache(obs, perturbed, part, local.max_c_harmonics);
    const Fit f = Fitter(cache, problem, local).Run(chosen.spec);
    if (f.ok) draws.push_back(f.params);
  }
  if (draws.size() < 2) return out;
  for (size_t k = 0; k < chosen.params.size(); ++k) {
    const int p = static_cast<int>(chosen.params[k].size());
    if (out.covariance[k].rows() != p) continue;
    Eigen::MatrixXd x(static_cast<int>(draws.size()), p);
    for (size_t d = 0; d < draws.size(); ++d)
      for (int i = 0; i < p; ++i) x(static_cast<int>(d), i) = draws[d][k][i];
    const Eigen::MatrixXd centred = x.rowwise() - x.colwise().mean();
    out.covariance[k] +=
        centred.transpose() * centred / static_cast<double>(draws.size() - 1);
  }
  return out;
}

}  // namespace

DiagnosisReport Diagnose(const Observations& obs, const EffectContext& context,
                         const PartSpec& part,
                         const DiagnosisOptions& options) {
  std::string invalid;
  if (!options.IsValid(&invalid))
    throw std::invalid_argument("DiagnosisOptions." + invalid);
  DiagnosisReport report;
  const int n = static_cast<int>(obs.size());
  const int nf = static_cast<int>(obs.figures());
  report.observations = n;
  if (n == 0)
    throw InputError("measurement", 0, "",
                     "no residual observations (no figures or angles)");
  report.raw_rms_um = Rms(obs.figure_value_um);
  for (int g = 0; g < kFigureKinds; ++g)
    report.figures_anchored = report.figures_anchored || !FreeOffset(obs, g);
  report.raw_rms_urad = Rms(obs.angle_value_urad);

  const ColumnCache cache(obs, context, part, options.max_c_harmonics);
  Column y(n);
  for (int i = 0; i < nf; ++i) y[i] = obs.figure_value_um[i];
  for (int i = nf; i < n; ++i) y[i] = obs.angle_value_urad[i - nf];
  auto split_rms = [&](const Column& r, double* um, double* urad) {
    std::vector<double> a(r.data(), r.data() + nf), b(r.data() + nf,
                                                      r.data() + n);
    *um = Rms(a);
    *urad = Rms(b);
  };

  const Problem problem(obs, std::vector<bool>(n, true));
  const Selection sel = Select(cache, problem, options);
  const double none_bic = Bic(sel.fits[0], n);
  for (const Fit& f : sel.fits) {
    CandidateResult c;
    c.name = f.spec.Name();
    c.causes = f.spec.causes;
    c.cause = f.spec.causes.empty() ? Cause::kNone : f.spec.causes.front();
    c.params = f.params;
    c.parameters = f.parameters;
    c.chi2 = f.chi2;
    c.bic = Bic(f, n);
    c.delta_bic = c.bic - none_bic;
    c.note = f.note;
    if (f.ok)
      c.report_params = ReportParams(f, options.wear_path_relative_uncertainty);
    // What the piece shows of a fitted C stop error: its variation over the
    // facets' cut angles (the constant part is the piece's yaw). Over the
    // 78 degrees cut, the harmonics' amplitudes are an extrapolation to the
    // whole turn; this is the measured quantity.
    for (size_t k = 0; f.ok && k < f.spec.causes.size(); ++k) {
      if (f.spec.causes[k] != Cause::kCAxisIndexing || obs.angles() < 2)
        continue;
      const auto cols = cache.CAxis(f.spec.c_harmonics);
      const int m = n - nf, p = static_cast<int>(cols.size());
      Eigen::MatrixXd a(m, p);  // the harmonics at the angles, centred
      for (int h = 0; h < p; ++h) {
        a.col(h) = cols[h].tail(m);
        a.col(h).array() -= a.col(h).mean();
      }
      const Eigen::VectorXd b =
          Eigen::Map<const Eigen::VectorXd>(f.params[k].data(), p);
      const Eigen::VectorXd v = a * b;
      const double rms = std::sqrt(v.squaredNorm() / m);
      // Its standard uncertainty from the coefficients' (delta method).
      double sd = 0;
      if (rms > 0 && f.covariance[k].rows() == p) {
        const Eigen::VectorXd g = a.transpose() * v / (m * rms);
        sd = std::sqrt(std::max(0.0, g.dot(f.covariance[k] * g)));
      }
      c.report_params.push_back({"shown_rms_urad", rms, sd});
    }
    split_rms(y - Prediction(f, cache, obs), &c.rms_um, &c.rms_urad);
    report.candidates.push_back(c);
  }
  const Fit& chosen = sel.fits[sel.chosen];
  report.status = sel.status;
  report.reason = sel.reason;
  report.chi2_per_dof = sel.chi2_per_dof;
  report.best_evidence = sel.best_evidence;
  report.structure_z = sel.local_z;
  report.machine_z = sel.machine_z;
  report.machine_pooled_z = sel.machine_pooled_z;
  report.machine_kind_z = sel.machine_kind_z;
  report.machine_pooled_z_one_kind = sel.machine_pooled_z_one_kind;
  report.machine_pooled_z_other_machine = sel.machine_pooled_z_other_machine;
  report.step_chi2 = sel.step_chi2;
  report.trend_chi2 = sel.trend_chi2;
  report.trend_um = sel.trend_um;
  report.evidence_threshold = sel.threshold;
  report.baseline_rms_um = report.candidates[0].rms_um;
  report.baseline_rms_urad = report.candidates[0].rms_urad;
  const Column after = y - Prediction(chosen, cache, obs);
  report.figure_after_um.assign(after.data(), after.data() + nf);
  if (sel.status == DiagnosisStatus::kNamed) {
    report.cause = chosen.spec.Name();
    if (std::count(chosen.spec.causes.begin(), chosen.spec.causes.end(),
                   Cause::kWorkpieceExpansion) > 0) {
      // The uncertainties with the regressor's own error added.
      const std::vector<ParamEstimate> wider =
          ReportParams(WithRegressorUncertainty(chosen, obs, context, part,
                                                problem, options),
                       options.wear_path_relative_uncertainty);
      for (ParamEstimate& p : report.candidates[sel.chosen].report_params)
        for (const ParamEstimate& w : wider)
          if (w.name == p.name) p.uncertainty = w.uncertainty;
    }
    report.params = report.candidates[sel.chosen].report_params;
    report.extended_rms_um = report.candidates[sel.chosen].rms_um;
    report.extended_rms_urad = report.candidates[sel.chosen].rms_urad;
  } else {
    report.cause = StatusName(sel.status);
    report.extended_rms_um = report.baseline_rms_um;
    report.extended_rms_urad = report.baseline_rms_urad;
    report.figure_after_um.assign(after.data(), after.data() + nf);
  }
  report.structure = LocateStructure(obs, after, part.cycles());

  // Gain on held-out cycles: the whole selection repeated without cycle
  // k, its chosen model and the nominal one predicting cycle k.
  if (sel.status == DiagnosisStatus::kNamed) {
    std::vector<double> base_um, ext_um, base_urad, ext_urad;
    // Held-out residuals in units of their sigma, figures and angles
    // together (what a name is judged on: NamedCauseHolds).
    double heldout_base_chi2 = 0, heldout_ext_chi2 = 0;
    for (int k = 1; k <= part.cycles(); ++k) {
      std::vector<bool> use(n);
      bool any = false;
      for (int i = 0; i < n; ++i) {
        const int cycle = i < nf ? obs.figure_cycle[i] : obs.angle_cycle[i - nf];
        use[i] = cycle != k;
        any = any || !use[i];
      }
      if (!any) continue;
      const Problem fold(obs, use);
      const Selection fs = Select(cache, fold, options, false);
      const Column pb = Prediction(fs.fits[0], cache, obs);
      const Column pe = Prediction(fs.fits[fs.chosen], cache, obs);
      const Column vb = PredictionVariance(fs.fits[0], cache, obs);
      const Column ve = PredictionVariance(fs.fits[fs.chosen], cache, obs);
      for (int i = 0; i < n; ++i) {
        if (use[i]) continue;
        (i < nf ? base_um : base_urad).push_back(y[i] - pb[i]);
        (i < nf ? ext_um : ext_urad).push_back(y[i] - pe[i]);
        const double sigma =
            i < nf ? obs.figure_sigma_um[i] : obs.angle_sigma_urad[i - nf];
        // A facet angle: the deviance of the held-out value under each
        // fold's prediction (its own uncertainty added to the
        // observation's). A held-out cycle's facets lie at table angles the
        // fold has not seen, at the edges of the span beyond them, where a
        // sum of harmonics extrapolates: it is judged against what it
        // claims there, and pays for claiming little (the log term). A
        // figure: its residual over its sigma (every cycle pins the
        // figures' shapes; their prediction's variance is a small
        // leverage, and the deviance would only add noise).
        const auto deviance = [&](double residual, double variance) {
          const double inflation =
              i < nf ? 1.0 : 1.0 + variance / (sigma * sigma);
          return std::pow(residual / sigma, 2) / inflation +
                 std::log(inflation);
        };
        heldout_base_chi2 += deviance(y[i] - pb[i], vb[i]);
        heldout_ext_chi2 += deviance(y[i] - pe[i], ve[i]);
      }
    }
    report.heldout_baseline_rms_um = Rms(base_um);
    report.heldout_extended_rms_um = Rms(ext_um);
    report.heldout_baseline_rms_urad = Rms(base_urad);
    report.heldout_extended_rms_urad = Rms(ext_urad);
    const bool angles_only =
        chosen.spec.causes.size() == 1 &&
        chosen.spec.causes[0] == Cause::kCAxisIndexing;
    const double b = angles_only ? report.heldout_baseline_rms_urad
                                 : report.heldout_baseline_rms_um;
    const double e = angles_only ? report.heldout_extended_rms_urad
                                 : report.heldout_extended_rms_um;
    if (b > 0) report.gain_pct = 100.0 * (1.0 - e / b);
    const std::string why = NamedCauseHolds(
        report, sel.chosen, heldout_base_chi2, heldout_ext_chi2, options);
    if (!why.empty()) {
      WithdrawName(
          &report,
          fmt::format("{} beats the nominal model (delta BIC {:.1f}) but does "
                      "not hold: {}; the residual holds structure that no "
                      "known cause explains",
                      chosen.spec.Name(),
                      report.candidates[sel.chosen].delta_bic, why));
      // Where the structure lives: after the nominal model, since the
      // cause's fit does not hold.
      const Column nominal = y - Prediction(sel.fits[0], cache, obs);
      report.figure_after_um.assign(nominal.data(), nominal.data() + nf);
      report.structure = LocateStructure(obs, nominal, part.cycles());
    }
  }
  return report;
}

namespace {
// The instrument's error of a feature: the scatter of its points when it
// was fitted to points - the plane fit's covariance carried to where d is
// taken, as the inspection gives it (a facet's d is taken at W's origin,
// 1-11 mm above its points, so the fit's tilt moves it: 2.3 times rms /
// sqrt(points)); without it, FeatureFitScatter's, for points spread
// evenly over the feature -, else the variances it comes with (probe,
// dial, DMIS); plus
// the form error, a fraction of the fit's residual RMS that does not
// average out over the points. The instrument's error limit is common to
// the cycles and cancels in the figures' differences (and the per-figure
// offsets of every model absorb what is left).
void SetFeatureVariance(const PartSpec& part, FeatureKind kind,
                        double form_fraction, FeatureResult* r) {
  const bool fitted = r->present && r->rms_mm > 0 && r->points >= 3;
  if (!fitted) return;  // its stated variances stand
  // The inspection's plane covariance also holds the datum alignment and
  // the instrument's error limit, common to every feature: the per-figure
  // offsets absorb those, so a fitted feature is judged by its own
  // scatter.
  FitScatter s = FeatureFitScatter(part, kind, r->rms_mm, r->points);
  if (r->scatter_var_d_mm2 > 0 && r->scatter_var_angle_rad2 > 0) {
    s.d_mm = std::sqrt(r->scatter_var_d_mm2);
    s.angle_rad = std::sqrt(r->scatter_var_angle_rad2);
  }
  // A few touches (a probe's 4-6 points) leave one to three degrees of
  // freedom: their scatter is no estimate of the instrument's noise, and
  // their positions are not spread over the facet as a cloud's are. The
  // variances the instrument states (from its trigger noise and the
  // touch positions, the lever of their tilt included) then stand, unless
  // the scatter, as rms / sqrt(points), is larger.
  constexpr int kFewPoints = 30;
  if (r->points < kFewPoints) {
    const double plain_d = r->rms_mm / std::sqrt(r->points);
    const double stated_d = std::isfinite(r->var_d_mm2) ? r->var_d_mm2 : 0.0;
    const double stated_a =
        std::isfinite(r->var_angle_rad2) ? r->var_angle_rad2 : 0.0;
    r->var_d_mm2 = std::max(stated_d, plain_d * plain_d);
    r->var_angle_rad2 = std::max(stated_a, s.angle_rad * s.angle_rad);
  } else {
    r->var_d_mm2 = s.d_mm * s.d_mm;
    r->var_angle_rad2 = s.angle_rad * s.angle_rad;
  }
  // (The form error on the distance only: a form error that does not
  // average out shifts the plane more than it turns it.)
  r->var_d_mm2 += std::pow(form_fraction * r->rms_mm, 2);
}
// The reference cycle's part of each figure kind's error (the common
// variance of Observations::figure_reference_var_um2): the reference
// features' measurement, weighted as in the figure, plus the estimator's
// error at the reference cut (`estimator_var_um2`, per kind; what the
// R-tests leave there). A reference feature read as the zero of an instrument
// (a dial gauge's setting on facet 5 and strip 5, stated variance 0) counts as
// one reading of its family. Without feature results (figures only), half
// the figure's variance: the figure is the difference of two cycles'
// measurements.
struct ReferenceCycleVariance {
  // Per figure kind: the common variance (infinite: not known).
  std::vector<double> common_um2 = std::vector<double>(
      kFigureKinds, std::numeric_limits<double>::infinity());
  // Per figure kind: the part of it that each figure's own uncertainty
  // already holds (a figure's uncertainty combines the reference features'
  // stated variances with its cycle's: counted once, not twice).
  std::vector<double> in_figure_sigma_um2 =
      std::vector<double>(kFigureKinds, 0.0);
};
ReferenceCycleVariance ReferenceCycleVarianceUm2(
    const PartSpec& part, const MeasuredPiece& measured,
    const Observations& obs, const std::vector<double>& estimator_var_um2) {
  ReferenceCycleVariance result;
  std::vector<double>& out = result.common_um2;
  std::vector<double>& own = result.in_figure_sigma_um2;
  const int ref = part.reference_index;
  // A reference feature's own stated variance, um^2 (what the figures'
  // uncertainties hold of it; 0 when not measured).
  auto own_var = [&](const FeatureId& id) {
    auto it = measured.features.find(id);
    if (it == measured.features.end() || !it->second.present ||
        !std::isfinite(it->second.var_d_mm2))
      return 0.0;
    return it->second.var_d_mm2 * 1e6;
  };
  // Variance of a reference feature, um^2 (NaN when it was not measured).
  auto reference_var = [&](const FeatureId& id) {
    auto it = measured.features.find(id);
    if (it == measured.features.end() || !it->second.present)
      return std::numeric_limits<double>::quiet_NaN();
    std::vector<double> family;
    for (const auto& [other, r] : measured.features)
      if (other.kind == id.kind && other.segment == id.segment &&
          other.index != ref && other.IsTestFeature() && r.present &&
          std::isfinite(r.var_d_mm2))
        family.push_back(r.var_d_mm2);
    double v = std::isfinite(it->second.var_d_mm2) ? it->second.var_d_mm2 : 0;
    if (!family.empty()) {
      std::nth_element(family.begin(), family.begin() + family.size() / 2,
                       family.end());
      v = std::max(v, family[family.size() / 2]);
    }
    return v * 1e6;
  };
  if (!measured.features.empty()) {
    // The reference features' variances weighted as in each figure.
    const auto by_kind = [&](const auto& variance, std::vector<double>* kind) {
      const double x1 = variance(FeatureId::Facet(Segment::kX1, ref)),
                   x2 = variance(FeatureId::Facet(Segment::kX2, ref)),
                   y1 = variance(FeatureId::Facet(Segment::kY1, ref)),
                   y2 = variance(FeatureId::Facet(Segment::kY2, ref)),
                   z = variance(FeatureId::Strip(ref));
      (*kind)[0] = 0.25 * (x1 + x2);
      (*kind)[1] = 0.25 * (y1 + y2);
      (*kind)[2] = z;
      (*kind)[3] = 0.0625 * (x1 + x2 + y1 + y2);
      (*kind)[4] = (*kind)[3];
    };
    by_kind(reference_var, &out);
    by_kind(own_var, &own);
  } else {
    for (int g = 0; g < 4; ++g) {
      std::vector<double> v;
      for (size_t i = 0; i < obs.figures(); ++i)
        if (obs.figure_kind[i] == g) v.push_back(obs.figure_sigma_um[i]);
      if (v.empty()) continue;
      std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
      out[g] = 0.5 * v[v.size() / 2] * v[v.size() / 2];
      own[g] = out[g];
    }
  }
  for (int g = 0; g < kFigureKinds; ++g)
    if (std::isfinite(out[g])) out[g] += estimator_var_um2[g];
  return result;
}

}  // namespace

MeasuredPiece MeasuredPieceFromFeatures(const PartSpec& part,
                                        const FeatureResults& features) {
  MeasuredPiece m;
  const double form_fraction = DiagnosisOptions{}.form_fraction;
  for (const auto& [id, r] : features) {
    if (!r.present) continue;
    FeatureResult& f = m.features[id] = r;
    if (!id.IsTestFeature()) continue;
    const FeatureKind kind = id.kind;
    SetFeatureVariance(part, kind, form_fraction, &f);
    if (kind == FeatureKind::kFacet && std::isfinite(r.angle_rad))
      m.facet_angle_rad[id] = r.angle_rad;
  }
  m.figures = ComputeFigures(part, m.features);
  return m;
}

MeasuredPiece MeasuredPieceFromInspection(
    const PartSpec& part, const inspect::InspectionResult& result) {
  MeasuredPiece m;
  const bool any_feature =
      std::any_of(result.features.begin(), result.features.end(),
                  [](const auto& f) { return f.second.present; });
  if (any_feature) {
    m = MeasuredPieceFromFeatures(part, result.features);
  } else {
    m.figures = result.figures;
    m.facet_angle_rad = result.facet_angle_rad;
  }
  m.source = result.source;
  if (m.figures.empty() && m.facet_angle_rad.empty())
    throw InputError(result.source.empty() ? "measurement" : result.source, 0,
                     "figures",
                     "the measurement has neither feature results nor "
                     "figures");
  return m;
}

MeasuredPiece LoadMeasuredPiece(const Config& config, const std::string& path,
                                const inspect::MeasurementOptions& options) {
  return MeasuredPieceFromInspection(
      config.part, inspect::LoadMeasurement(config, path, options).result);
}

PreparedRun PrepareRun(const thermal::TalcLog& log, const Config& config,
                       const MeasuredPiece& measured,
                       const DiagnosisOptions& options) {
  const auto estimator = thermal::MachineErrorEstimator::Fit(
      log, thermal::EstimatorOptionsFor(config.machine));
  return PrepareRun(log, config, estimator,
                    thermal::SimulatePiece(log, config, estimator, {}),
                    measured, options);
}

PreparedRun PrepareRun(const thermal::TalcLog& log, const Config& config,
                       const thermal::MachineErrorEstimator& estimator,
                       thermal::Simulation simulation,
                       const MeasuredPiece& measured,
                       const DiagnosisOptions& options) {
  std::string invalid;
  if (!options.IsValid(&invalid))
    throw std::invalid_argument("DiagnosisOptions." + invalid);
  PreparedRun run;
  run.simulation = std::move(simulation);
  const PartSpec& part = config.part;

  std::vector<CutState> states;
  for (const auto& cut : run.simulation.cuts)
    states.push_back(MakeCutState(config, cut.feature, cut.t_s, cut.c_rad));
  run.context = MakeEffectContext(config, states);
  // Machine temperature history from the estimated E_R0T (extrapolated
  // through the estimator's model beyond the last R-test).
  const double t_end = log.LastTimeS();
  run.context.grid_t0_s = 0;
  run.context.grid_step_s = 10;
  const double first = estimator.FirstRTestS();
  for (double t = 0; t <= t_end + 10; t += 10) {
    const double tc = std::max(t, first);
    run.context.machine_dT_K.push_back(
        TemperatureChangeK(estimator.MachineErrorsAt(tc).er0t_mm,
                           kTableAlphaPerK, log.sphere_distance_mm));
    run.context.machine_dT_sigma_K.push_back(std::abs(TemperatureChangeK(
        estimator.ErrorSigmaAt(3, tc) * options.estimator_sigma_scale * 1e-3,
        kTableAlphaPerK, log.sphere_distance_mm)));
  }
  run.context.machine_dT_correlation_s = estimator.CorrelationTimeS();

  // Every measured feature must have been cut in the log: otherwise the
  // log does not cover the measured piece (or belongs to another piece).
  std::vector<std::string> uncut;
  auto check_cut = [&](const FeatureId& id) {
    auto it = run.simulation.results.find(id);
    if (it == run.simulation.results.end() || !it->second.present)
      if (std::find(uncut.begin(), uncut.end(), id.ToString()) == uncut.end())
        uncut.push_back(id.ToString());
  };
  for (const auto& [id, r] : measured.features)
    if (r.present) check_cut(id);
  for (const auto& [id, a] : measured.facet_angle_rad) check_cut(id);
  for (const CycleFigures& m : measured.figures) {
    if (m.cycle < 1 ||
        m.cycle > static_cast<int>(run.simulation.figures.size()))
      continue;
    const CycleFigures& s = run.simulation.figures[m.cycle - 1];
    for (int g = 0; g < 4; ++g)
      if (std::isfinite(FigureValueMm(m, g)) &&
          !std::isfinite(FigureValueMm(s, g)))
        uncut.push_back(fmt::format("{} of cycle {}", kFigureNames[g], m.cycle));
  }
  if (!uncut.empty()) {
    std::string list;
    for (size_t k = 0; k < uncut.size() && k < 6; ++k)
      list += (k ? ", " : "") + uncut[k];
    if (uncut.size() > 6) list += fmt::format(" and {} more", uncut.size() - 6);
    run.refusal = fmt::format(
        "the log {} has no cut of {} that the measurement {} holds: the log "
        "does not cover the piece's cut times, or log and measurement do not "
        "belong together",
        log.source, list, measured.source);
    return run;
  }

  // Cut time of each cycle (its features are cut within a minute).
  std::map<int, std::pair<double, int>> cycle_time;
  for (const auto& cut : run.simulation.cuts) {
    auto& [sum, count] = cycle_time[CycleForIndex(part, cut.feature.index)];
    sum += cut.t_s;
    ++count;
  }
  auto time_of = [&](int cycle) {
    auto it = cycle_time.find(cycle);
    return it == cycle_time.end() ? 0.0
                                  : it->second.first / it->second.second;
  };

  // The estimator's error of the error each figure follows (a figure is a
  // combination of one cycle's cuts): blocked cross-validation, scaled.
  const double ttp_scale =
      part.facet_final_distance_mm / log.sphere_distance_mm;
  auto est_sigma_um = [&](int kind, double t) {
    // The ovality follows none of the machine's errors.
    if (kind == 4) return 0.0;
    const int e = kind;  // EX0C, EY0C, EZ0T, ER0T
    const double s = estimator.ErrorSigmaAt(e, t) * options.estimator_sigma_scale;
    return kind == 3 ? s * ttp_scale : s;
  };
  const double corr_s = estimator.CorrelationTimeS();

  Observations& obs = run.observations;
  for (const CycleFigures& m : measured.figures) {
    if (m.cycle < 1 ||
        m.cycle > static_cast<int>(run.simulation.figures.size()))
      continue;
    const CycleFigures& s = run.simulation.figures[m.cycle - 1];
    for (int g = 0; g < 4; ++g) {
      const double mv = FigureValueMm(m, g), sv = FigureValueMm(s, g);
      if (!std::isfinite(mv) || !std::isfinite(sv)) continue;
      obs.figure_cycle.push_back(m.cycle);
      obs.figure_kind.push_back(g);
      obs.figure_t_s.push_back(time_of(m.cycle));
      obs.figure_value_um.push_back((mv - sv) * 1e3);
      const double u = FigureUncertaintyMm(m, g) * 1e3;
      obs.figure_sigma_um.push_back(
          std::max(options.min_sigma_um, std::isfinite(u) ? u : 0.0));
    }
  }
  // The ovality per cycle, where the measurement has facet distances.
  for (int cycle = 1; cycle <= part.cycles() && !measured.features.empty();
       ++cycle) {
    double var_mm2 = 0;
    const double mv = OvalityMm(part, measured.features, cycle, &var_mm2);
    const double sv = OvalityMm(part, run.simulation.results, cycle);
    if (!std::isfinite(mv) || !std::isfinite(sv)) continue;
    obs.figure_cycle.push_back(cycle);
    obs.figure_kind.push_back(4);
    obs.figure_t_s.push_back(time_of(cycle));
    obs.figure_value_um.push_back((mv - sv) * 1e3);
    obs.figure_sigma_um.push_back(std::max(
        options.min_sigma_um, std::isfinite(var_mm2) ? std::sqrt(var_mm2) * 1e3
                                                     : 0.0));
  }
  for (const auto& [id, angle] : measured.facet_angle_rad) {
    const FeatureId* const facet = &id;
    auto it = run.simulation.results.find(*facet);
    if (it == run.simulation.results.end() || !it->second.present) continue;
    if (!facet->IsTestFeature()) continue;
    const int j = facet->index;
    obs.angle_feature.push_back(*facet);
    obs.angle_cycle.push_back(CycleForIndex(part, j));
    obs.angle_t_s.push_back(time_of(CycleForIndex(part, j)));
    obs.angle_value_urad.push_back((angle - it->second.angle_rad) * 1e6);
    double u = 0;
    auto mf = measured.features.find(*facet);
    if (mf != measured.features.end() &&
        std::isfinite(mf->second.var_angle_rad2))
      u = std::sqrt(mf->second.var_angle_rad2) * 1e6;
    obs.angle_sigma_urad.push_back(std::max(options.min_sigma_urad, u));
  }
  // Covariances: the measurement's variance on the diagonal; the
  // estimator's error common to a figure kind's observations, fully
  // correlated within a cycle and decaying over the R-test spacing across
  // cycles.
  auto rho = [&](double a, double b) {
    return std::exp(-std::abs(a - b) / std::max(corr_s, 1.0));
  };
  const size_t nf = obs.figures(), na = obs.angles();
  obs.figure_covariance_um2 = Eigen::MatrixXd::Zero(nf, nf);
  std::vector<double> est_figure(nf), est_angle(na);
  for (size_t i = 0; i < nf; ++i)
    est_figure[i] = est_sigma_um(obs.figure_kind[i], obs.figure_t_s[i]);
  for (size_t i = 0; i < na; ++i)
    est_angle[i] = estimator.ErrorSigmaAt(6, obs.angle_t_s[i]) *
                   options.estimator_sigma_scale;
  for (size_t i = 0; i < nf; ++i) {
    for (size_t j = 0; j < nf; ++j) {
      if (obs.figure_kind[i] != obs.figure_kind[j]) continue;
      obs.figure_covariance_um2(i, j) = est_figure[i] * est_figure[j] *
                                        rho(obs.figure_t_s[i], obs.figure_t_s[j]);
    }
    obs.figure_covariance_um2(i, i) += std::pow(obs.figure_sigma_um[i], 2);
  }
  obs.angle_covariance_urad2 = Eigen::MatrixXd::Zero(na, na);
  for (size_t i = 0; i < na; ++i) {
    for (size_t j = 0; j < na; ++j)
      obs.angle_covariance_urad2(i, j) =
          est_angle[i] * est_angle[j] * rho(obs.angle_t_s[i], obs.angle_t_s[j]);
    obs.angle_covariance_urad2(i, i) += std::pow(obs.angle_sigma_urad[i], 2);
  }
  if (options.anchor_reference_cycle) {
    std::vector<double> est_reference_var_um2(kFigureKinds);
    for (int g = 0; g < kFigureKinds; ++g)
      est_reference_var_um2[g] = std::pow(est_sigma_um(g, time_of(0)), 2);
    const ReferenceCycleVariance reference =
        ReferenceCycleVarianceUm2(part, measured, obs, est_reference_var_um2);
    obs.figure_reference_var_um2 = reference.common_um2;
    // The common part enters every pair of a kind's observations, the
    // diagonal included; the part of it a figure's own uncertainty already
    // holds comes off that figure's own variance (never below the floor
    // of an observation's sigma).
    for (size_t i = 0; i < nf; ++i) {
      const int g = obs.figure_kind[i];
      if (!std::isfinite(reference.common_um2[g])) continue;
      const double own = std::pow(obs.figure_sigma_um[i], 2);
      const double floor = std::pow(options.min_sigma_um, 2);
      obs.figure_covariance_um2(i, i) -= std::clamp(
          reference.in_figure_sigma_um2[g], 0.0, std::max(own - floor, 0.0));
    }
  }
  // The total standard uncertainty of each observation (for displays).
  for (size_t i = 0; i < nf; ++i) {
    const int g = obs.figure_kind[i];
    obs.figure_sigma_um[i] =
        std::sqrt(obs.figure_covariance_um2(i, i) +
                  (FreeOffset(obs, g) ? 0.0 : obs.figure_reference_var_um2[g]));
  }
  for (size_t i = 0; i < na; ++i)
    obs.angle_sigma_urad[i] = std::sqrt(obs.angle_covariance_urad2(i, i));
  return run;
}

DiagnosisReport DiagnoseRun(const thermal::TalcLog& log, const Config& config,
                            const MeasuredPiece& measured,
                            const DiagnosisOptions& options) {
  PreparedRun run = PrepareRun(log, config, measured, options);
  return DiagnosePrepared(std::move(run), log, config.part, measured, options);
}

namespace {
DiagnosisReport Refused(const std::string& reason) {
  DiagnosisReport r;
  r.status = DiagnosisStatus::kRefused;
  r.cause.clear();
  r.reason = reason;
  return r;
}

// The slope of the measured figure changes over the simulated ones (per
// kind offsets removed), over the first `kinds` figure kinds (2: E_X and
// E_Y; 3: E_Z too): 1 when the log describes the run that cut the piece.
// NaN when the simulation barely varies (nothing to compare).
double MismatchSlope(const PreparedRun& run, double* sd, int kinds = 2) {
  const Observations& obs = run.observations;
  double sxx = 0, sxy = 0, var_ref = 0;
  for (int g = 0; g < kinds; ++g) {
    std::vector<double> x, y, w;
    for (size_t i = 0; i < obs.figures(); ++i) {
      if (obs.figure_kind[i] != g) continue;
      const int c = obs.figure_cycle[i];
      const double sim = FigureValueMm(run.simulation.figures[c - 1], g) * 1e3;
      x.push_back(sim);
      y.push_back(sim + obs.figure_value_um[i]);
      w.push_back(1.0 / std::pow(obs.figure_sigma_um[i], 2));
    }
    if (x.size() < 3) continue;
    double sw = 0, mx = 0, my = 0;
    for (size_t k = 0; k < x.size(); ++k) {
      sw += w[k];
      mx += w[k] * x[k];
      my += w[k] * y[k];
    }
    mx /= sw;
    my /= sw;
    for (size_t k = 0; k < x.size(); ++k) {
      sxx += w[k] * (x[k] - mx) * (x[k] - mx);
      sxy += w[k] * (x[k] - mx) * (y[k] - my);
      var_ref += (x[k] - mx) * (x[k] - mx);
    }
  }
  if (!(sxx > 100.0)) return std::numeric_limits<double>::quiet_NaN();
  *sd = 1.0 / std::sqrt(sxx);
  return sxy / sxx;
}
}  // namespace

// DiagnosePrepared without what every outcome carries (the estimator's
// warnings).
static DiagnosisReport DecidePrepared(const PreparedRun& run,
                                      const thermal::TalcLog& log,
                                      const PartSpec& part,
                                      const MeasuredPiece& measured,
                                      const DiagnosisOptions& options) {
  if (!run.refusal.empty()) return Refused(run.refusal);
  DiagnosisReport report =
      Diagnose(run.observations, run.context, part, options);
  report.estimator = run.simulation.estimator_description;
  // A measurement whose E_X, E_Y and E_Z follow the simulated ones
  // mirrored (slope near -1) was most likely read with the wrong sign
  // convention: the refusal says so.
  const auto sign_hint = [&run]() -> std::string {
    double sd = 0;
    const double slope = MismatchSlope(run, &sd, 3);
    if (!std::isfinite(slope) || slope > -0.5 ||
        std::abs(slope + 1) > std::max(0.3, 3 * sd))
      return "";
    return fmt::format(
        " (its E_X, E_Y and E_Z follow the simulated ones with slope {:.2f} "
        "+- {:.2f}, mirrored: a reading of the wrong sign? measurements.md: "
        "dial readings of facets positive towards the axis, of strips "
        "positive downwards)",
        slope, sd);
  };
  // A refusal that keeps the evidence it was decided on.
  const auto refuse_keeping_evidence = [&report,
                                        &sign_hint](const std::string& reason) {
    DiagnosisReport refused = Refused(reason + sign_hint());
    refused.candidates = report.candidates;
    refused.observations = report.observations;
    refused.estimator = report.estimator;
    refused.machine_z = report.machine_z;
    refused.machine_pooled_z = report.machine_pooled_z;
    refused.machine_kind_z = report.machine_kind_z;
    refused.machine_pooled_z_one_kind = report.machine_pooled_z_one_kind;
    refused.machine_pooled_z_other_machine =
        report.machine_pooled_z_other_machine;
    refused.structure_z = report.structure_z;
    refused.best_evidence = report.best_evidence;
    refused.evidence_threshold = report.evidence_threshold;
    refused.step_chi2 = report.step_chi2;
    refused.trend_chi2 = report.trend_chi2;
    refused.trend_um = report.trend_um;
    return refused;
  };
  // The log of another run: the measured piece's E_X and E_Y (which no
  // known cause changes much) do not follow the simulated ones.
  const bool beyond_one_kind =
      report.machine_pooled_z_one_kind > options.refuse_after_one_kind_z;
  // ... and a machine of another run under this run's loads explains what
  // E_X, E_Y and E_Z keep: what another run's log leaves is smooth in
  // time; structure that moves each cycle its own way is the piece's, not
  // the log's (`unexplained`).
  const bool another_machine =
      report.machine_pooled_z_other_machine <= options.refuse_other_machine_z;
  if (report.status == DiagnosisStatus::kUnexplained &&
      report.machine_z > options.refuse_z && beyond_one_kind &&
      another_machine) {
    // E_X, E_Y and E_Z follow the machine's location errors, which the
    // log's R-tests measure and which no catalogue cause changes much
    // (after the best model): far beyond the error budget there, the log
    // does not describe the run that cut the piece.
    DiagnosisReport refused = refuse_keeping_evidence(fmt::format(
        "{} does not follow the machine errors of {}: {} (E_X, E_Y and E_Z "
        "follow the machine's location errors the R-tests measure; limit {:g} "
        "standard deviations): the measurement and the log do not belong "
        "together",
        measured.source.empty() ? "the piece" : measured.source, log.source,
        report.reason, options.refuse_z));
    return refused;
  }
  // A cause named while E_X, E_Y and E_Z (which no catalogue cause changes
  // much) stay off the simulated ones beyond the budget: the cause absorbs
  // what the log of another run leaves in the facet distances (an
  // instrument's few touches hide the mismatch in each kind alone).
  // Whatever the outcome, E_X, E_Y and E_Z pooled far beyond the budget
  // after the best model: the R-tests of the log imply machine location
  // errors the piece does not show (another run's log; a probe's or dial's
  // few touches keep each kind alone within its budget).
  const bool named_off_machine =
      report.status == DiagnosisStatus::kNamed &&
      report.machine_pooled_z > options.named_machine_z;
  if (beyond_one_kind && another_machine &&
      (named_off_machine ||
       report.machine_pooled_z > options.refuse_machine_pooled_z)) {
    DiagnosisReport refused = refuse_keeping_evidence(fmt::format(
        "{} does not follow the machine errors of {}: {} fits, but E_X, E_Y "
        "and E_Z, which no catalogue cause changes much, keep a chi2 "
        "deviate of {:.1f} after it (limit {:g}): the measurement and the "
        "log do not belong together",
        measured.source.empty() ? "the piece" : measured.source, log.source,
        report.status == DiagnosisStatus::kNamed ? report.cause
                                                 : "the best model",
        report.machine_pooled_z,
        report.status == DiagnosisStatus::kNamed
            ? options.named_machine_z
            : options.refuse_machine_pooled_z));
    refused.machine_pooled_z = report.machine_pooled_z;
    return refused;
  }
  // A cause fits but E_X, E_Y and E_Z stay off the log beyond the budget
  // in a way no other run's machine explains: the cause does not account
  // for the piece.
  if (beyond_one_kind && named_off_machine)
    WithdrawName(
        &report,
        fmt::format(
            "{} beats the nominal model, but E_X, E_Y and E_Z, which no "
            "catalogue cause changes much, keep a chi2 deviate of {:.1f} "
            "after it (limit {:g}) that neither one figure kind nor another "
            "run's machine explains: the residual holds structure that no "
            "known cause explains",
            report.cause, report.machine_pooled_z, options.named_machine_z));
  if (report.status == DiagnosisStatus::kUnexplained) {
    double sd = 0;
    const double slope = MismatchSlope(run, &sd);
    report.simulation_slope = slope;
    report.simulation_slope_sd = sd;
    if (std::isfinite(slope) &&
        std::abs(slope - 1) > options.mismatch_slope_limit &&
        std::abs(slope - 1) > 5 * sd) {
      DiagnosisReport refused = Refused(fmt::format(
          "the measured E_X and E_Y of {} follow the ones simulated from {} "
          "with slope {:.2f} +- {:.2f} instead of 1 (and no model fits: {}): "
          "the measurement and the log do not belong together{}",
          measured.source.empty() ? "the piece" : measured.source, log.source,
          slope, sd, report.reason, sign_hint()));
      refused.candidates = report.candidates;
      refused.observations = report.observations;
      refused.estimator = report.estimator;
      return refused;
    }
  }
  return report;
}

DiagnosisReport DiagnosePrepared(const PreparedRun& run,
                                 const thermal::TalcLog& log,
                                 const PartSpec& part,
                                 const MeasuredPiece& measured,
                                 const DiagnosisOptions& options) {
  // Named here, where the measurement's file is known (every caller).
  if (run.refusal.empty() && run.observations.size() == 0)
    throw InputError(measured.source.empty() ? "measurement" : measured.source,
                     0, "",
                     "no figure or facet angle to compare: the measurement "
                     "holds no cycle's features beside the reference "
                     "cycle's");
  DiagnosisReport report = DecidePrepared(run, log, part, measured, options);
  report.warnings = run.simulation.warnings;
  return report;
}

nlohmann::json DiagnosisToJson(const DiagnosisReport& r) {
  nlohmann::json params = nlohmann::json::object();
  nlohmann::json uncertainty = nlohmann::json::object();
  for (const auto& p : r.params) {
    params[p.name] = p.value;
    uncertainty[p.name] = p.uncertainty;
  }
  nlohmann::json candidates = nlohmann::json::array();
  for (const auto& c : r.candidates) {
    nlohmann::json cp = nlohmann::json::object();
    for (const auto& p : c.report_params)
      cp[p.name] = {{"value", p.value}, {"uncertainty", p.uncertainty}};
    nlohmann::json entry = {{"cause", c.name},
                            {"bic", c.bic},
                            {"delta_bic", c.delta_bic},
                            {"chi2", c.chi2},
                            {"parameters", c.parameters},
                            {"rms_um", c.rms_um},
                            {"rms_urad", c.rms_urad},
                            {"params", cp}};
    if (!c.note.empty()) entry["note"] = c.note;
    candidates.push_back(entry);
  }
  nlohmann::json structure = nlohmann::json::array();
  for (const auto& s : r.structure)
    structure.push_back({{"where", s.where},
                         {"rms", s.rms},
                         {"unit", s.unit},
                         {"chi2_per_observation", s.chi2_per_observation}});
  nlohmann::json j = {
      {"status", StatusName(r.status)},
      {"reason", r.reason},
      {"baseline",
       {{"rms_um", r.baseline_rms_um}, {"rms_urad", r.baseline_rms_urad}}},
      {"extended",
       {{"rms_um", r.extended_rms_um},
        {"rms_urad", r.extended_rms_urad},
        {"params", params},
        {"uncertainty", uncertainty}}},
      {"gain_pct", r.gain_pct},
      {"gain",
       {{"method",
         "leave one cycle out: the whole selection repeated without cycle "
         "k, its chosen model and the nominal model predicting cycle k; RMS "
         "of the held-out residuals (figures um, facet angles urad); "
         "gain_pct from the figures (from the angles for c_axis_indexing "
         "alone)"},
        {"heldout_baseline_rms_um", r.heldout_baseline_rms_um},
        {"heldout_extended_rms_um", r.heldout_extended_rms_um},
        {"heldout_baseline_rms_urad", r.heldout_baseline_rms_urad},
        {"heldout_extended_rms_urad", r.heldout_extended_rms_urad}}},
      {"evidence",
       "BIC = chi2 + k ln n, chi2 of the residuals whitened with their "
       "covariance (measurement, form, the estimator's cross-validated "
       "error common to a cycle and correlated across cycles, and the "
       "reference cycle's error common to every cycle of a figure kind; "
       "figures E_X, E_Y, E_Z, E_TTP, the ovality E_OV and facet angles, "
       "the angles with a fitted offset for their datum); a cause is named "
       "when its BIC is lower than the nominal model's by the threshold and "
       "it passes the tests of docs/DIAGNOSIS.md (goodness of fit, no step, "
       "drift or other lobe count explaining the data as well, held-out "
       "cycles)"},
      {"chi2_per_dof", r.chi2_per_dof},
      {"observations", r.observations},
      {"estimator", r.estimator},
      {"warnings", r.warnings},
      {"candidates", candidates}};
  if (r.status != DiagnosisStatus::kRefused) j["cause"] = r.cause;
  if (r.status == DiagnosisStatus::kUnexplained) {
    nlohmann::json where = nlohmann::json::array();
    for (const auto& l : structure)
      if (l["chi2_per_observation"].get<double>() > 2.0) where.push_back(l);
    j["unexplained"] = where.empty() ? structure : where;
  }
  j["residual_by_location"] = structure;
  // The statistics the decision was taken on (docs/DIAGNOSIS.md: the
  // thresholds and their calibration); null where not computed.
  auto finite_or_null = [](double v) {
    return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
  };
  nlohmann::json kind_z = nlohmann::json::object();
  for (size_t g = 0; g < r.machine_kind_z.size() && g < 3; ++g)
    kind_z[kFigureNames[g]] = finite_or_null(r.machine_kind_z[g]);
  j["decision"] = {
      {"best_evidence", finite_or_null(r.best_evidence)},
      {"evidence_threshold", r.evidence_threshold},
      {"largest_kind_deviate", finite_or_null(r.structure_z)},
      {"machine_kind_deviate", kind_z},
      {"machine_pooled_deviate", finite_or_null(r.machine_pooled_z)},
      {"machine_pooled_deviate_after_one_kind",
       finite_or_null(r.machine_pooled_z_one_kind)},
      {"machine_pooled_deviate_after_other_machine",
       finite_or_null(r.machine_pooled_z_other_machine)},
      {"step_chi2", r.step_chi2},
      {"trend_chi2", r.trend_chi2},
      {"trend_um", r.trend_um}};
  if (std::isfinite(r.simulation_slope))
    j["simulation_slope"] = {{"value", r.simulation_slope},
                             {"uncertainty", r.simulation_slope_sd}};
  return j;
}

std::string DiagnosisText(const DiagnosisReport& r) {
  std::string s = fmt::format("status: {}\n", StatusName(r.status));
  if (r.status != DiagnosisStatus::kRefused)
    s += fmt::format("cause: {}\n", r.cause);
  s += fmt::format("  ({})\n", r.reason);
  for (const std::string& w : r.warnings) s += "warning: " + w + "\n";
  if (r.status == DiagnosisStatus::kRefused) return s;
  for (const auto& p : r.params)
    s += fmt::format("  {} = {:.4g} +- {:.2g}\n", p.name, p.value,
                     p.uncertainty);
  if (r.status == DiagnosisStatus::kUnexplained) {
    s += "where the unexplained structure lives (RMS after the best model, "
         "chi2 per observation):\n";
    for (const auto& l : r.structure)
      s += fmt::format("  {:<24} {:8.3f} {:<4} {:7.1f}\n", l.where, l.rms,
                       l.unit, l.chi2_per_observation);
  }
  s += fmt::format(
      "residual RMS (figures, um): measured - simulated {:.3f}, nominal "
      "model {:.3f}, extended {:.3f}\n"
      "residual RMS (facet angles, urad): measured - simulated {:.3f}, "
      "nominal model {:.3f}, extended {:.3f}\n"
      "held-out cycles: figures {:.3f} -> {:.3f} um, angles {:.3f} -> {:.3f} "
      "urad; gain {:.1f} %\n"
      "(models: nominal simulation, {}; {} observations)\n\n",
      r.raw_rms_um, r.baseline_rms_um, r.extended_rms_um, r.raw_rms_urad,
      r.baseline_rms_urad, r.extended_rms_urad, r.heldout_baseline_rms_um,
      r.heldout_extended_rms_um, r.heldout_baseline_rms_urad,
      r.heldout_extended_rms_urad, r.gain_pct,
      r.figures_anchored ? "figures anchored on the reference cycle, facet "
                           "angles with a fitted offset"
                         : "a fitted offset per figure",
      r.observations);
  s += "candidate                                  k      chi2    delta BIC  "
       " rms_um  rms_urad\n";
  for (const auto& c : r.candidates)
    s += fmt::format("{:<40} {:>3} {:>9.1f} {:>12.1f} {:>8.3f} {:>9.3f}{}\n",
                     c.name, c.parameters, c.chi2, c.delta_bic, c.rms_um,
                     c.rms_urad, c.note.empty() ? "" : "  (" + c.note + ")");
  return s;
}

}  // namespace ttp::diagnosis
