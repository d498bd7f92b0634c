// PartMesh measures, stage/format names, the nominal feature table, surface
// sampling and WritePartMeshes (the export used by `ttp part export` and
// `ttp run`).
#include "ttp/geometry/part_mesh.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>

#include "ttp/geometry/error.h"
#include "ttp/geometry/file_io.h"
#include "ttp/geometry/json_text.h"

namespace ttp {

int PartMesh::FeatureIndex(const std::string& id) const {
  const auto it = std::find(feature_ids.begin(), feature_ids.end(), id);
  return it == feature_ids.end() ? -1
                                 : static_cast<int>(it - feature_ids.begin());
}

double PartMesh::TriangleAreaMm2(int t) const {
  const auto& tri = triangles[t];
  return 0.5 * (vertices[tri[1]] - vertices[tri[0]])
                   .cross(vertices[tri[2]] - vertices[tri[0]])
                   .norm();
}

Eigen::Vector3d PartMesh::TriangleNormal(int t) const {
  const auto& tri = triangles[t];
  return (vertices[tri[1]] - vertices[tri[0]])
      .cross(vertices[tri[2]] - vertices[tri[0]])
      .normalized();
}

double PartMesh::FeatureAreaMm2(const std::string& id) const {
  const int index = FeatureIndex(id);
  double area = 0;
  for (size_t t = 0; t < triangles.size(); ++t) {
    if (triangle_feature[t] == index) area += TriangleAreaMm2(t);
  }
  return index < 0 ? 0.0 : area;
}

double PartMesh::AreaMm2() const {
  double area = 0;
  for (size_t t = 0; t < triangles.size(); ++t) area += TriangleAreaMm2(t);
  return area;
}

double PartMesh::VolumeMm3() const {
  // Sum of signed tetrahedra against a point near the mesh (keeps the
  // terms small and the sum accurate).
  const Eigen::Vector3d o =
      vertices.empty() ? Eigen::Vector3d::Zero() : vertices.front();
  double six_v = 0;
  for (const auto& tri : triangles) {
    six_v += (vertices[tri[0]] - o)
                 .dot((vertices[tri[1]] - o).cross(vertices[tri[2]] - o));
  }
  return six_v / 6.0;
}

const char* StageName(Stage stage) {
  switch (stage) {
    case Stage::kBlank:
      return "blank";
    case Stage::kPreMachined:
      return "pre";
    case Stage::kFinished:
      return "finished";
  }
  return "?";
}

Stage ParseStage(const std::string& text, const std::string& source,
                 const std::string& field) {
  if (text == "blank") return Stage::kBlank;
  if (text == "pre") return Stage::kPreMachined;
  if (text == "finished") return Stage::kFinished;
  throw InputError(source, 0, field,
                   "'" + text + "' is not blank, pre or finished");
}

MeshFormat ParseMeshFormat(const std::string& text, const std::string& source,
                           const std::string& field) {
  if (text == "stl") return MeshFormat::kStl;
  if (text == "obj") return MeshFormat::kObj;
  if (text == "ply") return MeshFormat::kPly;
  throw InputError(source, 0, field, "'" + text + "' is not stl, obj or ply");
}

const char* MeshFormatExtension(MeshFormat format) {
  switch (format) {
    case MeshFormat::kStl:
      return "stl";
    case MeshFormat::kObj:
      return "obj";
    case MeshFormat::kPly:
      return "ply";
  }
  return "?";
}

const char* FeatureKindName(FeatureKind kind) {
  switch (kind) {
    case FeatureKind::kFacet:
      return "facet";
    case FeatureKind::kStrip:
      return "strip";
    case FeatureKind::kTopFace:
      return "top";
    case FeatureKind::kFlank:
      return "flank";
    case FeatureKind::kCylinder:
      return "cylinder";
    case FeatureKind::kNotchFloor:
      return "notch_floor";
    case FeatureKind::kMark:
      return "mark";
    case FeatureKind::kSphere:
      return "sphere";
  }
  return "?";
}

std::string NominalFeaturesCsv(const std::vector<NominalFeature>& features) {
  std::string out =
      "id,kind,point_x_mm,point_y_mm,point_z_mm,normal_x,normal_y,normal_z,"
      "size_mm,t_min_mm,t_max_mm,z_min_mm,z_max_mm,segment,index,cycle\n";
  for (const NominalFeature& f : features) {
    out +=
        fmt::format("{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n", f.id,
                    FeatureKindName(f.kind), f.point.x(), f.point.y(),
                    f.point.z(), f.normal.x(), f.normal.y(), f.normal.z(),
                    f.size_mm, f.t_min_mm, f.t_max_mm, f.z_min_mm, f.z_max_mm,
                    f.segment ? SegmentName(*f.segment) : "", f.index, f.cycle);
  }
  return out;
}

nlohmann::json NominalFeaturesJson(
    const std::vector<NominalFeature>& features) {
  nlohmann::json list = nlohmann::json::array();
  for (const NominalFeature& f : features) {
    nlohmann::json j;
    j["id"] = f.id;
    j["kind"] = FeatureKindName(f.kind);
    j["point_mm"] = {f.point.x(), f.point.y(), f.point.z()};
    j[f.kind == FeatureKind::kCylinder ? "axis"
      : f.kind == FeatureKind::kMark   ? "direction"
                                     : "normal"] = {f.normal.x(), f.normal.y(),
                                                    f.normal.z()};
    j["size_mm"] = f.size_mm;
    j["t_range_mm"] = {f.t_min_mm, f.t_max_mm};
    j["z_range_mm"] = {f.z_min_mm, f.z_max_mm};
    if (f.segment) j["segment"] = SegmentName(*f.segment);
    if (f.index > 0) j["index"] = f.index;
    if (f.cycle >= 0) j["cycle"] = f.cycle;
    list.push_back(j);
  }
  return list;
}

std::vector<std::filesystem::path> WritePartMeshes(
    const Config& config, const std::filesystem::path& dir,
    const std::vector<Stage>& stages, const std::vector<MeshFormat>& formats,
    const PartMeshOptions& options) {
  std::vector<std::filesystem::path> written;
  for (Stage stage : stages) {
    const PartMesh mesh = BuildPartMesh(config.part, stage, options);
    const std::string stem = std::string("part-") + StageName(stage);
    for (MeshFormat format : formats) {
      const auto path = dir / (stem + "." + MeshFormatExtension(format));
      WritePartMesh(mesh, path, format);
      written.push_back(path);
    }
    const auto features = BuildNominalFeatures(config.part, stage);
    const auto csv =
        dir / (std::string("features-") + StageName(stage) + ".csv");
    WriteFileAtomic(csv, NominalFeaturesCsv(features));
    written.push_back(csv);
    const auto json =
        dir / (std::string("features-") + StageName(stage) + ".json");
    WriteFileAtomic(json, JsonText(NominalFeaturesJson(features), 2) + "\n");
    written.push_back(json);
  }
  return written;
}

std::vector<std::filesystem::path> WritePartMeshes(
    const Config& config, const std::filesystem::path& dir) {
  return WritePartMeshes(config, dir,
                         {Stage::kBlank, Stage::kPreMachined, Stage::kFinished},
                         {MeshFormat::kStl, MeshFormat::kPly});
}

std::vector<SurfaceSample> SampleSurface(const PartMesh& mesh, int n,
                                         uint32_t seed) {
  std::vector<SurfaceSample> samples;
  if (n <= 0 || mesh.triangles.empty()) return samples;
  std::vector<double> cumulative(mesh.triangles.size());
  double total = 0;
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    total += mesh.TriangleAreaMm2(static_cast<int>(t));
    cumulative[t] = total;
  }
  // mt19937 and a hand-made uniform (not std::uniform_real_distribution,
  // whose output differs between standard libraries).
  std::mt19937 rng(seed);
  const auto uniform = [&rng] { return (rng() + 0.5) / 4294967296.0; };
  samples.reserve(n);
  for (int i = 0; i < n; ++i) {
    const double pick = uniform() * total;
    const int t = static_cast<int>(std::min<size_t>(
        std::lower_bound(cumulative.begin(), cumulative.end(), pick) -
            cumulative.begin(),
        cumulative.size() - 1));
    double u = uniform(), v = uniform();
    if (u + v > 1) {
      u = 1 - u;
      v = 1 - v;
    }
    const auto& tri = mesh.triangles[t];
    const Eigen::Vector3d& a = mesh.vertices[tri[0]];
    SurfaceSample s;
    s.point =
        a + u * (mesh.vertices[tri[1]] - a) + v * (mesh.vertices[tri[2]] - a);
    s.normal = mesh.TriangleNormal(t);
    s.triangle = t;
    s.feature = mesh.triangle_feature[t];
    samples.push_back(s);
  }
  return samples;
}

}  // namespace ttp
