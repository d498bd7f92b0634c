#include "ttp/inspect/measurement.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include "feature_ids.h"
#include "test_dir.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/file_io.h"

namespace ttp::inspect {
namespace {

namespace fs = std::filesystem;

class MeasurementTest : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = test::TestDir("measurement"); }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path Write(const std::string& name, const std::string& text) {
    const fs::path p = dir_ / name;
    std::ofstream(p, std::ios::binary) << text;
    return p;
  }
  std::string ErrorOf(const fs::path& p) {
    try {
      LoadMeasurement(config_, p);
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  }
  fs::path dir_;
  Config config_;
};

TEST(SniffTest, RecognisesEachFormatFromItsContent) {
  const fs::path any = "m.dat";
  EXPECT_EQ(SniffMeasurement("ply\nformat ascii 1.0\n", any),
            MeasurementKind::kCloud);
  EXPECT_EQ(SniffMeasurement("# .PCD v0.7\nVERSION 0.7\n", any),
            MeasurementKind::kCloud);
  EXPECT_EQ(SniffMeasurement("  \n{\"figures\": []}", any),
            MeasurementKind::kInspectionJson);
  EXPECT_EQ(SniffMeasurement("# sheet\nfeature,reading_um\nX1-1,2\n", any),
            MeasurementKind::kDial);
  EXPECT_EQ(SniffMeasurement("DMISMN/'x',5.0\nFA(A)=FEAT/PLANE\n", any),
            MeasurementKind::kDmis);
  EXPECT_EQ(SniffMeasurement("UNITS/MM\nFA(X1_1)=FEAT/PLANE,CART\n", any),
            MeasurementKind::kDmis);
  EXPECT_EQ(SniffMeasurement("point_id,x,y,z,c_deg\n1,0,0,0,0\n", any),
            MeasurementKind::kProbe);
  EXPECT_EQ(SniffMeasurement("1 2 3\n4 5 6\n", "p.xyz"),
            MeasurementKind::kCloud);
  // The extension decides only when the content does not.
  EXPECT_EQ(SniffMeasurement("1 2 3\n", "p.dmo"), MeasurementKind::kDmis);
  EXPECT_EQ(SniffMeasurement("ply\n", "p.json"), MeasurementKind::kCloud);
}

TEST(SniffTest, TellsLogsByTheirFormatKey) {
  EXPECT_EQ(SniffLogFormat("# thermal-log: 1\n# start: x\nt_s,n_a\n"),
            "thermal-log");
  // Keys in any order, spaces, a byte-order mark, CRLF.
  EXPECT_EQ(SniffLogFormat("\xEF\xBB\xBF# machine: m\r\n\n#  talc-log : 1\r\n"),
            "talc-log");
  EXPECT_EQ(SniffLogFormat("# .PCD v0.7\nVERSION 0.7\n"), "");
  EXPECT_EQ(SniffLogFormat("# talc-logger notes\nfeature,reading_um\n"), "");
  // Only the comment lines before the data count.
  EXPECT_EQ(SniffLogFormat("1 2 3\n# talc-log: 1\n"), "");
  EXPECT_EQ(SniffLogFormat(""), "");
}

TEST_F(MeasurementTest, ALogGivenAsThePieceSaysWhatItIs) {
  const std::string thermal =
      ErrorOf(Write("t.csv",
                    "# thermal-log: 1\n# start: 2024-01-01T00:00:00Z\n"
                    "t_s,n_s,T_a\n0,0,20\n"));
  EXPECT_NE(thermal.find("t.csv:1: # thermal-log: a thermal test log"),
            std::string::npos)
      << thermal;
  const std::string talc = ErrorOf(Write(
      "l.csv", "# compensation: off\n# talc-log: 1\nt_s,event\n0,sample\n"));
  EXPECT_NE(talc.find("a TALC log (talc-log.md), not a measured piece: give "
                      "it with --log"),
            std::string::npos)
      << talc;
}

// Random per-feature results -> inspection JSON -> LoadMeasurement: the
// figures and their U come back as computed from the features directly.
TEST_F(MeasurementTest, InspectionJsonRoundTrip) {
  const PartSpec& part = config_.part;
  std::mt19937 rng(11);
  std::normal_distribution<double> dev(0.0, 3e-3);
  std::uniform_real_distribution<double> u(0.2e-3, 2e-3);
  InspectionResult r;
  r.source = "synthetic";
  for (const NominalFeature& f : TestFeatures(part)) {
    FeatureResult fr;
    fr.present = true;
    fr.d_mm =
        (f.kind == FeatureKind::kStrip ? -part.strip_floor_z_mm : f.size_mm) +
        dev(rng);
    fr.var_d_mm2 = std::pow(u(rng), 2);
    fr.angle_rad = dev(rng) * 1e-2;
    fr.var_angle_rad2 = std::pow(u(rng) * 1e-2, 2);
    // The fit's own part of them, as a cloud's inspection gives it.
    fr.scatter_var_d_mm2 = fr.var_d_mm2 * 0.3;
    fr.scatter_var_angle_rad2 = fr.var_angle_rad2 * 0.9;
    r.features[f.Key()] = fr;
  }
  r.features[FeatureId::Facet(Segment::kY2, 3)].present =
      false;  // cycle of index 3 loses E_Y, E_TTP
  ComputeResultFigures(part, &r);
  const nlohmann::json doc = InspectionToJson(r);
  const fs::path p = Write("inspection.json", doc.dump(1));
  const Measurement m = LoadMeasurement(config_, p);
  EXPECT_EQ(m.kind, MeasurementKind::kInspectionJson);
  for (const auto& [id, want] : r.features) {
    if (!want.present) continue;
    const FeatureResult& got = m.result.features.at(id);
    EXPECT_NEAR(got.scatter_var_d_mm2 / want.scatter_var_d_mm2, 1.0, 1e-9)
        << id.ToString();
    EXPECT_NEAR(got.scatter_var_angle_rad2 / want.scatter_var_angle_rad2, 1.0,
                1e-9)
        << id.ToString();
  }
  ASSERT_EQ(m.result.figures.size(), r.figures.size());
  int missing = 0;
  for (size_t i = 0; i < r.figures.size(); ++i) {
    const CycleFigures &a = r.figures[i], &b = m.result.figures[i];
    if (std::isnan(a.e_y_mm)) {
      ++missing;
      EXPECT_TRUE(std::isnan(b.e_y_mm));
      EXPECT_TRUE(std::isnan(b.e_ttp_mm));
      EXPECT_FALSE(std::isnan(b.e_x_mm));
      continue;
    }
    EXPECT_NEAR(a.e_x_mm, b.e_x_mm, 1e-12);
    EXPECT_NEAR(a.e_y_mm, b.e_y_mm, 1e-12);
    EXPECT_NEAR(a.e_z_mm, b.e_z_mm, 1e-12);
    EXPECT_NEAR(a.e_b_rad, b.e_b_rad, 1e-12);
    EXPECT_NEAR(a.e_ttp_mm, b.e_ttp_mm, 1e-12);
    EXPECT_NEAR(a.u_x_mm, b.u_x_mm, 1e-9);
    EXPECT_NEAR(a.u_b_rad, b.u_b_rad, 1e-9);
    EXPECT_NEAR(r.extras[i].e_c_rad, m.result.extras[i].e_c_rad, 1e-12);
  }
  EXPECT_EQ(missing, 1);
  const nlohmann::json out = MeasurementToJson(m);
  EXPECT_EQ(out["kind"], "inspection-json");
  EXPECT_FALSE(out.contains("alignment"));
  EXPECT_EQ(out["segmentation"]["missing"], nlohmann::json({"Y2-3"}));
}

// `ttp inspect --json` writes features and the figures they give. A file
// whose features were edited afterwards holds figures that no longer
// follow from them: the evaluation uses the features and says so.
TEST_F(MeasurementTest, FiguresThatDoNotFollowFromTheFeaturesAreNamed) {
  const fs::path cloud = fs::path(TTP_DATA_DIR) / "samples/run-a/piece.ply";
  const Measurement measured = LoadMeasurement(config_, cloud);
  nlohmann::json doc = InspectionToJson(measured.result);
  ASSERT_TRUE(doc.contains("figures"));
  ASSERT_TRUE(doc.contains("facets"));
  const Measurement same =
      LoadMeasurement(config_, Write("same.json", doc.dump(1)));
  for (const std::string& w : same.result.warnings)
    EXPECT_EQ(w.find("\"figures\""), std::string::npos) << w;
  // X1-3 is a facet of cycle 3 (thesis 7.2): 8 um further out.
  doc["facets"]["X1-3"]["distance_mm"] =
      doc["facets"]["X1-3"]["distance_mm"].get<double>() + 0.008;
  const Measurement edited =
      LoadMeasurement(config_, Write("edited.json", doc.dump(1)));
  int named = 0;
  for (const std::string& w : edited.result.warnings)
    named +=
        w.find("differ from those of its features (E_") != std::string::npos &&
        w.find("of cycle 3") != std::string::npos;
  EXPECT_EQ(named, 1);
  for (size_t i = 0; i < edited.result.figures.size(); ++i) {
    const CycleFigures& f = edited.result.figures[i];
    if (f.cycle != 3) continue;
    EXPECT_GT(std::abs(f.e_x_mm - measured.result.figures[i].e_x_mm), 1e-3);
  }
}

TEST_F(MeasurementTest, FiguresOnlyJsonIsTakenAsIs) {
  const fs::path p =
      Write("f.json",
            R"({"figures": [{"cycle": 1, "E_X": 1.5, "E_Y": -2, "E_Z": 3,
           "E_B": 4, "E_TTP": null, "U": {"E_X": 0.4}}]})");
  const Measurement m = LoadMeasurement(config_, p);
  ASSERT_EQ(m.result.figures.size(), 1u);
  EXPECT_DOUBLE_EQ(m.result.figures[0].e_x_mm, 1.5e-3);
  EXPECT_DOUBLE_EQ(m.result.figures[0].u_x_mm, 0.2e-3);
  EXPECT_DOUBLE_EQ(m.result.figures[0].e_b_rad, 4e-6);
  EXPECT_TRUE(std::isnan(m.result.figures[0].e_ttp_mm));
  EXPECT_TRUE(m.result.facet_angle_rad.empty());
}

