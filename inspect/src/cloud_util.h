// Small order statistics and subsampling shared by the cloud stages (not
// part of the public API).
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <limits>
#include <vector>

namespace ttp::inspect::internal {

using Index = Eigen::Index;
using Indices = std::vector<Index>;

inline double Median(std::vector<double> v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + mid, v.end());
  return v[mid];
}

inline double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * v.size()));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

// Every k-th index of 0..n-1 so that at most `max` remain (all if n <= max).
inline Indices Subsample(Index n, Index max) {
  const Index step = std::max<Index>(1, (n + max - 1) / max);
  Indices out;
  out.reserve(static_cast<size_t>(n / step + 1));
  for (Index i = 0; i < n; i += step) out.push_back(i);
  return out;
}

}  // namespace ttp::inspect::internal
