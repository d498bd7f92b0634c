// Reading the exported meshes back with OpenMesh, independently of the
// library's own mesh code.
#pragma once

#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <vector>

namespace ttp::test {

struct OmDouble : public OpenMesh::DefaultTraits {
  using Point = OpenMesh::Vec3d;
  using Normal = OpenMesh::Vec3d;
};
using OmMesh = OpenMesh::TriMesh_ArrayKernelT<OmDouble>;

// Enclosed volume by the divergence theorem, mm^3 (faces are triangles).
inline double OmVolume(const OmMesh& om) {
  double six_v = 0;
  for (auto f : om.faces()) {
    std::vector<OpenMesh::Vec3d> p;
    for (auto v : om.fv_range(f)) p.push_back(om.point(v));
    six_v += OpenMesh::dot(p[0], OpenMesh::cross(p[1], p[2]));
  }
  return six_v / 6;
}

}  // namespace ttp::test
