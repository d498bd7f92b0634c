// Diagnosis on measured pieces read from files in every accepted format.
#include "ttp/diagnosis/diagnose.h"

#include <gtest/gtest.h>

#include <cctype>
#include <cmath>
#include <filesystem>
#include <limits>
#include <sstream>

#include "test_dir.h"
#include "ttp/diagnosis/twin.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/file_io.h"
#include "ttp/thermal/talc_log.h"

namespace ttp::diagnosis {
namespace {

namespace fs = std::filesystem;

fs::path TempFile(const std::string& name, const std::string& text) {
  const fs::path dir = test::TestDir("diagnose");
  WriteFileAtomic(dir / name, text);
  return dir / name;
}

// The facet angles of an inspection JSON (`ttp inspect --json`) must reach
// the model: a C-axis indexing error shows only in them.
TEST(Diagnose, InspectionJsonCarriesFacetAnglesToTheModel) {
  const Config config;
  TwinOptions o;
  o.effect = Cause::kCAxisIndexing;
  o.size = 150;  // urad
  o.seed = 7;
  const TwinRun twin = RunTwin(config, o);
  const fs::path path =
      TempFile("c_axis.json",
               MeasuredInspectionJson(config.part, twin.measured).dump(1));
  const MeasuredPiece measured = LoadMeasuredPiece(config, path.string());
  EXPECT_EQ(measured.facet_angle_rad.size(), 36u);
  ASSERT_EQ(measured.features.size(), twin.measured.size());
  for (const auto& [id, r] : twin.measured) {
    const FeatureResult& m = measured.features.at(id);
    EXPECT_NEAR(m.d_mm, r.d_mm, 1e-12) << id;
    EXPECT_NEAR(m.angle_rad, r.angle_rad, 1e-15) << id;
    EXPECT_NEAR(m.var_angle_rad2, r.var_angle_rad2, 1e-6 * r.var_angle_rad2);
  }
  const thermal::TalcLog log = thermal::ParseTalcLog(twin.log_text, "twin");
  const DiagnosisReport report = DiagnoseRun(log, config, measured);
  EXPECT_GT(report.baseline_rms_urad, 10.0);
  EXPECT_LT(report.extended_rms_urad, report.baseline_rms_urad / 3);
  EXPECT_EQ(report.cause, "c_axis_indexing");
  double amplitude = 0, u = 0;
  for (const auto& p : report.params)
    if (p.name == "amplitude_urad") amplitude = p.value, u = p.uncertainty;
  EXPECT_NEAR(amplitude, o.size, 3 * u + 5);
}

TEST(Diagnose, InspectionJsonMissingFeatureIsLeftOut) {
  const Config config;
  TwinOptions o;
  o.seed = 3;
  const TwinRun twin = RunTwin(config, o);
  nlohmann::json doc = MeasuredInspectionJson(config.part, twin.measured);
  doc["facets"]["X1-3"]["distance_mm"] = nullptr;
  doc["facets"]["X1-3"]["angle_error_urad"] = nullptr;
  const MeasuredPiece m =
      LoadMeasuredPiece(config, TempFile("piece.json", doc.dump()).string());
  EXPECT_EQ(m.features.count("X1-3"), 0u);
  EXPECT_EQ(m.facet_angle_rad.size(), 35u);
}

TEST(Diagnose, BadMeasurementJsonNamesFileAndField) {
  const Config config;
  const TwinRun twin = RunTwin(config, TwinOptions{});
  nlohmann::json doc = MeasuredInspectionJson(config.part, twin.measured);
  doc["facets"]["X1-2"]["angle_error_urad"] = "abc";
  try {
    LoadMeasuredPiece(config, TempFile("piece.json", doc.dump()).string());
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("piece.json"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("facets.X1-2.angle_error_urad"),
              std::string::npos)
        << e.what();
  }
  nlohmann::json other = {{"facets", {{"Q7", {{"distance_mm", 1.0}}}}}};
  EXPECT_THROW(LoadMeasuredPiece(config, TempFile("x.json", other.dump())),
               InputError);
  EXPECT_THROW(LoadMeasuredPiece(config, TempFile("array.json", "[]")),
               InputError);
  EXPECT_THROW(LoadMeasuredPiece(config, TempFile("bad.json", "{not json")),
               InputError);
}

// A dial gauge measures no angle, and a feature may be missing: neither
// becomes an observation (nor a NaN in one).
TEST(Diagnose, UnmeasuredAnglesAndMissingFeaturesAreLeftOut) {
  const Config config;
  const TwinRun twin = RunTwin(config, TwinOptions{});
  FeatureResults features = twin.measured;
  features.at("X1-2").angle_rad = std::numeric_limits<double>::quiet_NaN();
  features.at("X1-3").present = false;
  const MeasuredPiece m = MeasuredPieceFromFeatures(config.part, features);
  EXPECT_EQ(m.features.count("X1-3"), 0u);
  EXPECT_EQ(m.facet_angle_rad.count("X1-2"), 0u);
  EXPECT_EQ(m.facet_angle_rad.size(), 34u);
  const thermal::TalcLog log = thermal::ParseTalcLog(twin.log_text, "twin");
  const PreparedRun run = PrepareRun(log, config, m, DiagnosisOptions{});
  int angles = 0;
  for (size_t i = 0; i < run.observations.size(); ++i) {
    EXPECT_TRUE(std::isfinite(run.observations.value[i]))
        << run.observations.labels[i];
    angles += run.observations.group[i] == 4;
  }
  EXPECT_EQ(angles, 34);
}

// The samples' truth.json: figures and facet angles, no features.
TEST(Diagnose, FiguresAndFacetAnglesAreReadAsGiven) {
  const Config config;
  // The figures and facet angles of the sample's truth, without the rest of
  // the truth file (a truth file itself is refused as a measurement).
  const nlohmann::json truth = nlohmann::json::parse(ReadTextFile(
      std::string(TTP_DATA_DIR) + "/samples/run-a/truth.json"));
  const std::string path =
      (test::TestDir("diagnose-figures") / "figures.json").string();
  WriteFileAtomic(path, nlohmann::json{{"figures", truth["figures"]},
                                       {"facet_angle_err_urad",
                                        truth["facet_angle_err_urad"]}}
                            .dump());
  const MeasuredPiece m = LoadMeasuredPiece(config, path);
  EXPECT_TRUE(m.features.empty());
  EXPECT_EQ(m.figures.size(), truth["figures"].size());
  ASSERT_EQ(m.facet_angle_rad.size(), truth["facet_angle_err_urad"].size());
  for (const auto& [id, urad] : truth["facet_angle_err_urad"].items())
    EXPECT_NEAR(m.facet_angle_rad.at(id), urad.get<double>() * 1e-6, 1e-15);
}

// A piece measured after another run's log: refused, not diagnosed.
TEST(Diagnose, MeasurementOfAnotherRunIsRefused) {
  const Config config;
  TwinOptions a;
  a.seed = 21;
  TwinOptions b = a;
  b.seed = 22;
  b.effect = Cause::kWorkpieceExpansion;
  b.size = 1.0;
  const TwinRun run_a = RunTwin(config, a), run_b = RunTwin(config, b);
  const thermal::TalcLog log_a = thermal::ParseTalcLog(run_a.log_text, "a.csv");
  // Its own piece is fine.
  EXPECT_EQ(DiagnoseRun(log_a, config,
                        MeasuredPieceFromFeatures(config.part, run_a.measured))
                .cause,
            "none");
  MeasuredPiece other = MeasuredPieceFromFeatures(config.part, run_b.measured);
  other.source = "b.json";
  try {
    DiagnoseRun(log_a, config, other);
    FAIL() << "a piece of another run was diagnosed";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("do not belong together"),
              std::string::npos)
        << e.what();
  }
}

// A log without the last cycles' cuts does not cover the measured piece.
TEST(Diagnose, LogWithoutTheMeasuredCutsIsRefused) {
  const Config config;
  TwinOptions o;
  o.seed = 5;
  const TwinRun run = RunTwin(config, o);
  std::string shortened;
  std::istringstream in(run.log_text);
  for (std::string line; std::getline(in, line);) {
    if (!line.empty() && std::isdigit(static_cast<unsigned char>(line[0])) &&
        std::stod(line) > 4 * 3600 + 600)
      break;
    shortened += line + "\n";
  }
  const thermal::TalcLog log = thermal::ParseTalcLog(shortened, "short.csv");
  try {
    DiagnoseRun(log, config,
                MeasuredPieceFromFeatures(config.part, run.measured));
    FAIL() << "diagnosed a piece the log did not cut";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("short.csv"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("X1-6"), std::string::npos)
        << e.what();
  }
}

// A cutter does not grow: negative wear is not a fit of tool_wear.
TEST(Diagnose, ToolWearIsNeverNegative) {
  const Config config;
  TwinOptions o;
  o.seed = 8;
  const TwinRun run = RunTwin(config, o);
  FeatureResults grown = run.measured;
  const PreparedRun prepared =
      PrepareRun(thermal::ParseTalcLog(run.log_text, "twin"), config,
                 MeasuredPieceFromFeatures(config.part, grown));
  for (const CutState& s : prepared.context.cuts)
    if (s.is_facet) grown[s.feature].d_mm -= 3e-3 * s.cut_length_mid_m;
  DiagnosisOptions options;
  options.max_chi2_per_dof = 1e9;  // (a growing cutter is no known cause)
  const DiagnosisReport report =
      DiagnoseRun(thermal::ParseTalcLog(run.log_text, "twin"), config,
                  MeasuredPieceFromFeatures(config.part, grown), options);
  EXPECT_NE(report.cause, "tool_wear");
  for (const CandidateResult& c : report.candidates)
    if (c.cause == Cause::kToolWear) {
      EXPECT_EQ(c.params.at(0), 0.0);
      EXPECT_GE(c.delta_bic, 0.0);
    }
}

}  // namespace
}  // namespace ttp::diagnosis
