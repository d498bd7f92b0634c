// Golden outputs: every measurement path (cloud PLY and XYZ, probe CSV,
// DMIS output, dial CSV) and `ttp fit` on NIST reference sets, compared with
// the outputs committed under tests/inspect/golden/ (written by `ttp ...
// --json` from the same inputs). A refactoring must not change them beyond the
// last digits.
//
// Tolerance: a number agrees when |got - want| <= 1e-9 (absolute, in the
// file's own units: um, urad, mm) or <= 1e-7 * |want| (relative). Different
// but equivalent algorithms (a closed-form plane fit against a
// Gauss-Newton one, Ceres against hand-written iterations) agree to about
// 1e-12; 1e-7 relative also absorbs the fit covariance's dependence on the
// smallest scatter eigenvalue (noise^2 / extent^2 ~ 1e-9 for a facet).
// Texts (ids, verdicts, warnings) must be equal.
//
// To regenerate after an intended change of the outputs, run from the
// repository root (and say why in the commit):
//   ttp -q inspect samples/run-a/piece.ply --json
//   tests/inspect/golden/run-a.inspect.json (likewise run-b, probe.csv,
//   piece.dmo, dial.csv; `ttp -q fit SHAPE reference/nist-fits/...ds --json
//   .../fit-NAME.json`)
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <string>

#include "ttp/geometry/config.h"
#include "ttp/geometry/fit.h"
#include "ttp/inspect/measurement.h"
#include "ttp/inspect/point_io.h"

