// Test helpers for the fits: NIST reference pairs (.ds points, .fit
// numbers) and seeded synthetic point sets.
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <fstream>
#include <iterator>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace ttp::fit::testing {

// NIST's certified results hold to these (their files carry about ten
// digits).
constexpr double kNistMm = 1e-6;
constexpr double kNistRad = 1e-8;

inline std::string NistDir() {
  return std::string(TTP_DATA_DIR) + "/reference/nist-fits/";
}

// NIST .ds: count, then x y z per line.
inline Eigen::Matrix3Xd ReadNistPoints(const std::string& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << path;
  long n = 0;
  in >> n;
  Eigen::Matrix3Xd p(3, n);
  for (long i = 0; i < n; ++i) in >> p(0, i) >> p(1, i) >> p(2, i);
  EXPECT_TRUE(in.good()) << path;
  return p;
}

inline std::vector<double> ReadNistFit(const std::string& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << path;
  std::vector<double> v;
  double x;
  while (in >> x) v.push_back(x);
  return v;
}

// Names of the cases of one shape folder, from the README table row.
inline std::vector<std::string> NistCases(const std::string& shape) {
  std::ifstream in(NistDir() + "README.md");
  std::string line;
  std::vector<std::string> names;
  while (std::getline(in, line)) {
    if (line.rfind("| " + shape + " |", 0) != 0) continue;
    const std::string list = line.substr(line.rfind('|', line.size() - 2) + 1);
    std::size_t pos = 0;
    while ((pos = list.find('(', pos)) != std::string::npos) {
      std::size_t start = list.rfind(',', pos);
      start = start == std::string::npos ? 0 : start + 1;
      std::string name = list.substr(start, pos - start);
      name.erase(0, name.find_first_not_of(' '));
      name.erase(name.find_last_not_of(' ') + 1);
      names.push_back(name);
      ++pos;
    }
  }
  return names;
}

inline std::string QifPath() {
  return std::string(TTP_DATA_DIR) +
         "/reference/cmm-files/QIF_PTS_SAMPLE.QIF";
}

// The points of <MeasuredPointSet id="ID"> of the QIF sample.
inline Eigen::Matrix3Xd ReadQifPointSet(const std::string& id) {
  std::ifstream in(QifPath());
  EXPECT_TRUE(in.good()) << QifPath();
  std::string line;
  while (std::getline(in, line)) {
    if (line.find("<MeasuredPointSet id=\"" + id + "\"") != std::string::npos) {
      break;
    }
  }
  while (std::getline(in, line) && line.find("<Points>") == std::string::npos) {
  }
  std::vector<Eigen::Vector3d> points;
  while (std::getline(in, line) &&
         line.find("</Points>") == std::string::npos) {
    if (line.find("<!--") != std::string::npos) continue;
    std::istringstream fields(line);
    Eigen::Vector3d p;
    if (fields >> p.x() >> p.y() >> p.z()) points.push_back(p);
  }
  Eigen::Matrix3Xd m(3, points.size());
  for (std::size_t i = 0; i < points.size(); ++i) m.col(i) = points[i];
  return m;
}

// Numbers inside the first <TAG>...</TAG> after `anchor` in the QIF sample.
inline std::vector<double> QifNumbersAfter(const std::string& anchor,
                                           const std::string& tag) {
  std::ifstream in(QifPath());
  const std::string text((std::istreambuf_iterator<char>(in)),
                         std::istreambuf_iterator<char>());
  const std::size_t at = text.find(anchor);
  EXPECT_NE(at, std::string::npos) << anchor;
  const std::size_t open = text.find("<" + tag + ">", at);
  const std::size_t close = text.find("</" + tag + ">", open);
  std::istringstream numbers(
      text.substr(open + tag.size() + 2, close - open - tag.size() - 2));
  std::vector<double> v;
  double x;
  while (numbers >> x) v.push_back(x);
  return v;
}

// ProbeRadius of every point set in the sample (all equal, uncompensated).
constexpr double kQifProbeRadiusMm = 2.49978271104;

inline Eigen::Vector3d Vec3(const std::vector<double>& v, int at) {
  return Eigen::Vector3d(v[at], v[at + 1], v[at + 2]);
}

// Distance of point p from the line (a, d).
inline double DistanceToLine(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                             const Eigen::Vector3d& d) {
  return (p - a).cross(d.normalized()).norm();
}

// Angle between two directions, sign free.
inline double AxisAngle(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.normalized().cross(b.normalized()).norm(),
                    std::abs(a.normalized().dot(b.normalized())));
}

inline Eigen::Vector3d RandomUnit(std::mt19937_64& rng) {
  std::normal_distribution<double> g(0, 1);
  return Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
}

}  // namespace ttp::fit::testing
