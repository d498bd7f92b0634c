#include "ttp/geometry/series.h"

#include <cmath>

namespace ttp {

std::vector<double> LagFilter(const std::vector<double>& input, double step_s,
                              double tau_s) {
  std::vector<double> out(input.size(), 0.0);
  if (input.empty()) return out;
  const double a = std::exp(-step_s / std::max(tau_s, 1e-9));
  out[0] = input[0];
  // Over one step with u linear from u0 to u1, the exact solution is
  // y1 = a y0 + (1 - a) u0 + (u1 - u0) (1 - tau / step (1 - a)).
  const double ramp = 1 - tau_s / step_s * (1 - a);
  for (size_t i = 1; i < input.size(); ++i)
    out[i] = a * out[i - 1] + (1 - a) * input[i - 1] +
             (input[i] - input[i - 1]) * ramp;
  return out;
}

}  // namespace ttp