// Figures with facet angle errors beside them (the samples' truth.json):
// the angles are kept, and written back the same way.
TEST_F(MeasurementTest, FiguresWithFacetAnglesKeepTheAngles) {
  const fs::path p = Write("t.json",
                           R"({"figures": [{"cycle": 2, "E_X": 1.0}],
           "facet_angle_err_urad": {"X1-1": 12.5, "Y2-3": -4}})");
  const Measurement m = LoadMeasurement(config_, p);
  ASSERT_EQ(m.result.facet_angle_rad.size(), 2u);
  EXPECT_DOUBLE_EQ(m.result.facet_angle_rad.at(test::Fid("X1-1")), 12.5e-6);
  EXPECT_DOUBLE_EQ(m.result.facet_angle_rad.at(test::Fid("Y2-3")), -4e-6);
  const nlohmann::json back = MeasurementToJson(m);
  EXPECT_FALSE(back.contains("facets"));
  const Measurement again =
      LoadMeasurement(config_, Write("again.json", back.dump()));
  ASSERT_EQ(again.result.facet_angle_rad.size(), 2u);
  for (const auto& [id, angle] : m.result.facet_angle_rad)
    EXPECT_NEAR(again.result.facet_angle_rad.at(id), angle, 1e-18) << id;
  ASSERT_EQ(again.result.figures.size(), 1u);
  EXPECT_DOUBLE_EQ(again.result.figures[0].e_x_mm, 1.0e-3);
}

