#include "ttp/inspect/point_io.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <pcl/PCLPointCloud2.h>
#include <pcl/io/pcd_io.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>

#include "synth_piece.h"
#include "test_dir.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/file_io.h"
#include "ttp/geometry/limits.h"
#include "ttp/inspect/measurement.h"

namespace ttp::inspect {
namespace {

using sim::SynthPiece;

namespace fs = std::filesystem;

class PointIoTest : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = test::TestDir("point_io"); }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path Write(const std::string& name, const std::string& bytes) {
    const fs::path p = dir_ / name;
    std::ofstream(p, std::ios::binary) << bytes;
    return p;
  }
  static std::string ErrorOf(const fs::path& p, ReadOptions o = {}) {
    try {
      ReadPointCloud(p, o);
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  }
  fs::path dir_;
};

SynthPiece SmallPiece() { return test::RandomSynthPiece(77); }

// A synthetic measured piece written in every format and read back through
// LoadMeasurement gives the same points and the same figures.
TEST_F(PointIoTest, EveryFormatRoundTripsToTheSameFigures) {
  const SynthPiece s = SmallPiece();
  const Config config;
  std::vector<CycleFigures> first;
  for (CloudFormat f : kAllCloudFormats) {
    const fs::path p = dir_ / (std::string("piece-") + CloudFormatName(f) +
                               CloudFormatExtension(f));
    WritePointCloud(p, s.cloud, f);
    const PointCloud back = ReadPointCloud(p);
    ASSERT_EQ(back.size(), s.cloud.size()) << CloudFormatName(f);
    EXPECT_LT((back.xyz_mm - s.cloud.xyz_mm).cwiseAbs().maxCoeff(), 1e-9)
        << CloudFormatName(f);
    const Measurement m = LoadMeasurement(config, p);
    EXPECT_EQ(m.kind, MeasurementKind::kCloud);
    if (first.empty()) {
      first = m.result.figures;
      continue;
    }
    for (size_t c = 0; c < first.size(); ++c) {
      EXPECT_NEAR(m.result.figures[c].e_x_mm, first[c].e_x_mm, 1e-9);
      EXPECT_NEAR(m.result.figures[c].e_b_rad, first[c].e_b_rad, 1e-9);
    }
  }
  // Metres, when the user says so.
  PointCloud metres = s.cloud;
  metres.xyz_mm *= 1e-3;
  const fs::path pm = dir_ / "piece-m.xyz";
  WritePointCloud(pm, metres, CloudFormat::kXyz);
  MeasurementOptions mo;
  mo.read.units = LengthUnit::kMetre;
  mo.read.units_given = true;
  const Measurement m = LoadMeasurement(config, pm, mo);
  EXPECT_NEAR(m.result.figures[0].e_x_mm, first[0].e_x_mm, 1e-9);
  // ... and an error naming the problem when they do not.
  try {
    LoadMeasurement(config, pm);
    ADD_FAILURE() << "metres accepted as millimetres";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--units m"), std::string::npos);
  }
}

// A point given twice (double hits, a cloud written twice, one point
// repeated many times) is one measurement: the repeats are dropped with a
// warning, and the figures and their uncertainties are the single cloud's.
TEST_F(PointIoTest, RepeatedPointsCountOnce) {
  const SynthPiece s = SmallPiece();
  const Config config;
  const fs::path once = dir_ / "once.xyz";
  WritePointCloud(once, s.cloud, CloudFormat::kXyz);
  PointCloud twice = s.cloud;
  const Eigen::Index n = s.cloud.size();
  twice.xyz_mm.conservativeResize(3, 2 * n + 500);
  twice.xyz_mm.middleCols(n, n) = s.cloud.xyz_mm;
  for (Eigen::Index k = 0; k < 500; ++k)
    twice.xyz_mm.col(2 * n + k) = s.cloud.xyz_mm.col(n / 2);
  for (CloudFormat f :
       {CloudFormat::kXyz, CloudFormat::kPlyAscii, CloudFormat::kPcdBinary}) {
    const fs::path p = dir_ / (std::string("twice-") + CloudFormatName(f) +
                               CloudFormatExtension(f));
    WritePointCloud(p, twice, f);
    const PointCloud back = ReadPointCloud(p);
    ASSERT_EQ(back.size(), n) << CloudFormatName(f);
    EXPECT_EQ(back.xyz_mm, s.cloud.xyz_mm) << "order kept, first kept";
    ASSERT_EQ(back.warnings.size(), 1u);
    EXPECT_NE(back.warnings[0].find(
                  fmt::format("{} of {} points repeat", n + 500, 2 * n + 500)),
              std::string::npos)
        << back.warnings[0];
    const Measurement a = LoadMeasurement(config, once);
    const Measurement b = LoadMeasurement(config, p);
    ASSERT_EQ(a.result.figures.size(), b.result.figures.size());
    for (size_t c = 0; c < a.result.figures.size(); ++c) {
      EXPECT_EQ(a.result.figures[c].e_z_mm, b.result.figures[c].e_z_mm);
      EXPECT_EQ(a.result.figures[c].u_b_rad, b.result.figures[c].u_b_rad);
    }
  }
}

// Repeats are found by the coordinates' bits through a hash table: points
// on a grid of whole millimetres (their low mantissa bits all zero) are
// all told apart, -0 repeats +0, and points that differ in the last bit of
// one coordinate are two points.
TEST_F(PointIoTest, RepeatsOfRoundCoordinatesAndSignedZeros) {
  std::string text;
  int distinct = 0;
  for (int x = 0; x < 40; ++x)
    for (int y = 0; y < 40; ++y) {
      text += fmt::format("{} {} 0\n", x, y);
      ++distinct;
    }
  // The grid again, zeros negative, and the first 100 points once more.
  for (int x = 0; x < 40; ++x)
    for (int y = 0; y < 40; ++y)
      text += fmt::format("{} {} -0\n", x == 0 ? "-0" : std::to_string(x), y);
  for (int k = 0; k < 100; ++k) text += fmt::format("0 {} 0\n", k % 40);
  // Next to 1 in the last bit: distinct.
  text += fmt::format("{:.17g} 1 0\n", std::nextafter(1.0, 2.0));
  ++distinct;
  const PointCloud back = ReadPointCloud(Write("grid.xyz", text));
  ASSERT_EQ(back.size(), distinct);
  EXPECT_EQ(back.xyz_mm(0, 41), 1.0);
  EXPECT_EQ(back.xyz_mm(1, 41), 1.0);
  EXPECT_EQ(back.xyz_mm(0, distinct - 1), std::nextafter(1.0, 2.0));
  ASSERT_EQ(back.warnings.size(), 1u);
  EXPECT_NE(back.warnings[0].find(fmt::format("{} of {} points repeat",
                                              1600 + 100, 3200 + 100 + 1)),
            std::string::npos)
      << back.warnings[0];
}

TEST_F(PointIoTest, BadFilesNameTheProblem) {
  const SynthPiece s = SmallPiece();
  const fs::path ply = dir_ / "good.ply";
  WritePointCloud(ply, s.cloud, CloudFormat::kPlyBinary);
  std::string bytes = ReadTextFile(ply);
  // Truncated binary: cut in the middle of the vertex data.
  EXPECT_NE(ErrorOf(Write("cut.ply", bytes.substr(0, bytes.size() / 2)))
                .find("cut.ply"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Write("cut.ply", bytes.substr(0, bytes.size() / 2)))
                .find("vertex"),
            std::string::npos);
  // Truncated header.
  EXPECT_NE(ErrorOf(Write("head.ply", "ply\nformat ascii 1.0\nelement vertex"))
                .find("head.ply"),
            std::string::npos);
  // Wrong header for the extension.
  EXPECT_NE(ErrorOf(Write("wrong.ply", "PLX\n1 2 3\n")).find("wrong header"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Write("wrong.pcd", "hello\n")).find("wrong header"),
            std::string::npos);
  // Empty.
  EXPECT_NE(ErrorOf(Write("empty.xyz", "")).find("empty"), std::string::npos);
  EXPECT_NE(ErrorOf(Write("comments.xyz", "# nothing\n\n")).find("no points"),
            std::string::npos);
  // NaN and junk in a text cloud, named by line.
  EXPECT_NE(ErrorOf(Write("nan.xyz", "1 2 3\n4 nan 6\n")).find("nan.xyz:2"),
            std::string::npos);
  EXPECT_NE(
      ErrorOf(Write("junk.csv", "1,2,3\n4,5,6\n7,x,9\n")).find("junk.csv:3"),
      std::string::npos);
  EXPECT_NE(ErrorOf(Write("two.xyz", "1 2 3\n4 5\n")).find("two.xyz:2"),
            std::string::npos);
  // NaN in a binary PLY.
  {
    std::string nan_bytes = bytes;
    const size_t data = nan_bytes.find("end_header\n") + 11;
    const double nan = std::numeric_limits<double>::quiet_NaN();
    std::memcpy(&nan_bytes[data + 24 * 5 + 8], &nan, 8);
    const std::string e = ErrorOf(Write("nan.ply", nan_bytes));
    EXPECT_NE(e.find("vertex 5"), std::string::npos) << e;
  }
  // Unknown format: binary junk without a known header.
  EXPECT_NE(ErrorOf(Write("blob.bin", std::string("\x01\x02\x03\xff", 4)))
                .find("unknown point cloud format"),
            std::string::npos);
}

// PCL's own writer (an independent implementation of the format) in every
// mode it has, coordinates as FLOAT64, organised with NaN "no return"
// points: the reader gives back exactly the doubles written.
TEST_F(PointIoTest, ReadsEveryPcdThatPclWrites) {
  const SynthPiece s = SmallPiece();
  const Eigen::Index n = s.cloud.size();
  const uint32_t width = 100;
  const uint32_t height = static_cast<uint32_t>((n + width - 1) / width) + 1;
  pcl::PCLPointCloud2 pc;
  pc.width = width;
  pc.height = height;  // organised; the last row(s) padded with NaN
  const char* names[4] = {"x", "y", "z", "intensity"};
  for (int a = 0; a < 4; ++a) {
    pcl::PCLPointField f;
    f.name = names[a];
    f.offset = 8 * a;
    f.datatype = pcl::PCLPointField::FLOAT64;
    f.count = 1;
    pc.fields.push_back(f);
  }
  pc.point_step = 32;
  pc.row_step = pc.point_step * width;
  pc.is_dense = false;
  pc.data.assign(static_cast<size_t>(pc.row_step) * height, 0);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (size_t i = 0; i < static_cast<size_t>(width) * height; ++i) {
    double rec[4] = {nan, nan, nan, 1.0};
    if (static_cast<Eigen::Index>(i) < n)
      for (int a = 0; a < 3; ++a) rec[a] = s.cloud.xyz_mm(a, i);
    std::memcpy(pc.data.data() + i * 32, rec, 32);
  }
  const size_t padded = static_cast<size_t>(width) * height - n;
  pcl::PCDWriter writer;
  for (const char* mode : {"ascii", "binary", "binary_compressed"}) {
    const fs::path p = dir_ / (std::string("pcl-") + mode + ".pcd");
    int rc = 0;
    if (std::string(mode) == "ascii")
      rc = writer.writeASCII(p.string(), pc, Eigen::Vector4f::Zero(),
                             Eigen::Quaternionf::Identity(), 17);
    else if (std::string(mode) == "binary")
      rc = writer.writeBinary(p.string(), pc);
    else
      rc = writer.writeBinaryCompressed(p.string(), pc);
    ASSERT_EQ(rc, 0) << mode;
    const PointCloud back = ReadPointCloud(p);
    ASSERT_EQ(back.size(), n) << mode;
    EXPECT_EQ((back.xyz_mm - s.cloud.xyz_mm).cwiseAbs().maxCoeff(), 0.0)
        << mode;
    ASSERT_EQ(back.warnings.size(), 1u) << mode;
    EXPECT_NE(back.warnings[0].find(std::to_string(padded) + " of"),
              std::string::npos)
        << back.warnings[0];
  }
}

// PCL splits a header line on space, tab and CR only; the reader on any
// white space. What PCL is given is the header as checked here, so a
// vertical tab or form feed between words reads as a space does.
TEST_F(PointIoTest, PclReadsTheHeaderAsChecked) {
  const std::string spaced =
      "VERSION 0.7\nFIELDS x y z\nSIZE 8 8 8\nTYPE F F F\nCOUNT 1 1 1\n"
      "WIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA ascii\n1 2 3\n4 5 6.5\n";
  const std::string odd =
      "VERSION 0.7\nFIELDS x\vy\fz\nSIZE 8\v8 8\nTYPE F F\fF\n"
      "COUNT 1 1 1\nWIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA ascii\n1 2 3\n4 5 6.5\n";
  const PointCloud a = ReadPointCloud(Write("spaced.pcd", spaced));
  const PointCloud b = ReadPointCloud(Write("odd.pcd", odd));
  ASSERT_EQ(a.size(), 2);
  ASSERT_EQ(b.size(), 2);
  EXPECT_EQ((a.xyz_mm - b.xyz_mm).cwiseAbs().maxCoeff(), 0.0);
}

// Limits are checked from the header, before anything is allocated for
// the data: a COUNT of 1e9 or POINTS beyond the limit are refused at once.
TEST_F(PointIoTest, LimitsBeforeAllocation) {
  const std::string head =
      "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 8 8 8\nTYPE F F F\n";
  EXPECT_NE(ErrorOf(Write("count.pcd",
                          head + "COUNT 1000000000 1 1\nWIDTH 2\nHEIGHT 1\n"
                                 "POINTS 2\nDATA binary\n"))
                .find("COUNT of x"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Write("points.pcd", head + "COUNT 1 1 1\nWIDTH 4000000000\n"
                                               "HEIGHT 1\nPOINTS 4000000000\n"
                                               "DATA binary\n"))
                .find("limit"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Write("ply.ply",
                          "ply\nformat binary_little_endian 1.0\nelement "
                          "vertex 99999999999999999999\nproperty double x\n"
                          "end_header\n"))
                .find("ply.ply:3"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Write("n.xyz", "1e300 0 0\n0 1 0\n0 0 1\n")).find("limit"),
            std::string::npos);
  // Counts within the limit but far beyond the data: refused before the
  // coordinates are allocated (a few bytes must not cost a gigabyte).
  EXPECT_NE(ErrorOf(Write("short.ply",
                          "ply\nformat ascii 1.0\nelement vertex 50000000\n"
                          "property double x\nproperty double y\nproperty "
                          "double z\nend_header\n1 2 3\n"))
                .find("too short"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Write("short.pcd", head + "COUNT 1 1 1\nWIDTH 50000000\n"
                                              "HEIGHT 1\nPOINTS 50000000\n"
                                              "DATA ascii\n1 2 3\n"))
                .find("too short"),
            std::string::npos);
  // A header line given twice: PCL sizes its buffer on every POINTS line,
  // so a first POINTS of 50 million would cost 400 GB before the second
  // is read; refused here, naming the line.
  EXPECT_NE(ErrorOf(Write("twice.pcd", head + "COUNT 1 1 1024\nWIDTH 2\n"
                                              "HEIGHT 1\nPOINTS 50000000\n"
                                              "POINTS 2\nDATA ascii\n"
                                              "1 2 3\n4 5 6\n"))
                .find("twice.pcd:10: POINTS: given twice (first on line 9)"),
            std::string::npos);
  // Blank space only: no points (and no exception other than InputError).
  EXPECT_NE(ErrorOf(Write("blank.xyz", " \n\t\n")).find("blank"),
            std::string::npos);
}

}  // namespace
}  // namespace ttp::inspect
