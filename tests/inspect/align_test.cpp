// AlignCloud alone: the frame W from the datums of synthetic clouds (the
// project's generator, synth.cpp, in a random pose, and a small one written
// here from test-piece.md whose walls reach the top edge), and the clouds
// whose orientation cannot be determined: refused, naming what is missing.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>

#include "synth_piece.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/inspect/cloud_stages.h"

namespace ttp::inspect {
namespace {

using sim::SynthPiece;

SynthPiece Piece(uint32_t seed, std::vector<std::string> missing = {}) {
  return test::RandomSynthPiece(seed, 20000, std::move(missing));
}

std::string RefusalOf(const PointCloud& cloud) {
  try {
    AlignCloud(PartSpec{}, cloud, InspectOptions{});
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "alignment");
    return e.what();
  }
  return "";
}

// Drops the points whose W position satisfies `drop` (W from the
// generator's own pose, not from the alignment under test).
PointCloud Without(const SynthPiece& s,
                   const std::function<bool(const Eigen::Vector3d&)>& drop) {
  PointCloud out = s.cloud;
  const Eigen::Matrix3Xd w =
      s.rotation.transpose() * (s.cloud.xyz_mm.colwise() - s.translation);
  Eigen::Index kept = 0;
  for (Eigen::Index i = 0; i < w.cols(); ++i)
    if (!drop(w.col(i))) out.xyz_mm.col(kept++) = s.cloud.xyz_mm.col(i);
  out.xyz_mm.conservativeResize(3, kept);
  return out;
}

// W = R cloud + t must invert the generator's cloud = rotation W +
// translation.
void ExpectPoseUndone(const AlignedCloud& a, const SynthPiece& s) {
  std::string warnings;
  for (const std::string& w : a.warnings) warnings += "\n  " + w;
  SCOPED_TRACE(testing::Message()
               << "top face " << a.alignment.top_points << " points, rms "
               << a.alignment.top_rms_mm << " mm; flanks "
               << a.alignment.flank_points[0] << "/"
               << a.alignment.flank_points[1] << "; circle "
               << a.alignment.circle_points << " points, rms "
               << a.alignment.circle_rms_mm << " mm; warnings:" << warnings);
  EXPECT_LT(
      (a.alignment.rotation * s.rotation - Eigen::Matrix3d::Identity()).norm(),
      1e-4);
  EXPECT_LT(
      (a.alignment.rotation * s.translation + a.alignment.translation).norm(),
      2e-3);
}

TEST(AlignCloud, UndoesAnyPose) {
  for (uint32_t seed : {3u, 4u}) {
    const SynthPiece s = Piece(seed);
    const AlignedCloud a = AlignCloud(PartSpec{}, s.cloud, InspectOptions{});
    EXPECT_TRUE(a.alignment.mark_found);
    EXPECT_EQ(a.alignment.mark_points_opposite, 0);
    ExpectPoseUndone(a, s);
    EXPECT_NEAR(a.alignment.circle_diameter_mm, 199.0, 1e-3);
    EXPECT_GT(a.origin_covariance_mm2(0, 0), 0);
    EXPECT_TRUE(a.warnings.empty());
    // The points in W it hands on are the cloud moved by its alignment.
    Eigen::Matrix3Xd w;
    PointsInW(a.alignment, s.cloud.xyz_mm, &w);
    EXPECT_EQ(a.points_w_mm, w);
  }
}

// Strays above the top face (dust, a fixture's edge, double hits: 1 % of
// the points, 5 to 20 mm above it) and 2 % spread over the cloud's box:
// the top face is still the datum, the pose undone as without them.
TEST(AlignCloud, StraysAboveTheTopFaceLeaveTheDatums) {
  const SynthPiece s = Piece(5);
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(0, 1);
  const Eigen::Index n = s.cloud.size();
  const Eigen::Vector3d lo = s.cloud.xyz_mm.rowwise().minCoeff();
  const Eigen::Vector3d hi = s.cloud.xyz_mm.rowwise().maxCoeff();
  for (int kind = 0; kind < 2; ++kind) {
    SCOPED_TRACE(kind == 0 ? "above the top face" : "over the box");
    PointCloud c = s.cloud;
    const Eigen::Index extra = kind == 0 ? n / 100 : n / 50;
    c.xyz_mm.conservativeResize(3, n + extra);
    for (Eigen::Index k = 0; k < extra; ++k) {
      Eigen::Vector3d p;
      if (kind == 0) {
        const double r = 100 * std::sqrt(u(rng)), phi = 2 * M_PI * u(rng);
        const Eigen::Vector3d w(r * std::cos(phi), r * std::sin(phi),
                                5 + 15 * u(rng));
        p = s.rotation * w + s.translation;
      } else {
        for (int a = 0; a < 3; ++a) p(a) = lo(a) + (hi(a) - lo(a)) * u(rng);
      }
      c.xyz_mm.col(n + k) = p;
    }
    ExpectPoseUndone(AlignCloud(PartSpec{}, c, InspectOptions{}), s);
  }
}

// Other surfaces (measurements.md section 1: present and ignored): the
// piece on its adapter (test-piece.md: 180 mm, 30 mm high) on the machine
// table; the piece straight on a CMM table; and that table with three
// clamp posts beside the piece standing 30-50 mm above its top. The table
// is a 600 x 500 mm rectangle off the piece's axis holding 2 or 6 times
// the piece's points. The pose is undone as without them.
TEST(AlignCloud, TableAdapterAndPostsInTheCloudAreLeftOut) {
  const SynthPiece s = Piece(6);
  const Eigen::Index n = s.cloud.size();
  enum Setup { kAdapter, kCmmTable, kPosts };
  for (const Setup setup : {kAdapter, kCmmTable, kPosts}) {
    for (const int share : {2, 6}) {
      SCOPED_TRACE(std::string(setup == kAdapter    ? "adapter"
                               : setup == kCmmTable ? "CMM table"
                                                    : "posts") +
                   ", table share " + std::to_string(share));
      std::mt19937 rng(23 + share);
      std::uniform_real_distribution<double> u(0, 1);
      std::normal_distribution<double> noise(0, 0.002);
      std::vector<Eigen::Vector3d> w;
      const double table_z = setup == kAdapter ? -54 : -24;
      if (setup == kAdapter) {
        for (Eigen::Index k = 0; k < n / 5; ++k) {
          const double phi = 2 * M_PI * u(rng);
          w.emplace_back(90 * std::cos(phi), 90 * std::sin(phi),
                         -54 + 29.5 * u(rng));
        }
      }
      if (setup == kPosts) {
        for (int k = 0; k < 3; ++k) {
          const double a = 0.4 + k * 2 * M_PI / 3, top = 30 + 10 * k;
          const Eigen::Vector2d c(125 * std::cos(a), 125 * std::sin(a));
          for (Eigen::Index m = 0; m < n / 10; ++m) {
            const double phi = 2 * M_PI * u(rng);
            const bool wall = u(rng) < 0.8;
            const double r = wall ? 8 : 8 * std::sqrt(u(rng));
            w.emplace_back(c.x() + r * std::cos(phi), c.y() + r * std::sin(phi),
                           wall ? table_z + (top - table_z) * u(rng) : top);
          }
        }
      }
      const size_t before = w.size();
      while (w.size() < before + static_cast<size_t>(share * n)) {
        const double x = 40 + 600 * (u(rng) - 0.5);
        const double y = -60 + 500 * (u(rng) - 0.5);
        if (std::hypot(x, y) < 101) continue;  // under the rim: not seen
        w.emplace_back(x, y, table_z + noise(rng));
      }
      PointCloud c = s.cloud;
      c.xyz_mm.conservativeResize(3, n + static_cast<Eigen::Index>(w.size()));
      for (size_t k = 0; k < w.size(); ++k)
        c.xyz_mm.col(n + static_cast<Eigen::Index>(k)) =
            s.rotation * w[k] + s.translation;
      const AlignedCloud a = AlignCloud(PartSpec{}, c, InspectOptions{});
      ExpectPoseUndone(a, s);
      EXPECT_NEAR(a.alignment.circle_diameter_mm, 199.0, 1e-3);
    }
  }
}

// Other fixtures a lab measures the piece in (measurements.md section 1:
// present and ignored), each at a random direction about the piece:
//  - a vise holding it by its 201 mm cylinder: two jaws 30 mm thick and
//    150 mm wide, their tops (planes parallel to the top face, at
//    z = -20.5) and outer faces seen, on a vise base at z = -24 wider
//    than the piece, the CMM table at z = -90;
//  - an angle plate beside it: a vertical face 105 mm from the axis,
//    150 or 250 mm wide, rising 60 mm above the top face, with its 25 mm
//    top edge (a plane parallel to the top face, above it);
//  - the table tilted against the piece by 3 degrees (shims, a tilting
//    fixture), 2 mm below the bottom face under the axis.
// The pose is undone as without them.
TEST(AlignCloud, ViseAnglePlateAndTiltedTableAreLeftOut) {
  const SynthPiece s = Piece(8);
  const Eigen::Index n = s.cloud.size();
  enum Setup { kVise, kNarrowAnglePlate, kWideAnglePlate, kTiltedTable };
  for (const Setup setup :
       {kVise, kNarrowAnglePlate, kWideAnglePlate, kTiltedTable}) {
    SCOPED_TRACE(setup == kVise               ? "vise"
                 : setup == kNarrowAnglePlate ? "angle plate 150 mm"
                 : setup == kWideAnglePlate   ? "angle plate 250 mm"
                                              : "table tilted 3 deg");
    std::mt19937 rng(31 + setup);
    std::uniform_real_distribution<double> u(0, 1);
    std::normal_distribution<double> noise(0, 0.002);
    const double dir = 2 * M_PI * u(rng);
    // (along, across, z) about the fixture's direction -> W
    const auto to_w = [dir](double a, double b, double z) {
      return Eigen::Vector3d(a * std::cos(dir) - b * std::sin(dir),
                             a * std::sin(dir) + b * std::cos(dir), z);
    };
    std::vector<Eigen::Vector3d> w;
    double table_z = -24;
    Eigen::Vector2d table_slope(0, 0);
    if (setup == kVise) {
      table_z = -90;
      for (Eigen::Index k = 0; k < n / 2; ++k) {
        const double side = u(rng) < 0.5 ? 1 : -1, f = u(rng);
        const double b = 150 * (u(rng) - 0.5);
        if (f < 0.6)  // a jaw's top
          w.push_back(to_w(side * (100.5 + 30 * u(rng)), b, -20.5));
        else if (f < 0.8)  // its outer face
          w.push_back(to_w(side * 130.5, b, -24 + 3.5 * u(rng)));
        else  // the vise's base around the piece
          w.push_back(
              to_w(side * (130.5 + 49.5 * u(rng)), 200 * (u(rng) - 0.5), -24));
      }
    }
    if (setup == kNarrowAnglePlate || setup == kWideAnglePlate) {
      const double half = setup == kNarrowAnglePlate ? 75 : 125;
      for (Eigen::Index k = 0; k < n / 2; ++k) {
        const double b = 2 * half * (u(rng) - 0.5);
        if (u(rng) < 0.8)  // the face towards the piece
          w.push_back(to_w(105, b, -24 + 84 * u(rng)));
        else  // its top edge
          w.push_back(to_w(105 + 25 * u(rng), b, 60));
      }
    }
    if (setup == kTiltedTable) {
      table_z = -26;
      table_slope = std::tan(3 * M_PI / 180) *
                    Eigen::Vector2d(std::cos(dir), std::sin(dir));
    }
    const size_t before = w.size();
    while (w.size() < before + static_cast<size_t>(2 * n)) {
      const double x = 40 + 600 * (u(rng) - 0.5);
      const double y = -60 + 500 * (u(rng) - 0.5);
      if (std::hypot(x, y) < 101) continue;  // under the rim: not seen
      w.emplace_back(x, y, table_z + table_slope.dot(Eigen::Vector2d(x, y)));
    }
    PointCloud c = s.cloud;
    c.xyz_mm.conservativeResize(3, n + static_cast<Eigen::Index>(w.size()));
    for (size_t k = 0; k < w.size(); ++k) {
      const Eigen::Vector3d jitter(noise(rng), noise(rng), noise(rng));
      c.xyz_mm.col(n + static_cast<Eigen::Index>(k)) =
          s.rotation * (w[k] + jitter) + s.translation;
    }
    const AlignedCloud a = AlignCloud(PartSpec{}, c, InspectOptions{});
    ExpectPoseUndone(a, s);
    EXPECT_NEAR(a.alignment.circle_diameter_mm, 199.0, 1e-3);
  }
}

// x -> -x: every datum is still there, but the mark sits where only a
// mirrored piece has it; the cycles would come out reversed.
TEST(AlignCloud, MirrorImageIsRefused) {
  SynthPiece s = Piece(5);
  s.cloud.xyz_mm.row(0) *= -1;
  const std::string e = RefusalOf(s.cloud);
  EXPECT_NE(e.find("mirror image"), std::string::npos) << e;
}

// Without the datum circle the origin would be the rough centre of the
// other cylinders, micrometres off: refused, naming CYL199.
TEST(AlignCloud, MissingDatumCircleIsRefused) {
  const SynthPiece s = Piece(6, {DatumCylinderId(PartSpec{})});
  const std::string e = RefusalOf(s.cloud);
  EXPECT_NE(e.find("CYL199"), std::string::npos) << e;
  EXPECT_NE(e.find("origin"), std::string::npos) << e;
}

TEST(AlignCloud, MissingMarkIsRefused) {
  const std::string e = RefusalOf(Piece(7, {"MARK"}).cloud);
  EXPECT_NE(e.find("engraved mark"), std::string::npos) << e;
  EXPECT_NE(e.find("X1"), std::string::npos) << e;
}

// The whole X1 sector cut away (its facets, the top face and the mark on
// it): which end is X1 is then unknown, and the cloud is refused rather
// than turned by a guess.
TEST(AlignCloud, MissingSegmentX1SectorIsRefused) {
  const PartSpec part;
  const double centre = part.segment_centre_deg[0] * M_PI / 180;
  const SynthPiece s = Piece(8);
  const PointCloud cut = Without(s, [&](const Eigen::Vector3d& w) {
    return std::abs(std::remainder(std::atan2(w.y(), w.x()) - centre,
                                   2 * M_PI)) < 30 * M_PI / 180;
  });
  ASSERT_LT(cut.xyz_mm.cols(), s.cloud.xyz_mm.cols());
  const std::string e = RefusalOf(cut);
  EXPECT_NE(e.find("engraved mark"), std::string::npos) << e;
}

// Only X1's facets missing (the mark is there): the orientation is found
// and the missing features are X1's, not the opposite segment's.
TEST(AlignCloud, MissingX1FacetsKeepTheOrientation) {
  std::vector<std::string> x1;
  for (int j = 1; j <= PartSpec{}.facets_per_segment; ++j)
    x1.push_back(FacetId(Segment::kX1, j));
  const SynthPiece s = Piece(9, x1);
  const InspectionResult r = InspectCloud(PartSpec{}, s.cloud);
  EXPECT_LT(
      (r.alignment.rotation * s.rotation - Eigen::Matrix3d::Identity()).norm(),
      1e-4);
  for (const FeatureDiagnostic& d : r.diagnostics)
    EXPECT_EQ(d.status == "missing", d.id.rfind("X1-", 0) == 0) << d.id;
  for (size_t c = 0; c < r.figures.size(); ++c)
    EXPECT_NEAR(r.figures[c].e_y_mm, s.truth.figures[c].e_y_mm, 0.2e-3) << c;
}

// A CMM-like cloud of the nominal finished piece written from
// test-piece.md section 2 alone (no project code): the top face (four
// segments, with the mark's groove), the facets, the big-notch flanks and
// the small-notch walls up to `wall_top_mm` below the top edge (a scanner
// sees them up to the edge), the strips, the reference cylinders and a few
// strays; Gaussian noise, a uniformly random pose. The walls carry many
// more points per mm^2 than the top face (as a CMM program measures them):
// within 2 mm of the top they outnumber the face's points.
struct EdgeCloud {
  PointCloud cloud;
  Eigen::Matrix3d rotation;  // cloud = rotation * W + translation
  Eigen::Vector3d translation;
  int top_points = 0;
};

EdgeCloud MakeEdgeCloud(uint32_t seed, double wall_top_mm,
                        double noise_um = 0.5, double top_noise_um = 0.5) {
  constexpr double kPi = M_PI, kDeg = M_PI / 180;
  const double d_facet = 97.3, r_cyl = 99.5, half_notch = 53, small = 5;
  const double centres[4] = {60, 120, 240, 300};
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  auto uni = [&](double a, double b) { return a + (b - a) * u(rng); };
  std::normal_distribution<double> gauss(0, 1);
  // Inside the top face's outline: on a segment (|y| > 53, |x| > 5) and
  // inside its nearest facet's plane.
  auto inside = [&](double x, double y) {
    if (std::abs(y) < half_notch || std::abs(x) < small) return false;
    const double phi = std::atan2(y, x) / kDeg;
    for (double c : centres) {
      const double rel = std::remainder(phi - c, 360.0);
      if (std::abs(rel) > 30) continue;
      const int j = std::clamp(static_cast<int>(std::lround(rel / 6)), -4, 4);
      const double a = (c + 6 * j) * kDeg;
      return x * std::cos(a) + y * std::sin(a) <= d_facet;
    }
    return false;
  };
  // The mark's groove: along phi = 60 deg, r 70..90, 0.6 mm wide.
  auto in_groove = [&](double x, double y) {
    const double a = 60 * kDeg;
    const double along = x * std::cos(a) + y * std::sin(a);
    const double across = -x * std::sin(a) + y * std::cos(a);
    return along > 70 && along < 90 && std::abs(across) < 0.3;
  };
  std::vector<Eigen::Vector3d> w;
  std::vector<double> sigma_um;
  auto add = [&](double x, double y, double z, double s = -1) {
    w.emplace_back(x, y, z);
    sigma_um.push_back(s < 0 ? noise_um : s);
  };
  EdgeCloud out;
  while (out.top_points < 1700) {
    const double x = uni(-d_facet - 1, d_facet + 1);
    const double y = uni(-d_facet - 1, d_facet + 1);
    if (!inside(x, y) || in_groove(x, y)) continue;
    add(x, y, 0, top_noise_um);
    ++out.top_points;
  }
  for (int k = 0; k < 100; ++k) {
    const double a = 60 * kDeg, along = uni(70, 90), across = uni(-0.3, 0.3);
    add(along * std::cos(a) - across * std::sin(a),
        along * std::sin(a) + across * std::cos(a), -0.3);
  }
  const double half_facet = d_facet * std::tan(3 * kDeg);
  for (double c : centres) {
    for (int j = -4; j <= 4; ++j) {
      const double a = (c + 6 * j) * kDeg;
      for (int k = 0; k < 250;) {
        const double t = uni(-half_facet, half_facet);
        const double x = d_facet * std::cos(a) - t * std::sin(a);
        const double y = d_facet * std::sin(a) + t * std::cos(a);
        if (std::abs(y) < half_notch || std::abs(x) < small) continue;
        add(x, y, uni(-12.1, -wall_top_mm));
        ++k;
      }
    }
  }
  for (double side : {-1.0, 1.0}) {
    for (int k = 0; k < 800;) {
      const double x = uni(-d_facet, d_facet);
      if (!inside(x, side * (half_notch + 1e-9))) continue;
      add(x, side * half_notch, uni(-12, -wall_top_mm));
      ++k;
    }
    for (int k = 0; k < 100;) {
      const double y = uni(-d_facet, d_facet);
      if (!inside(side * (small + 1e-9), y)) continue;
      add(side * small, y, uni(-14, -wall_top_mm));
      ++k;
    }
  }
  for (int k = 0; k < 3000;) {
    const double x = uni(-r_cyl, r_cyl), y = uni(-52.75, 52.75);
    if (std::abs(x) < small + 0.5 || std::hypot(x, y) > r_cyl - 0.5) continue;
    add(x, y, -12.1);
    ++k;
  }
  for (int k = 0; k < 1800;) {
    const double a = uni(-kPi, kPi), z = uni(-16, -12);
    if (z > -14 && std::abs(r_cyl * std::cos(a)) < small) continue;
    add(r_cyl * std::cos(a), r_cyl * std::sin(a), z);
    ++k;
  }
  for (int k = 0; k < 600; ++k) {
    const double r = k % 2 ? 100 : 100.5, a = uni(-kPi, kPi);
    add(r * std::cos(a), r * std::sin(a),
        k % 2 ? uni(-20, -16) : uni(-24, -20));
  }
  for (int k = 0; k < 30; ++k)
    add(uni(-100, 100), uni(-100, 100), uni(-24, 2), 0);
  // A uniformly random rotation (a normalised Gaussian quaternion).
  Eigen::Quaterniond q(gauss(rng), gauss(rng), gauss(rng), gauss(rng));
  out.rotation = q.normalized().toRotationMatrix();
  out.translation =
      Eigen::Vector3d(uni(-400, 400), uni(-400, 400), uni(-400, 400));
  out.cloud.source = "edge-cloud";
  out.cloud.xyz_mm.resize(3, static_cast<Eigen::Index>(w.size()));
  for (size_t i = 0; i < w.size(); ++i) {
    const Eigen::Vector3d noise(gauss(rng), gauss(rng), gauss(rng));
    out.cloud.xyz_mm.col(static_cast<Eigen::Index>(i)) =
        out.rotation * (w[i] + sigma_um[i] * 1e-3 * noise) + out.translation;
  }
  return out;
}

// Facets, flanks and notch walls seen up to the top edge (or 0.3 mm, or
// 1 mm, below it): within a few mm of the top they outnumber the face's
// points, and a least-squares plane through all points near the end of the
// axis leans towards them. The top face must still be the face: all of its
// points, Z within 2 urad, figures of the nominal piece within 0.3 um.
TEST(AlignCloud, WallsUpToTheTopEdgeLeaveTheTopFace) {
  for (double wall_top_mm : {0.0, 0.3, 1.0}) {
    for (uint32_t seed : {11u, 12u, 13u}) {
      SCOPED_TRACE(testing::Message()
                   << "wall top " << wall_top_mm << " mm, seed " << seed);
      const EdgeCloud c = MakeEdgeCloud(seed, wall_top_mm);
      const AlignedCloud a = AlignCloud(PartSpec{}, c.cloud, InspectOptions{});
      const Eigen::Vector3d z_true = c.rotation.col(2);
      const double tilt =
          std::acos(std::min(1.0, a.alignment.rotation.row(2).dot(z_true)));
      EXPECT_LT(tilt, 2e-6);
      EXPECT_LT(
          (a.alignment.rotation * c.rotation - Eigen::Matrix3d::Identity())
              .norm(),
          1e-5);
      EXPECT_LT((a.alignment.rotation * c.translation + a.alignment.translation)
                    .norm(),
                1e-4);
      EXPECT_LT(a.alignment.top_rms_mm, 1e-3);
      EXPECT_GT(a.alignment.top_points, 0.95 * c.top_points);
      EXPECT_LE(a.alignment.top_points, c.top_points + 30);
      EXPECT_TRUE(a.alignment.mark_found);
      EXPECT_TRUE(a.warnings.empty());
      const InspectionResult r = InspectCloud(PartSpec{}, c.cloud);
      ASSERT_FALSE(r.figures.empty());
      for (const CycleFigures& f : r.figures) {
        EXPECT_NEAR(f.e_x_mm, 0, 0.3e-3) << f.cycle;
        EXPECT_NEAR(f.e_y_mm, 0, 0.3e-3) << f.cycle;
        EXPECT_NEAR(f.e_z_mm, 0, 0.3e-3) << f.cycle;
        EXPECT_NEAR(f.e_ttp_mm, 0, 0.3e-3) << f.cycle;
        EXPECT_NEAR(f.e_b_rad, 0, 3e-6) << f.cycle;
      }
    }
  }
}

// A top face that is not a plane at the instrument's noise (here 20 um of
// scatter on it against 0.5 um on the flanks) is refused naming the top
// face, not read into a tilted W nor blamed on another datum.
TEST(AlignCloud, TopFaceNotAPlaneIsRefused) {
  const EdgeCloud c = MakeEdgeCloud(14, 0.0, 0.5, 20.0);
  const std::string e = RefusalOf(c.cloud);
  EXPECT_NE(e.find("top face"), std::string::npos) << e;
  EXPECT_NE(e.find("RMS"), std::string::npos) << e;
  EXPECT_EQ(e.find("engraved mark"), std::string::npos) << e;
}

}  // namespace
}  // namespace ttp::inspect
