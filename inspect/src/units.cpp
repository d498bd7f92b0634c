// Stage 0 of the cloud inspection: is the cloud a test piece in
// millimetres? The piece is about 203 mm across; the cloud's robust extent
// (1 % to 99 % quantiles per axis, on at most 100,000 points) tells metres
// and inches from millimetres before anything is fitted.
#include <string>

#include "cloud_util.h"
#include "ttp/geometry/error.h"
#include "ttp/inspect/cloud_stages.h"

namespace ttp::inspect {

using internal::Quantile;
using internal::Subsample;

// Below this many points the extent is no evidence of the units.
constexpr Eigen::Index kMinPointsForUnits = 100;

void CheckCloudUnits(const PartSpec& part, const PointCloud& cloud,
                     const InspectOptions& o) {
  if (!o.check_units) return;
  const Eigen::Matrix3Xd& p = cloud.xyz_mm;
  // A handful of points says nothing about units: the extent of a few
  // points on one facet looks like inches. The alignment names the count.
  if (p.cols() < kMinPointsForUnits) return;
  double extent = 0;
  const internal::Indices some = Subsample(p.cols(), 100000);
  for (int a = 0; a < 3; ++a) {
    std::vector<double> v(some.size());
    for (size_t k = 0; k < some.size(); ++k) v[k] = p(a, some[k]);
    extent = std::max(extent, Quantile(v, 0.99) - Quantile(v, 0.01));
  }
  const double expected = part.blank_diameter_mm;
  const std::string& source = cloud.source;
  if (extent < expected / 200 && extent > expected / 5000) {
    throw InputError(source, 0, "units",
                     "the cloud is " + std::to_string(extent) +
                         " units across where the piece is " +
                         std::to_string(expected) +
                         " mm: it looks like metres; pass --units m");
  }
  if (extent > expected / 40 && extent < expected / 10) {
    throw InputError(source, 0, "units",
                     "the cloud is " + std::to_string(extent) +
                         " units across where the piece is " +
                         std::to_string(expected) +
                         " mm: it looks like inches; pass --units in");
  }
  if (extent < expected / 3 || extent > expected * 5) {
    throw InputError(source, 0, "alignment",
                     "no test piece found in the cloud: the cloud is " +
                         std::to_string(extent) + " mm across, the piece " +
                         std::to_string(expected) + " mm");
  }
}

}  // namespace ttp::inspect
