#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <random>

#include "run_ttp.h"
#include "ttp/geometry/rtest.h"

namespace ttp {
namespace {

TEST(CliRTest, EvaluatesASphereFile) {
  namespace fs = std::filesystem;
  const fs::path dir = test::TestDir("rtest");
  RTestGeometry g;  // machine defaults: 160 mm, 80 mm high
  const CAxisErrors truth =
      CAxisErrors::FromMicro({1.5, -2.0, 3.0, 0.5, 4.0, -6.0, 8.0});
  std::ofstream csv(dir / "spheres.csv");
  csv << "cycle,c_deg,x,y,z\n";
  for (int cycle : {0, 1}) {
    for (int k = 0; k < 5; ++k) {
      const double c = k * M_PI / 2;
      Eigen::Vector3d p = NominalSpherePosition(g, c);
      if (cycle == 1) p += TableDisplacement(truth, p, g.sphere_distance_mm);
      csv << cycle << "," << k * 90 << "," << std::setprecision(12) << p.x()
          << "," << p.y() << "," << p.z() << "\n";
    }
  }
  csv.close();
  const auto r = test::RunTtp("rtest " + (dir / "spheres.csv").string() +
                              " --json " + (dir / "out.json").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in(dir / "out.json");
  const auto j = nlohmann::json::parse(in);
  const auto want = truth.ToMicro();
  for (int i = 0; i < 7; ++i) {
    EXPECT_NEAR(j["cycles"][0][kErrorNames[i]].get<double>(), want[i], 1e-6);
  }
}

TEST(CliRTest, BadInputExitsTwoNamingTheLine) {
  namespace fs = std::filesystem;
  const fs::path dir = test::TestDir("rtest");
  std::ofstream(dir / "bad.csv")
      << "cycle,c_deg,x,y,z\n0,0,1,2,3\n1,0,1,abc,3\n";
  const auto r = test::RunTtp("rtest " + (dir / "bad.csv").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("bad.csv:3: y:"), std::string::npos) << r.output;
  EXPECT_EQ(test::RunTtp("rtest --no-such-flag").exit_code, 2);
}

}  // namespace
}  // namespace ttp
