// `ttp fit` on the NIST reference data sets: every pair of the reference
// folder, compared with its reference fit through invariants (a point
// sliding along an axis or within a plane is the same answer).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "../geometry/fit_test_util.h"
#include "run_ttp.h"

namespace ttp {
namespace {

namespace fs = std::filesystem;
using fit::testing::NistCases;
using fit::testing::NistDir;
using fit::testing::ReadNistFit;

Eigen::Vector3d V(const nlohmann::json& a) {
  return Eigen::Vector3d(a[0].get<double>(), a[1].get<double>(),
                         a[2].get<double>());
}

nlohmann::json Fit(const std::string& shape, const std::string& file,
                   const std::string& extra = "") {
  const fs::path out = test::TestDir("fit") / "fit.json";
  const auto r = test::RunTtp("fit " + shape + " " + file + " --json " +
                              out.string() + " " + extra);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in(out);
  return nlohmann::json::parse(in);
}

double LineDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                    const Eigen::Vector3d& d) {
  return (p - a).cross(d.normalized()).norm();
}

// 1e-6 mm and 1e-8 rad: the agreement asked of the fits.
constexpr double kMm = 1e-6, kRad = 1e-8;

TEST(CliFit, NistReferencePairs) {
  const std::pair<const char*, const char*> shapes[] = {
      {"Line2d", "line"},       {"Line3d", "line"},   {"Plane", "plane"},
      {"Circle3d", "circle3d"}, {"Sphere", "sphere"}, {"Cylinder", "cylinder"},
      {"Cone", "cone"}};
  int cases = 0;
  for (const auto& [folder, shape] : shapes) {
    for (const std::string& name : NistCases(folder)) {
      const std::string base = NistDir() + folder + "/" + name;
      const std::vector<double> ref = ReadNistFit(base + ".fit");
      const nlohmann::json j = Fit(shape, base + ".ds");
      const nlohmann::json& p = j["parameters"];
      SCOPED_TRACE(name);
      ++cases;
      const Eigen::Vector3d rp(ref[0], ref[1], ref[2]);
      const std::string s = shape;
      if (s == "line" || s == "plane") {
        const Eigen::Vector3d rd(ref[3], ref[4], ref[5]);
        const Eigen::Vector3d d = V(p[s == "line" ? "direction" : "normal"]);
        EXPECT_LT(d.cross(rd).norm(), kRad);
        // The reported point is the centroid in both.
        EXPECT_LT((V(p["point_mm"]) - rp).norm(), kMm);
      } else if (s == "circle3d") {
        EXPECT_LT((V(p["centre_mm"]) - rp).norm(), kMm);
        EXPECT_LT(V(p["normal"])
                      .cross(Eigen::Vector3d(ref[3], ref[4], ref[5]))
                      .norm(),
                  kRad);
        EXPECT_NEAR(p["diameter_mm"].get<double>(), ref[6], kMm);
      } else if (s == "sphere") {
        EXPECT_LT((V(p["centre_mm"]) - rp).norm(), kMm);
        EXPECT_NEAR(p["diameter_mm"].get<double>(), ref[3], kMm);
      } else if (s == "cylinder") {
        const Eigen::Vector3d axis = V(p["axis"]);
        EXPECT_LT(axis.cross(Eigen::Vector3d(ref[3], ref[4], ref[5])).norm(),
                  kRad);
        EXPECT_LT(LineDistance(rp, V(p["point_mm"]), axis), kMm);
        EXPECT_NEAR(p["diameter_mm"].get<double>(), ref[6], kMm);
      } else {  // cone
        const Eigen::Vector3d axis = V(p["axis"]).normalized();
        const Eigen::Vector3d rd(ref[3], ref[4], ref[5]);
        EXPECT_LT((axis - rd).norm(), kRad);  // same sense: radius grows
        EXPECT_LT(LineDistance(rp, V(p["point_mm"]), axis), kMm);
        const double half = p["half_angle_deg"].get<double>() * M_PI / 180;
        EXPECT_NEAR(2 * half * 180 / M_PI, ref[7], 1e-6);
        // Orthogonal distance from the reference axis point to the surface.
        const double s_along = (rp - V(p["point_mm"])).dot(axis);
        const double radius =
            p["radius_at_point_mm"].get<double>() + s_along * std::tan(half);
        EXPECT_NEAR(radius * std::cos(half), ref[6], kMm);
      }
      EXPECT_GT(j["residuals"]["rms_mm"].get<double>(), 0.0);
      EXPECT_TRUE(j["converged"].get<bool>());
    }
  }
  EXPECT_EQ(cases, 37);
}

// circle2d fits x, y only: a 3D circle data set seen from its plane.
TEST(CliFit, Circle2dAndRobustLoss) {
  const fs::path dir = test::TestDir("fit");
  {
    std::ofstream f(dir / "circle.xyz");
    f.precision(17);
    for (int i = 0; i < 40; ++i) {
      const double a = 2 * M_PI * i / 40;
      // Radius 12 at (5, -3), z varying (ignored), one wild point.
      const double r = i == 7 ? 12.5 : 12.0 + 1e-4 * std::sin(3 * a);
      f << 5 + r * std::cos(a) << " " << -3 + r * std::sin(a) << " " << 0.3 * i
        << "\n";
    }
  }
  const std::string file = (dir / "circle.xyz").string();
  const nlohmann::json plain = Fit("circle2d", file);
  const nlohmann::json robust =
      Fit("circle2d", file, "--robust cauchy --loss-scale-mm 0.001");
  const auto centre = [](const nlohmann::json& j) {
    return Eigen::Vector2d(j["parameters"]["centre_mm"][0].get<double>(),
                           j["parameters"]["centre_mm"][1].get<double>());
  };
  // The wild point pulls the plain fit by about 0.5/40 mm; Cauchy ignores it.
  EXPECT_GT((centre(plain) - Eigen::Vector2d(5, -3)).norm(), 5e-3);
  EXPECT_LT((centre(robust) - Eigen::Vector2d(5, -3)).norm(), 1e-4);
  EXPECT_NEAR(robust["parameters"]["radius_mm"].get<double>(), 12.0, 1e-4);
  EXPECT_TRUE(robust["standard_uncertainty"].contains("r_mm"));
}

TEST(CliFit, BadInputExitsTwo) {
  const std::string ds = NistDir() + "Plane/pla8.ds";
  auto r = test::RunTtp("fit torus " + ds);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("not one of line, plane"), std::string::npos)
      << r.output;
  r = test::RunTtp("fit plane " + ds + " --robust tukey");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("--robust"), std::string::npos) << r.output;
  r = test::RunTtp("fit plane /nonexistent/points.xyz");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  const fs::path bad = test::TestDir("fit") / "bad.xyz";
  std::ofstream(bad) << "3\n1 2 3\n4 5 6\n";  // says 3, has 2
  r = test::RunTtp("fit plane " + bad.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("says 3 points"), std::string::npos) << r.output;
}