// Gauge readings: g on X1 and X2 of one index; E_X = (gX1 - gX2) / 2 and
// no angles, so E_B and E_C are missing.
TEST_F(MeasurementTest, DialReadings) {
  const PartSpec& part = config_.part;
  const int j = IndexForCycle(part, 2);
  const fs::path p =
      Write("dial.csv",
            fmt::format("feature,reading_um\n{},3.0\n{},-1.0\n",
                        FacetId(Segment::kX1, j), FacetId(Segment::kX2, j)));
  const Measurement m = LoadMeasurement(config_, p);
  EXPECT_EQ(m.kind, MeasurementKind::kDial);
  const CycleFigures& f = m.result.figures[1];
  EXPECT_EQ(f.cycle, 2);
  EXPECT_NEAR(f.e_x_mm, 2.0e-3, 1e-12);
  EXPECT_TRUE(std::isnan(f.e_y_mm));  // Y facets of index j not read
  EXPECT_TRUE(std::isnan(f.e_b_rad));
  EXPECT_TRUE(std::isnan(m.result.extras[1].e_c_rad));
  EXPECT_GT(f.u_x_mm, 0.0);
}

// A DMIS output with every facet and strip at nominal, one facet moved out
// by 2 um: the figures are zero but for |E_X| = 1 um and E_TTP = 0.5 um of
// that facet's cycle.
TEST_F(MeasurementTest, DmisFeatureResults) {
  const PartSpec& part = config_.part;
  const int cycle = 3;
  const std::string moved = FacetId(Segment::kX1, IndexForCycle(part, cycle));
  std::string text = "DMISMN/'ttp test',05.0\nUNITS/MM,ANGDEC\n";
  for (const NominalFeature& f : TestFeatures(part)) {
    std::string label = f.id;
    std::replace(label.begin(), label.end(), '-', '_');
    const Eigen::Vector3d pt =
        f.point + (f.id == moved ? 2e-3 : 0.0) * f.normal;
    text += fmt::format(
        "FA({})=FEAT/PLANE,CART,{:.9f},{:.9f},{:.9f},{:.12f},"
        "{:.12f},{:.12f}\n",
        label, pt.x(), pt.y(), pt.z(), f.normal.x(), f.normal.y(),
        f.normal.z());
  }
  text += "ENDFIL\n";
  const Measurement m = LoadMeasurement(config_, Write("r.dmo", text));
  EXPECT_EQ(m.kind, MeasurementKind::kDmis);
  for (const CycleFigures& f : m.result.figures) {
    const double ex = f.cycle == cycle ? 1e-3 : 0.0;
    EXPECT_NEAR(std::abs(f.e_x_mm), ex, 1e-9) << f.cycle;
    EXPECT_NEAR(std::abs(f.e_ttp_mm), ex / 2, 1e-9) << f.cycle;
    EXPECT_NEAR(f.e_y_mm, 0.0, 1e-9);
    EXPECT_NEAR(f.e_z_mm, 0.0, 1e-9);
    EXPECT_NEAR(f.e_b_rad, 0.0, 1e-9);
    EXPECT_GT(f.u_x_mm, 0.0);
  }
}

