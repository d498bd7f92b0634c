// Mesh checks and files with OpenMesh: topology check, STL (ASCII, one
// named solid per feature), OBJ with feature groups and PLY with a per-face
// feature index (written here: OpenMesh writes neither groups nor header
// comments), PLY read back by a strict parser of that layout.
#include <fmt/format.h>

#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <cstring>
#include <sstream>

#include "ttp/geometry/error.h"
#include "ttp/geometry/file_io.h"
#include "ttp/geometry/part_mesh.h"

namespace ttp {
namespace {

struct DoubleTraits : public OpenMesh::DefaultTraits {
  using Point = OpenMesh::Vec3d;
  using Normal = OpenMesh::Vec3d;
};
using OmMesh = OpenMesh::TriMesh_ArrayKernelT<DoubleTraits>;

void AppendRaw(std::string* out, const void* data, size_t size) {
  out->append(static_cast<const char*>(data), size);
}

std::string PlyBytes(const PartMesh& mesh) {
  std::string out = "ply\nformat binary_little_endian 1.0\n";
  out +=
      fmt::format("comment ttp part mesh, stage {}\n", StageName(mesh.stage));
  for (size_t i = 0; i < mesh.feature_ids.size(); ++i) {
    out += fmt::format("comment feature {} {}\n", i, mesh.feature_ids[i]);
  }
  out += fmt::format(
      "element vertex {}\nproperty double x\nproperty double y\n"
      "property double z\nelement face {}\n"
      "property list uchar int vertex_indices\nproperty int feature\n"
      "end_header\n",
      mesh.vertices.size(), mesh.triangles.size());
  static_assert(sizeof(double) == 8 && sizeof(int32_t) == 4);
  // x86-64 is little-endian: the native bytes are the file's bytes.
  for (const Eigen::Vector3d& v : mesh.vertices) {
    const double xyz[3] = {v.x(), v.y(), v.z()};
    AppendRaw(&out, xyz, sizeof xyz);
  }
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const uint8_t count = 3;
    AppendRaw(&out, &count, 1);
    const int32_t ids[4] = {mesh.triangles[t][0], mesh.triangles[t][1],
                            mesh.triangles[t][2], mesh.triangle_feature[t]};
    AppendRaw(&out, ids, sizeof ids);
  }
  return out;
}

std::string ObjText(const PartMesh& mesh) {
  std::string out = fmt::format("# ttp part mesh, stage {}, W frame, mm\n",
                                StageName(mesh.stage));
  for (const Eigen::Vector3d& v : mesh.vertices) {
    out += fmt::format("v {} {} {}\n", v.x(), v.y(), v.z());
  }
  for (size_t f = 0; f < mesh.feature_ids.size(); ++f) {
    out += "g " + mesh.feature_ids[f] + "\n";
    for (size_t t = 0; t < mesh.triangles.size(); ++t) {
      if (mesh.triangle_feature[t] != static_cast<int>(f)) continue;
      const auto& tri = mesh.triangles[t];
      out += fmt::format("f {} {} {}\n", tri[0] + 1, tri[1] + 1, tri[2] + 1);
    }
  }
  return out;
}

// ASCII STL with one named solid per feature ("solid X1-5" ...
// "endsolid X1-5"): OpenMesh's STL writer writes a single unnamed solid, so
// the feature tags could not be kept. Coordinates are written as the
// shortest text that reads back to the same double, so shared vertices
// stay shared for readers that merge equal points (OpenMesh does).
std::string StlText(const PartMesh& mesh) {
  std::string out;
  out.reserve(mesh.triangles.size() * 260);
  for (size_t f = 0; f < mesh.feature_ids.size(); ++f) {
    const std::string& id = mesh.feature_ids[f];
    out += "solid " + id + "\n";
    for (size_t t = 0; t < mesh.triangles.size(); ++t) {
      if (mesh.triangle_feature[t] != static_cast<int>(f)) continue;
      const Eigen::Vector3d n = mesh.TriangleNormal(static_cast<int>(t));
      out += fmt::format("  facet normal {} {} {}\n    outer loop\n", n.x(),
                         n.y(), n.z());
      for (int k = 0; k < 3; ++k) {
        const Eigen::Vector3d& v = mesh.vertices[mesh.triangles[t][k]];
        out += fmt::format("      vertex {} {} {}\n", v.x(), v.y(), v.z());
      }
      out += "    endloop\n  endfacet\n";
    }
    out += "endsolid " + id + "\n";
  }
  return out;
}

}  // namespace

