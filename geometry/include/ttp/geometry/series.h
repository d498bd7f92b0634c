// Time series helpers shared by the thermal model, the diagnosis and the
// twin: piecewise-linear interpolation of samples and a first-order lag.
#pragma once

#include <algorithm>
#include <vector>

namespace ttp {

// Piecewise-linear interpolation of samples v at strictly increasing times
// t (same length, at least one), held constant outside [t.front, t.back].
// V is any type with V * double and V + V (double, Eigen vectors).
template <class V>
V Interpolate(const std::vector<double>& t, const std::vector<V>& v, double x) {
  if (x <= t.front()) return v.front();
  if (x >= t.back()) return v.back();
  const size_t i = std::upper_bound(t.begin(), t.end(), x) - t.begin();
  const double w = (x - t[i - 1]) / (t[i] - t[i - 1]);
  return v[i - 1] * (1 - w) + v[i] * w;
}

// The same on a uniform grid: samples v at t0_s + i * step_s (none: 0).
inline double InterpolateUniform(const std::vector<double>& v, double t0_s,
                                 double step_s, double x) {
  if (v.empty()) return 0;
  const double u = (x - t0_s) / step_s;
  if (u <= 0) return v.front();
  const size_t i = static_cast<size_t>(u);
  if (i + 1 >= v.size()) return v.back();
  const double w = u - i;
  return v[i] * (1 - w) + v[i + 1] * w;
}

// First-order lag y' = (u - y) / tau of `input` sampled every step_s,
// starting in steady state (y[0] = u[0]), exact for an input linear across
// each step (first-order hold). tau_s <= 0 is taken as 1e-9 s (y = u).
std::vector<double> LagFilter(const std::vector<double>& input, double step_s,
                              double tau_s);

}  // namespace ttp