namespace ttp::inspect {
namespace {

const std::string kData = TTP_DATA_DIR;
const std::string kGolden = kData + "/tests/inspect/golden/";

nlohmann::json ReadJson(const std::string& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << path;
  return nlohmann::json::parse(in);
}

bool Close(double got, double want) {
  const double diff = std::abs(got - want);
  return diff <= 1e-9 || diff <= 1e-7 * std::abs(want);
}

// Recursively compares got with want; `skip` lists keys whose values are
// not outputs (file names as given on the command line).
void ExpectSame(const nlohmann::json& got, const nlohmann::json& want,
                const std::string& path, const std::set<std::string>& skip,
                int* differences) {
  auto fail = [&](const std::string& what) {
    if (++*differences <= 20) ADD_FAILURE() << path << ": " << what;
  };
  if (want.is_number() && got.is_number()) {
    const double g = got.get<double>(), w = want.get<double>();
    if (!Close(g, w)) fail(fmt::format("{:.17g} != golden {:.17g}", g, w));
    return;
  }
  if (got.type() != want.type()) {
    fail("type " + std::string(got.type_name()) + " != golden " +
         want.type_name() + " (" + want.dump().substr(0, 80) + ")");
    return;
  }
  if (want.is_object()) {
    for (const auto& [k, v] : want.items()) {
      if (skip.count(k)) continue;
      if (!got.contains(k)) {
        fail("missing key " + k);
        continue;
      }
      ExpectSame(got[k], v, path + "." + k, skip, differences);
    }
    for (const auto& [k, v] : got.items()) {
      if (!want.contains(k) && !skip.count(k)) fail("extra key " + k);
    }
    return;
  }
  if (want.is_array()) {
    if (got.size() != want.size()) {
      fail(fmt::format("{} elements != golden {}", got.size(), want.size()));
      return;
    }
    for (size_t i = 0; i < want.size(); ++i)
      ExpectSame(got[i], want[i], fmt::format("{}[{}]", path, i), skip,
                 differences);
    return;
  }
  if (got != want) fail(got.dump() + " != golden " + want.dump());
}

void ExpectGolden(const nlohmann::json& got, const std::string& golden_file) {
  int differences = 0;
  ExpectSame(got, ReadJson(kGolden + golden_file), golden_file, {"source"},
             &differences);
  EXPECT_EQ(differences, 0) << golden_file;
}

Measurement Load(const std::string& path) {
  return LoadMeasurement(Config{}, kData + "/" + path);
}

struct Case {
  const char* input;   // relative to the repository root
  const char* golden;  // under tests/inspect/golden/
};

class GoldenInspection : public ::testing::TestWithParam<Case> {};

TEST_P(GoldenInspection, SameAsCommitted) {
  const Measurement m = Load(GetParam().input);
  ExpectGolden(MeasurementToJson(m), GetParam().golden);
}

INSTANTIATE_TEST_SUITE_P(
    Paths, GoldenInspection,
    ::testing::Values(
        Case{"samples/run-a/piece.ply", "run-a.inspect.json"},
        Case{"samples/run-b/piece.xyz", "run-b.inspect.json"},
        Case{"tests/inspect/golden/probe.csv", "probe.inspect.json"},
        Case{"tests/inspect/golden/piece.dmo", "dmis.inspect.json"},
        Case{"tests/inspect/golden/dial.csv", "dial.inspect.json"}),
    [](const auto& info) {
      std::string name = info.param.golden;
      name = name.substr(0, name.find('.'));
      for (char& c : name)
        if (c == '-') c = '_';
      return name;
    });

nlohmann::json Vec(const Eigen::VectorXd& v) {
  nlohmann::json a = nlohmann::json::array();
  for (Eigen::Index i = 0; i < v.size(); ++i) a.push_back(v(i));
  return a;
}

// The parameters and residuals of `ttp fit SHAPE FILE --json` (the same
// names), computed through the library.
nlohmann::json FitParameters(const std::string& shape,
                             const Eigen::Matrix3Xd& p) {
  nlohmann::json prm;
  fit::FitSummary s;
  if (shape == "plane") {
    const fit::PlaneFit f = fit::FitPlane(p);
    prm = {{"point_mm", Vec(f.point)}, {"normal", Vec(f.normal)}};
    s = f.summary;
  } else if (shape == "line") {
    const fit::LineFit3D f = fit::FitLine3D(p);
    prm = {{"point_mm", Vec(f.point)}, {"direction", Vec(f.direction)}};
    s = f.summary;
  } else if (shape == "circle3d") {
    const fit::CircleFit3D f = fit::FitCircle3D(p);
    prm = {{"centre_mm", Vec(f.centre)},
           {"normal", Vec(f.normal)},
           {"radius_mm", f.radius_mm},
           {"diameter_mm", 2 * f.radius_mm}};
    s = f.summary;
  } else if (shape == "sphere") {
    const fit::SphereFit f = fit::FitSphere(p);
    prm = {{"centre_mm", Vec(f.centre)},
           {"radius_mm", f.radius_mm},
           {"diameter_mm", 2 * f.radius_mm}};
    s = f.summary;
  } else if (shape == "cylinder") {
    const fit::CylinderFit f = fit::FitCylinder(p);
    prm = {{"point_mm", Vec(f.point)},
           {"axis", Vec(f.axis)},
           {"radius_mm", f.radius_mm},
           {"diameter_mm", 2 * f.radius_mm}};
    s = f.summary;
  } else if (shape == "cone") {
    const fit::ConeFit f = fit::FitCone(p);
    prm = {{"apex_mm", Vec(f.apex)},
           {"axis", Vec(f.axis)},
           {"half_angle_deg", f.half_angle_rad * 180.0 / M_PI},
           {"point_mm", Vec(f.point)},
           {"radius_at_point_mm", f.radius_at_point_mm}};
    s = f.summary;
  }
  nlohmann::json u = nlohmann::json::object();
  for (size_t i = 0; i < s.parameter_names.size(); ++i) {
    const auto k = static_cast<Eigen::Index>(i);
    u[s.parameter_names[i]] = std::sqrt(std::max(0.0, s.covariance(k, k)));
  }
  return {{"parameters", prm},
          {"standard_uncertainty", u},
          {"residuals", {{"rms_mm", s.rms_mm}, {"max_abs_mm", s.max_abs_mm}}},
          {"points", s.points},
          {"converged", s.converged}};
}

TEST(GoldenFit, NistSetsSameAsCommitted) {
  const struct {
    const char* shape;
    const char* set;
  } sets[] = {{"plane", "Plane/pla8"},        {"line", "Line3d/lin3"},
              {"circle3d", "Circle3d/cir5"},  {"sphere", "Sphere/sph5"},
              {"cylinder", "Cylinder/cyl21"}, {"cone", "Cone/con19"}};
  for (const auto& s : sets) {
    const std::string name =
        std::string(s.set).substr(std::string(s.set).find('/') + 1);
    const PointCloud cloud = ReadPointCloud(
        kData + "/reference/nist-fits/" + s.set + ".ds", ReadOptions{});
    nlohmann::json want = ReadJson(kGolden + "fit-" + name + ".json");
    nlohmann::json subset;
    for (const char* k : {"parameters", "standard_uncertainty", "residuals",
                          "points", "converged"})
      subset[k] = want[k];
    int differences = 0;
    ExpectSame(FitParameters(s.shape, cloud.xyz_mm), subset, name, {},
               &differences);
    EXPECT_EQ(differences, 0) << name;
  }
}

}  // namespace
}  // namespace ttp::inspect