TEST_F(MeasurementTest, BadFilesNameTheProblem) {
  EXPECT_NE(ErrorOf(dir_ / "nope.ply").find("no such file"), std::string::npos);
  EXPECT_NE(ErrorOf(Write("empty.json", "  \n")).find("empty"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Write("bad.json", "{\"facets\": ")).find("not valid JSON"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Write("other.json", "{\"a\": 1}"))
                .find("not an inspection result"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Write("unk.json", R"({"facets": {"Q7-1": {}}})"))
                .find("facets.Q7-1"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Write("str.json",
                          R"({"facets": {"X1-1": {"distance_mm": "a"}}})"))
                .find("distance_mm: is not a number"),
            std::string::npos);
  // A value without its U is not exact: refused, naming the field.
  EXPECT_NE(ErrorOf(Write("no_u.json",
                          R"({"facets": {"X1-1": {"distance_mm": 97.3}}})"))
                .find("facets.X1-1.U_distance_um: missing"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Write("no_u_angle.json",
                          R"({"facets": {"X1-1": {"distance_mm": 97.3,
                          "U_distance_um": 1, "angle_error_urad": 5}}})"))
                .find("facets.X1-1.U_angle_urad: missing"),
            std::string::npos);
  // The fit's own part of U is optional, and not more than the whole.
  EXPECT_NE(ErrorOf(Write("scatter.json",
                          R"({"facets": {"X1-1": {"distance_mm": 97.3,
                          "U_distance_um": 1, "U_scatter_distance_um": 1.5}}})"))
                .find("facets.X1-1.U_scatter_distance_um: 1.5 is larger than "
                      "the whole uncertainty"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Write("cycle.json", R"({"figures": [{"cycle": 9}]})"))
                .find("figures[0].cycle: outside 1..8"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Write("twice.json",
                          R"({"figures": [{"cycle": 1, "E_X": 1},
                          {"cycle": 2}, {"cycle": 1, "E_X": 2}]})"))
                .find("figures[2].cycle: cycle 1 is given twice"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Write("angle.json", R"({"figures": [{"cycle": 1}],
                          "facet_angle_err_urad": {"Z3": 1}})"))
                .find("facet_angle_err_urad.Z3: is not a facet"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Write("dial.csv", "feature,reading_um\nX9-1,2\n"))
                .find("dial.csv:2: feature"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Write("none.dmo", "DMISMN/'x',05.0\nENDFIL\n"))
                .find("no facet or strip"),
            std::string::npos);
  // Probe results reach the probe reader (which names line and field).
  EXPECT_NE(ErrorOf(Write("probe.csv", "point_id,x,y,z,c_deg\n0,1,2,3,0\n"))
                .find("probe.csv:2: point_id"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Write("words.txt", "hello world\n")).find("words.txt"),
            std::string::npos);
}

