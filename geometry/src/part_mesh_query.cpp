// PartQuery: closest point, feature and signed distance on a part mesh with
// CGAL's AABB tree (double kernel; the mesh's own coordinates).
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>

#include "ttp/geometry/part_mesh.h"

namespace ttp {
namespace {
using Kd = CGAL::Simple_cartesian<double>;
using Triangles = std::vector<Kd::Triangle_3>;
using Primitive = CGAL::AABB_triangle_primitive<Kd, Triangles::const_iterator>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<Kd, Primitive>>;

Kd::Point_3 ToCgal(const Eigen::Vector3d& p) {
  return Kd::Point_3(p.x(), p.y(), p.z());
}
}  // namespace

struct PartQuery::Impl {
  Triangles triangles;
  Tree tree;
};

PartQuery::PartQuery(const PartMesh& mesh)
    : mesh_(mesh), impl_(std::make_unique<Impl>()) {
  impl_->triangles.reserve(mesh.triangles.size());
  for (const auto& t : mesh.triangles) {
    impl_->triangles.emplace_back(ToCgal(mesh.vertices[t[0]]),
                                  ToCgal(mesh.vertices[t[1]]),
                                  ToCgal(mesh.vertices[t[2]]));
  }
  impl_->tree.insert(impl_->triangles.cbegin(), impl_->triangles.cend());
  impl_->tree.accelerate_distance_queries();
}

PartQuery::~PartQuery() = default;

PartQuery::Hit PartQuery::Closest(const Eigen::Vector3d& p) const {
  const auto [point, primitive] =
      impl_->tree.closest_point_and_primitive(ToCgal(p));
  Hit hit;
  hit.point = Eigen::Vector3d(point.x(), point.y(), point.z());
  hit.triangle = static_cast<int>(primitive - impl_->triangles.cbegin());
  hit.normal = mesh_.TriangleNormal(hit.triangle);
  hit.feature = mesh_.triangle_feature[hit.triangle];
  hit.feature_id = mesh_.feature_ids[hit.feature];
  const double distance = (p - hit.point).norm();
  hit.signed_distance_mm =
      (p - hit.point).dot(hit.normal) < 0 ? -distance : distance;
  return hit;
}

double PartQuery::SignedDistanceMm(const Eigen::Vector3d& p) const {
  return Closest(p).signed_distance_mm;
}

double SignedDistanceMm(const PartMesh& mesh, const Eigen::Vector3d& p) {
  return PartQuery(mesh).SignedDistanceMm(p);
}

}  // namespace ttp
