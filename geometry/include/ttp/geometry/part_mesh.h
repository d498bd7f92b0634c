// Triangle meshes of the piece (blank, pre-machined, finished) built from a
// PartSpec, with every triangle tagged by the feature it belongs to (ids of
// features.h plus "BOTTOM", "RIM", "BOLT_HOLE", "NOTCH_SMALL_WALL",
// "OTHER"), writers (STL, OBJ, PLY), the nominal feature table, an
// AABB-tree spatial query and deterministic surface sampling.
//
// The piece is a stack of prismatic z-bands; each band's cross-section is a
// boolean of convex polygons (base discs minus notches, facet half-planes,
// strips, mark, bolt holes). All polygon edges are overlaid exactly in one
// constrained triangulation (CGAL, exact kernel), so walls and horizontal
// faces share vertices and the mesh is closed and manifold by construction.
// Circles are inscribed polygons within chord_error_mm of the true circle.
// The engraved mark is modelled as a rectangular slot (width x depth).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "ttp/geometry/config.h"
#include "ttp/geometry/features.h"

namespace ttp {

struct PartMeshOptions {
  double chord_error_mm = 0.005;  // max distance of a polygon to its circle
  // A facet pass runs this far past its neighbours' corners (spec: about
  // 1 mm); at a segment end it runs out into the notch.
  double facet_overrun_mm = 1.0;
  // Ceres style: false with "PartMeshOptions.<field>: <problem>".
  bool IsValid(std::string* error) const;
};

struct PartMesh {
  Stage stage = Stage::kFinished;
  std::vector<Eigen::Vector3d> vertices;      // W frame, mm
  std::vector<std::array<int, 3>> triangles;  // counter-clockwise from outside
  std::vector<int> triangle_feature;          // index into feature_ids
  std::vector<std::string> feature_ids;       // "X1-5", "TOP", ...

  // Index of a feature id, -1 if no triangle carries it.
  int FeatureIndex(const std::string& id) const;
  // Total area of the triangles tagged `id` (0 if none), mm^2.
  double FeatureAreaMm2(const std::string& id) const;
  double AreaMm2() const;
  // Enclosed volume (divergence theorem), mm^3.
  double VolumeMm3() const;
  Eigen::Vector3d TriangleNormal(int triangle) const;  // unit, outward
  double TriangleAreaMm2(int triangle) const;
};

const char* StageName(Stage stage);  // "blank", "pre", "finished"
// Parses "blank" | "pre" | "finished"; throws InputError(source, 0, field).
Stage ParseStage(const std::string& text, const std::string& source,
                 const std::string& field);

// Throws InputError("part", 0, "part.<field>", why) for a spec the mesher
// cannot build (non-positive sizes, facets outside the rim, ...).
PartMesh BuildPartMesh(const PartSpec& part, Stage stage,
                       const PartMeshOptions& options = {});

// Checks with OpenMesh that the mesh is closed (no boundary halfedge) and
// two-manifold (every vertex manifold, every triangle accepted). Returns an
// empty string when it is, else what is wrong.
std::string CheckClosedManifold(const PartMesh& mesh);

enum class MeshFormat { kStl, kObj, kPly };
MeshFormat ParseMeshFormat(const std::string& text, const std::string& source,
                           const std::string& field);
const char* MeshFormatExtension(MeshFormat format);  // "stl", ...

// Writes atomically (temporary file + rename). STL ASCII with one named
// solid per feature ("solid X1-5"); OBJ with one group per feature
// ("g X1-5"); PLY binary little-endian with a face
// property "feature" (int) and header comments "feature <index> <id>".
void WritePartMesh(const PartMesh& mesh, const std::filesystem::path& path,
                   MeshFormat format);

// Reads back a PLY written by WritePartMesh (OpenMesh reader): geometry and
// feature tags. Throws InputError naming the file when it cannot.
PartMesh ReadPartMeshPly(const std::filesystem::path& path);

// Nominal feature table: one row per feature (id, kind, point, normal or
// axis, size, extents, segment, index, cycle).
std::string NominalFeaturesCsv(const std::vector<NominalFeature>& features);
nlohmann::json NominalFeaturesJson(const std::vector<NominalFeature>& features);
const char* FeatureKindName(FeatureKind kind);

// Writes <dir>/part-<stage>.<ext> for each stage and format, plus
// <dir>/features-<stage>.csv/.json. Returns the files written, in order.
std::vector<std::filesystem::path> WritePartMeshes(
    const Config& config, const std::filesystem::path& dir,
    const std::vector<Stage>& stages, const std::vector<MeshFormat>& formats,
    const PartMeshOptions& options = {});
// What `ttp run` writes: all three stages as STL and PLY + feature tables.
// Returns the files written, in order.
std::vector<std::filesystem::path> WritePartMeshes(
    const Config& config, const std::filesystem::path& dir);

struct SurfaceSample {
  Eigen::Vector3d point;   // on the surface, W, mm
  Eigen::Vector3d normal;  // outward unit normal
  int triangle = -1;
  int feature = -1;  // index into PartMesh::feature_ids
};

// n points distributed by area over the whole surface (uniform in each
// triangle); same mesh + n + seed -> same points.
std::vector<SurfaceSample> SampleSurface(const PartMesh& mesh, int n,
                                         uint32_t seed);

// Closest-point queries on a mesh (CGAL AABB tree). The mesh must outlive
// the query.
class PartQuery {
 public:
  explicit PartQuery(const PartMesh& mesh);
  ~PartQuery();
  PartQuery(const PartQuery&) = delete;
  PartQuery& operator=(const PartQuery&) = delete;

  struct Hit {
    Eigen::Vector3d point;   // closest surface point
    Eigen::Vector3d normal;  // outward normal of its triangle
    int triangle = -1;
    int feature = -1;
    std::string feature_id;
    // Positive outside the solid, negative inside (sign from the closest
    // triangle's normal; reliable except exactly on sharp concave edges).
    double signed_distance_mm = 0;
  };
  Hit Closest(const Eigen::Vector3d& p) const;
  double SignedDistanceMm(const Eigen::Vector3d& p) const;

 private:
  struct Impl;
  const PartMesh& mesh_;
  std::unique_ptr<Impl> impl_;
};

// One-off convenience (builds a tree per call: use PartQuery for many).
double SignedDistanceMm(const PartMesh& mesh, const Eigen::Vector3d& p);

}  // namespace ttp