// The sample run made outside the project: a cloud through LoadMeasurement
// gives its truth figures.
TEST_F(MeasurementTest, SampleCloudAgreesWithItsTruth) {
  const std::string dir = std::string(TTP_DATA_DIR) + "/samples/run-a/";
  const Measurement m = LoadMeasurement(config_, dir + "piece.ply");
  EXPECT_EQ(m.kind, MeasurementKind::kCloud);
  const nlohmann::json truth =
      nlohmann::json::parse(ReadTextFile(dir + "truth.json"));
  const nlohmann::json got = MeasurementToJson(m);
  EXPECT_TRUE(got.contains("alignment"));
  for (size_t i = 0; i < 8; ++i) {
    for (const char* k : {"E_X", "E_Y", "E_Z", "E_TTP"}) {
      const double t = truth["figures"][i][k].get<double>();
      const double v = got["figures"][i][k].get<double>();
      const double u = got["figures"][i]["U"][k].get<double>();
      EXPECT_NEAR(v, t, 0.3) << k << " cycle " << i + 1;
      EXPECT_LT(std::abs(v - t), u) << k << " cycle " << i + 1;
    }
  }
}

// The options of every reader check themselves; the message names the
// member and the field.
TEST(MeasurementOptions, IsValidNamesTheMemberAndField) {
  MeasurementOptions o;
  std::string error;
  EXPECT_TRUE(o.IsValid(&error));
  o.dial.repeatability_um = -1;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_EQ(
      error.rfind("MeasurementOptions.dial.DialOptions.repeatability_um:", 0),
      0u)
      << error;
  o = MeasurementOptions();
  o.probe.repeatability_um = std::nan("");
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("ProbeReadOptions.repeatability_um"), std::string::npos);
  o = MeasurementOptions();
  o.inspect.stray_sigma = 0;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("InspectOptions.stray_sigma"), std::string::npos);
}

}  // namespace
}  // namespace ttp::inspect