std::string CheckClosedManifold(const PartMesh& mesh) {
  OmMesh om;
  std::vector<OmMesh::VertexHandle> handles;
  for (const Eigen::Vector3d& v : mesh.vertices) {
    handles.push_back(om.add_vertex(OmMesh::Point(v.x(), v.y(), v.z())));
  }
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& tri = mesh.triangles[t];
    for (int k = 0; k < 3; ++k) {
      if (tri[k] < 0 || tri[k] >= static_cast<int>(handles.size())) {
        return fmt::format("triangle {} has a bad vertex index", t);
      }
    }
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2]) {
      return fmt::format("triangle {} is degenerate", t);
    }
    // OpenMesh refuses a face that would make an edge non-manifold or
    // flip orientation against its neighbour.
    if (!om.add_face(handles[tri[0]], handles[tri[1]], handles[tri[2]])
             .is_valid()) {
      return fmt::format("triangle {} makes a complex edge or flips", t);
    }
  }
  for (auto h : om.halfedges()) {
    if (om.is_boundary(h)) {
      const auto p = om.point(om.from_vertex_handle(h));
      return fmt::format("open boundary at ({}, {}, {})", p[0], p[1], p[2]);
    }
  }
  for (auto v : om.vertices()) {
    if (!om.is_manifold(v)) {
      const auto p = om.point(v);
      return fmt::format("non-manifold vertex at ({}, {}, {})", p[0], p[1],
                         p[2]);
    }
    if (v.valence() == 0) return "unused vertex";
  }
  return "";
}

void WritePartMesh(const PartMesh& mesh, const std::filesystem::path& path,
                   MeshFormat format) {
  switch (format) {
    case MeshFormat::kStl:
      WriteFileAtomic(path, StlText(mesh));
      return;
    case MeshFormat::kObj:
      WriteFileAtomic(path, ObjText(mesh));
      return;
    case MeshFormat::kPly:
      WriteFileAtomic(path, PlyBytes(mesh));
      return;
  }
}

PartMesh ReadPartMeshPly(const std::filesystem::path& path) {
  // Our own layout, parsed here: OpenMesh's PLY reader keeps only float
  // precision of the coordinates (its use is checked in the tests).
  const std::string source = path.string();
  const std::string bytes = ReadTextFile(path);
  const std::string end_marker = "end_header\n";
  const size_t header_end = bytes.find(end_marker);
  if (bytes.rfind("ply\n", 0) != 0 || header_end == std::string::npos) {
    throw InputError(source, 1, "header", "not a PLY file");
  }
  PartMesh mesh;
  std::istringstream header(bytes.substr(0, header_end));
  std::string line;
  int line_number = 0;
  size_t vertex_count = 0, face_count = 0;
  std::string layout;
  while (std::getline(header, line)) {
    ++line_number;
    std::istringstream words(line);
    std::string w1, w2;
    words >> w1 >> w2;
    if (w1 == "comment" && w2 == "feature") {
      size_t index;
      std::string id;
      if (!(words >> index >> id) || index != mesh.feature_ids.size()) {
        throw InputError(source, line_number, "comment feature",
                         "expected 'comment feature <next index> <id>'");
      }
      mesh.feature_ids.push_back(id);
    } else if (w1 == "comment" && w2 == "ttp") {
      mesh.stage =
          ParseStage(line.substr(line.rfind(' ') + 1), source, "stage");
    } else if (w1 == "element") {
      size_t count;
      if (!(words >> count)) {
        throw InputError(source, line_number, "element", "count missing");
      }
      (w2 == "vertex" ? vertex_count : face_count) = count;
      layout += w1 + " " + w2 + "\n";
    } else if (w1 != "comment" && w1 != "ply") {
      layout += line + "\n";
    }
  }
  const std::string expected_layout =
      "format binary_little_endian 1.0\nelement vertex\nproperty double x\n"
      "property double y\nproperty double z\nelement face\n"
      "property list uchar int vertex_indices\nproperty int feature\n";
  if (layout != expected_layout) {
    throw InputError(source, 0, "header",
                     "not a ttp part mesh layout (binary, double x y z, "
                     "triangles with an int feature)");
  }
  size_t at = header_end + end_marker.size();
  if (bytes.size() != at + vertex_count * 24 + face_count * 17) {
    throw InputError(source, 0, "body", "size does not match the header");
  }
  for (size_t v = 0; v < vertex_count; ++v, at += 24) {
    double xyz[3];
    std::memcpy(xyz, bytes.data() + at, sizeof xyz);
    mesh.vertices.emplace_back(xyz[0], xyz[1], xyz[2]);
  }
  for (size_t f = 0; f < face_count; ++f, at += 17) {
    int32_t ids[4];
    if (bytes[at] != 3) {
      throw InputError(source, 0, "face",
                       fmt::format("face {} is not a triangle", f));
    }
    std::memcpy(ids, bytes.data() + at + 1, sizeof ids);
    for (int k = 0; k < 3; ++k) {
      if (ids[k] < 0 || ids[k] >= static_cast<int32_t>(vertex_count)) {
        throw InputError(source, 0, "vertex_indices",
                         fmt::format("face {} has a bad vertex index", f));
      }
    }
    if (ids[3] < 0 || ids[3] >= static_cast<int32_t>(mesh.feature_ids.size())) {
      throw InputError(
          source, 0, "feature",
          fmt::format("face {}: index {} has no comment line", f, ids[3]));
    }
    mesh.triangles.push_back({ids[0], ids[1], ids[2]});
    mesh.triangle_feature.push_back(ids[3]);
  }
  return mesh;
}

}  // namespace ttp
