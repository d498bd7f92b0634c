// `ttp part export`: meshes of the three stages with feature tags, read
// back with OpenMesh, and the nominal feature tables.
#include <gtest/gtest.h>

#include <OpenMesh/Core/IO/MeshIO.hh>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "om_mesh.h"
#include "run_ttp.h"
#include "ttp/geometry/config.h"

namespace ttp {
namespace {

namespace fs = std::filesystem;

using test::OmMesh;
using test::OmVolume;

// Closed (no boundary halfedge) and two-manifold (OpenMesh refuses complex
// edges on reading; every vertex manifold).
std::string ClosedManifold(const OmMesh& om) {
  if (om.n_faces() == 0) return "no faces";
  for (auto h : om.halfedges())
    if (om.is_boundary(h)) return "open boundary";
  for (auto v : om.vertices())
    if (!om.is_manifold(v)) return "non-manifold vertex";
  return "";
}

// Lines starting with `prefix`, the rest of each line.
std::set<std::string> Tags(const fs::path& path, const std::string& prefix) {
  std::ifstream in(path);
  std::set<std::string> out;
  std::string line;
  while (std::getline(in, line))
    if (line.rfind(prefix, 0) == 0) out.insert(line.substr(prefix.size()));
  return out;
}

TEST(CliPart, ExportsClosedTaggedMeshesAndTheFeatureTable) {
  const fs::path dir = test::TestDir("part");
  const auto r = test::RunTtp("part export -o " + dir.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;

  const PartSpec p;
  // The blank: a cylinder less its three bolt holes (independent of the
  // mesher).
  const double blank_volume =
      M_PI * std::pow(p.blank_diameter_mm / 2, 2) * p.blank_height_mm -
      p.bolt_phi_deg.size() * M_PI * std::pow(p.bolt_hole_diameter_mm / 2, 2) *
          p.bolt_hole_depth_mm;
  std::map<std::string, double> volume;
  for (const char* stage : {"blank", "pre", "finished"}) {
    SCOPED_TRACE(stage);
    const std::string stem = std::string("part-") + stage;
    const auto table = nlohmann::json::parse(
        std::ifstream(dir / ("features-" + std::string(stage) + ".json")));
    ASSERT_FALSE(table.empty());
    std::set<std::string> ids;
    for (const auto& f : table) {
      ids.insert(f.at("id").get<std::string>());
      EXPECT_EQ(f.at("point_mm").size(), 3u);
      EXPECT_TRUE(f.contains("normal") || f.contains("axis") ||
                  f.contains("direction"));
      EXPECT_TRUE(f.contains("size_mm"));
    }
    {
      std::ifstream csv(dir / ("features-" + std::string(stage) + ".csv"));
      std::string header;
      std::getline(csv, header);
      EXPECT_EQ(header.rfind("id,kind,point_x_mm", 0), 0u) << header;
      int rows = 0;
      for (std::string line; std::getline(csv, line);) ++rows;
      EXPECT_EQ(rows, static_cast<int>(table.size()));
    }

    // PLY: binary doubles, the feature index as a face property.
    OmMesh ply;
    OpenMesh::IO::Options opt = OpenMesh::IO::Options::Custom;
    ASSERT_TRUE(
        OpenMesh::IO::read_mesh(ply, (dir / (stem + ".ply")).string(), opt));
    EXPECT_EQ(ClosedManifold(ply), "");
    OpenMesh::FPropHandleT<int> feature;
    ASSERT_TRUE(ply.get_property_handle(feature, "feature"));
    std::map<int, std::string> names;  // "comment feature <i> <id>"
    for (const std::string& t :
         Tags(dir / (stem + ".ply"), "comment feature ")) {
      names[std::stoi(t)] = t.substr(t.find(' ') + 1);
    }
    std::set<std::string> ply_ids;
    for (auto f : ply.faces()) {
      const int i = ply.property(feature, f);
      ASSERT_TRUE(names.count(i)) << i;
      ply_ids.insert(names[i]);
    }
    // Every nominal feature carries faces (the finished piece's big-notch
    // floor is all strips); every tag is a feature or a named non-feature.
    for (const std::string& id : ids) {
      if (std::string(stage) == "finished" && id == "NOTCH_BIG") continue;
      EXPECT_TRUE(ply_ids.count(id)) << id;
    }
    for (const std::string& id : ply_ids) {
      EXPECT_TRUE(ids.count(id) || id == "BOTTOM" || id == "RIM" ||
                  id == "BOLT_HOLE" || id == "NOTCH_SMALL_WALL" ||
                  id == "OTHER")
          << id;
    }
    volume[stage] = OmVolume(ply);

    // OBJ: one group per feature.
    OmMesh obj;
    ASSERT_TRUE(OpenMesh::IO::read_mesh(obj, (dir / (stem + ".obj")).string()));
    EXPECT_EQ(ClosedManifold(obj), "");
    EXPECT_EQ(obj.n_faces(), ply.n_faces());
    EXPECT_NEAR(OmVolume(obj), volume[stage], 1e-3 * volume[stage]);
    EXPECT_EQ(Tags(dir / (stem + ".obj"), "g "), ply_ids);

    // STL: one named solid per feature; OpenMesh merges equal points, so
    // the triangle soup is the same closed solid.
    OmMesh stl;
    ASSERT_TRUE(OpenMesh::IO::read_mesh(stl, (dir / (stem + ".stl")).string()));
    EXPECT_EQ(ClosedManifold(stl), "");
    EXPECT_EQ(stl.n_faces(), ply.n_faces());
    EXPECT_NEAR(OmVolume(stl), volume[stage], 1e-3 * volume[stage]);
    EXPECT_EQ(Tags(dir / (stem + ".stl"), "solid "), ply_ids);
  }
  EXPECT_NEAR(volume["blank"], blank_volume, 1e-3 * blank_volume);
  // Material only comes off.
  EXPECT_LT(volume["pre"], volume["blank"]);
  EXPECT_LT(volume["finished"], volume["pre"]);
  // The finished piece loses the strips (width x length x depth) and the
  // facets' allowance: a few hundred mm^3, not a disc's worth.
  EXPECT_LT(volume["pre"] - volume["finished"], 0.01 * volume["pre"]);
}

TEST(CliPart, OneFormatOneStage) {
  const fs::path dir = test::TestDir("part_one");
  const auto r = test::RunTtp("part export -o " + dir.string() +
                              " --format obj --stage pre");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::set<std::string> files;
  for (const auto& e : fs::directory_iterator(dir))
    files.insert(e.path().filename().string());
  EXPECT_EQ(files, (std::set<std::string>{"part-pre.obj", "features-pre.csv",
                                          "features-pre.json"}));
}

TEST(CliPart, BadOutputOrFormatIsExit2) {
  const fs::path dir = test::TestDir("part_bad");
  { std::ofstream(dir / "a_file") << "x"; }
  auto r = test::RunTtp("part export -o " + (dir / "a_file").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("not a folder"), std::string::npos) << r.output;
  r = test::RunTtp("part export -o " + (dir / "a_file" / "sub").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  r = test::RunTtp("part export -o " + (dir / "out").string() +
                   " --format step");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("format"), std::string::npos) << r.output;
  r = test::RunTtp("part export -o " + (dir / "out").string() +
                   " --stage half");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  r = test::RunTtp("part export");  // -o is required
  EXPECT_EQ(r.exit_code, 2) << r.output;
  // Nothing half-written.
  EXPECT_FALSE(fs::exists(dir / "out" / "part-finished.step"));
}

// A part whose solid cannot be built (a band of its side no reference
// cylinder covers) is refused naming the configuration file and the field.
TEST(CliPart, AnUncoveredBandNamesTheConfigurationFile) {
  const fs::path dir = test::TestDir("part_gap");
  const fs::path config = dir / "tall.toml";
  std::ofstream(config) << "[part]\nblank_height_mm = 31.25\n";
  const auto r = test::RunTtp("--config " + config.string() +
                              " part export -o " + (dir / "out").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("tall.toml: part.ref_cylinders: leave a gap at z = "
                          "-27.125 mm"),
            std::string::npos)
      << r.output;
  EXPECT_FALSE(fs::exists(dir / "out"));
}

}  // namespace
}  // namespace ttp
