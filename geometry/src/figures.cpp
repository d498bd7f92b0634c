#include "ttp/geometry/figures.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "ttp/geometry/constants.h"
#include "ttp/geometry/features.h"

namespace ttp {
namespace {

struct Term {
  const FeatureResult* r;
  double coefficient;
};

// Linear combination of feature values (d or angle) and its standard
// uncertainty, features taken as independent; NaN if any is missing.
std::pair<double, double> Combine(std::initializer_list<Term> terms,
                                  bool use_angle) {
  double value = 0, var = 0;
  for (const Term& t : terms) {
    if (t.r == nullptr || !t.r->present) return {kNaN, kNaN};
    value += t.coefficient * (use_angle ? t.r->angle_rad : t.r->d_mm);
    var += t.coefficient * t.coefficient *
           (use_angle ? t.r->var_angle_rad2 : t.r->var_d_mm2);
  }
  return {value, std::sqrt(var)};
}

const FeatureResult* Find(const FeatureResults& r, const FeatureId& id) {
  auto it = r.find(id);
  return it == r.end() ? nullptr : &it->second;
}

nlohmann::json NumberOrNull(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

}  // namespace

std::vector<FeatureId> IdsInNameOrder(const FeatureResults& results) {
  std::vector<std::pair<std::string, FeatureId>> named;
  for (const auto& entry : results)
    named.emplace_back(entry.first.ToString(), entry.first);
  std::sort(named.begin(), named.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<FeatureId> out;
  for (const auto& entry : named) out.push_back(entry.second);
  return out;
}

std::vector<CycleFigures> ComputeFigures(const PartSpec& part,
                                         const FeatureResults& results) {
  const int ref = part.reference_index;
  auto facet = [&](Segment s, int j) {
    return Find(results, FeatureId::Facet(s, j));
  };
  auto strip = [&](int k) { return Find(results, FeatureId::Strip(k)); };
  std::vector<CycleFigures> out;
  for (int cycle = 1; cycle <= part.cycles(); ++cycle) {
    const int j = IndexForCycle(part, cycle);
    const auto *x1 = facet(Segment::kX1, j), *x1r = facet(Segment::kX1, ref);
    const auto *x2 = facet(Segment::kX2, j), *x2r = facet(Segment::kX2, ref);
    const auto *y1 = facet(Segment::kY1, j), *y1r = facet(Segment::kY1, ref);
    const auto *y2 = facet(Segment::kY2, j), *y2r = facet(Segment::kY2, ref);
    CycleFigures f;
    f.cycle = cycle;
    std::tie(f.e_x_mm, f.u_x_mm) =
        Combine({{x2, 0.5}, {x2r, -0.5}, {x1, -0.5}, {x1r, 0.5}}, false);
    std::tie(f.e_y_mm, f.u_y_mm) =
        Combine({{y2, 0.5}, {y2r, -0.5}, {y1, -0.5}, {y1r, 0.5}}, false);
    std::tie(f.e_z_mm, f.u_z_mm) =
        Combine({{strip(j), 1.0}, {strip(ref), -1.0}}, false);
    std::tie(f.e_b_rad, f.u_b_rad) =
        Combine({{strip(j), 1.0}, {strip(ref), -1.0}}, true);
    std::tie(f.e_ttp_mm, f.u_ttp_mm) = Combine({{x1, -0.25},
                                                {x2, -0.25},
                                                {y1, -0.25},
                                                {y2, -0.25},
                                                {x1r, 0.25},
                                                {x2r, 0.25},
                                                {y1r, 0.25},
                                                {y2r, 0.25}},
                                               false);
    out.push_back(f);
  }
  return out;
}

double TemperatureChangeK(double radial_growth_mm, double alpha_per_k,
                          double radius_mm) {
  return radial_growth_mm / (alpha_per_k * radius_mm);
}

nlohmann::json FiguresToJson(const std::vector<CycleFigures>& figures) {
  nlohmann::json arr = nlohmann::json::array();
  for (const CycleFigures& f : figures) {
    arr.push_back({{"cycle", f.cycle},
                   {"E_X", NumberOrNull(f.e_x_mm * 1e3)},
                   {"E_Y", NumberOrNull(f.e_y_mm * 1e3)},
                   {"E_Z", NumberOrNull(f.e_z_mm * 1e3)},
                   {"E_B", NumberOrNull(f.e_b_rad * 1e6)},
                   {"E_TTP", NumberOrNull(f.e_ttp_mm * 1e3)},
                   {"U",
                    {{"E_X", NumberOrNull(2 * f.u_x_mm * 1e3)},
                     {"E_Y", NumberOrNull(2 * f.u_y_mm * 1e3)},
                     {"E_Z", NumberOrNull(2 * f.u_z_mm * 1e3)},
                     {"E_B", NumberOrNull(2 * f.u_b_rad * 1e6)},
                     {"E_TTP", NumberOrNull(2 * f.u_ttp_mm * 1e3)}}}});
  }
  return {{"figures", arr}};
}

}  // namespace ttp