// Points that do not determine the shape: exit 2 naming the file and the
// reason, and nothing of Ceres' own logging on stderr.
TEST(CliFit, DegenerateShapesExitTwoWithAClearMessage) {
  const fs::path dir = test::TestDir("fit");
  {
    std::ofstream plane(dir / "plane.xyz");
    plane.precision(17);
    for (int i = 0; i < 200; ++i)
      plane << 500 + (i % 20) * 1.3 << " " << -200 + (i / 20) * 2.1 << " "
            << 40 + 1e-3 * std::sin(i) << "\n";
    std::ofstream four(dir / "four.xyz");
    four << "0 0 0\n1 0 0\n0 1 0\n0 0 1\n";
  }
  const std::string plane = (dir / "plane.xyz").string();
  for (const char* shape : {"cylinder", "sphere", "cone"}) {
    const auto r = test::RunTtp(std::string("fit ") + shape + " " + plane);
    EXPECT_EQ(r.exit_code, 2) << shape << ": " << r.output;
    EXPECT_NE(r.output.find("plane.xyz"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("degenerate"), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("covariance_impl"), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("InitGoogleLogging"), std::string::npos)
        << r.output;
  }
  const auto r = test::RunTtp("fit cone " + (dir / "four.xyz").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("four.xyz"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("inf"), std::string::npos) << r.output;
  // As many points as free parameters fit the shape exactly: the
  // uncertainties are not determined (null), not 0; one point more and they
  // are numbers.
  {
    std::ofstream(dir / "three.xyz") << "0 0 0\n10 0 0.1\n0 10 -0.2\n";
    std::ofstream(dir / "five.xyz")
        << "0 0 0\n10 0 0.1\n0 10 -0.2\n10 10 0.05\n5 5 0.3\n";
  }
  const nlohmann::json exact = Fit("plane", (dir / "three.xyz").string());
  for (const auto& [k, v] : exact["standard_uncertainty"].items())
    EXPECT_TRUE(v.is_null()) << k << " " << v;
  EXPECT_TRUE(exact.contains("uncertainty_note"));
  const nlohmann::json over = Fit("plane", (dir / "five.xyz").string());
  for (const auto& [k, v] : over["standard_uncertainty"].items())
    EXPECT_GT(v.get<double>(), 0.0) << k;
}

}  // namespace
}  // namespace ttp
