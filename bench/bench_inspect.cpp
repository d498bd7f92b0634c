// The inspection benchmark: a 1,000,000-point binary PLY (double
// properties, scanner-like sampling, 0.5 um noise, 0.2 % strays) in a random
// pose to all figures. Each pipeline runs in its own child process so that
// its peak memory (ru_maxrss) is its own:
//   ours: ReadPointCloud + InspectCloud (finds the pose itself);
//   PCL:  pcl::PLYReader on a float copy (PCL 1.13 will not load double x
//         into PointXYZ), handed the pose, crop of each feature by its
//         nominal region, SACSegmentation (RANSAC plane, coefficient
//         refinement) -> the same figure code.
// Prints wall time, peak memory, the speed ratio and both accuracies
// against the truth. Never fails. `bench_inspect [points]`.
#include <fmt/format.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "ttp/geometry/features.h"
#include "ttp/geometry/file_io.h"
#include "ttp/inspect/inspect.h"
#include "ttp/inspect/plane_result.h"
#include "ttp/sim/synth.h"

#ifdef TTP_HAVE_PCL
#include <pcl/ModelCoefficients.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>
#include <pcl/sample_consensus/method_types.h>
#include <pcl/sample_consensus/model_types.h>
#include <pcl/segmentation/sac_segmentation.h>
#endif

using namespace ttp;
using namespace ttp::inspect;
using namespace ttp::sim;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

void WriteJson(const std::string& path, const nlohmann::json& doc) {
  WriteFileAtomic(path, doc.dump(1) + "\n");
}

double CpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

double Seconds(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}

nlohmann::json FiguresJson(const PartSpec& part, const FeatureResults& f) {
  InspectionResult r;
  r.features = f;
  ComputeResultFigures(part, &r);
  return InspectionToJson(r)["figures"];
}

// Child: our pipeline.
int RunOurs(const std::string& ply, const std::string& out) {
  const PartSpec part;
  const double c0 = CpuSeconds();
  const auto t0 = Clock::now();
  const PointCloud cloud = ReadPointCloud(ply);
  const auto t1 = Clock::now();
  InspectOptions io;
  const InspectionResult r = InspectCloud(part, cloud, io);
  const auto t2 = Clock::now();
  nlohmann::json doc;
  doc["read_s"] = Seconds(t0, t1);
  doc["inspect_s"] = Seconds(t1, t2);
  doc["cpu_s"] = CpuSeconds() - c0;
  doc["figures"] = InspectionToJson(r)["figures"];
  doc["used"] = r.points_assigned;
  WriteJson(out, doc);
  return 0;
}

#ifdef TTP_HAVE_PCL
// Child: the straightforward PCL pipeline, handed the pose.
int RunPcl(const std::string& ply, const std::string& pose_json,
           const std::string& out) {
  const PartSpec part;
  const nlohmann::json pose = nlohmann::json::parse(ReadTextFile(pose_json));
  Eigen::Matrix3d rot;  // cloud = rot * W + t
  Eigen::Vector3d t;
  for (int i = 0; i < 3; ++i) {
    t(i) = pose["t"][i].get<double>();
    for (int j = 0; j < 3; ++j) rot(i, j) = pose["R"][i][j].get<double>();
  }
  const double c0 = CpuSeconds();
  const auto t0 = Clock::now();
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  pcl::PLYReader reader;
  if (reader.read(ply, *cloud) < 0) return 3;
  const auto t1 = Clock::now();
  // To W (in double, stored as float: W coordinates are within 120 mm).
  const Eigen::Matrix3d rt = rot.transpose();
  for (auto& p : cloud->points) {
    const Eigen::Vector3d w = rt * (Eigen::Vector3d(p.x, p.y, p.z) - t);
    p.x = static_cast<float>(w.x());
    p.y = static_cast<float>(w.y());
    p.z = static_cast<float>(w.z());
  }
  // Crop by the nominal regions (the same margins as InspectCloud).
  const InspectOptions o;
  const double kDeg = M_PI / 180;
  const int facets = part.facets_per_segment;
  std::vector<pcl::Indices> facet_idx(4 * facets), strip_idx(facets);
  const double d_facet = part.facet_final_distance_mm;
  const double half_facet = d_facet * std::tan(part.facet_step_deg / 2 * kDeg);
  const double r_cyl = part.ref_cylinders.front().diameter_mm / 2;
  for (int i = 0; i < static_cast<int>(cloud->size()); ++i) {
    const auto& p = cloud->points[i];
    const double x = p.x, y = p.y, z = p.z;
    if (z > part.facet_bottom_z_mm + o.edge_margin_mm &&
        z < -o.edge_margin_mm) {
      const double phi = std::atan2(y, x) / kDeg;
      for (int s = 0; s < 4; ++s) {
        const double rel =
            std::remainder(phi - part.segment_centre_deg[s], 360.0);
        const int j = static_cast<int>(std::lround(rel / part.facet_step_deg)) +
                      part.reference_index;
        if (j < 1 || j > facets) continue;
        const double a = FacetPhiDeg(part, kSegments[s], j) * kDeg;
        const double radial = x * std::cos(a) + y * std::sin(a);
        const double tang = -x * std::sin(a) + y * std::cos(a);
        if (std::abs(radial - d_facet) < o.capture_band_mm &&
            std::abs(tang) < half_facet - o.facet_edge_margin_mm)
          facet_idx[s * facets + j - 1].push_back(i);
      }
    } else if (std::abs(z - part.strip_floor_z_mm) < o.capture_band_mm) {
      const int k = static_cast<int>(std::lround(y / part.strip_pitch_mm)) +
                    part.reference_index;
      if (k < 1 || k > facets) continue;
      if (std::abs(y - StripY(part, k)) >
          part.strip_width_mm / 2 - o.edge_margin_mm)
        continue;
      const double ye = std::abs(StripY(part, k)) + part.strip_width_mm / 2;
      const double x_end = std::sqrt(std::max(0.0, r_cyl * r_cyl - ye * ye));
      if (std::abs(x) < part.small_notch_half_width_mm + o.edge_margin_mm ||
          std::abs(x) > x_end - o.edge_margin_mm)
        continue;
      strip_idx[k - 1].push_back(i);
    }
  }
  FeatureResults results;
  for (const NominalFeature& f : TestFeatures(part)) {
    const pcl::Indices* idx = nullptr;
    if (f.kind == FeatureKind::kStrip) {
      idx = &strip_idx[f.index - 1];
    } else {
      int s = 0;
      while (kSegments[s] != *f.segment) ++s;
      idx = &facet_idx[s * facets + f.index - 1];
    }
    if (idx->size() < 10) continue;
    pcl::SACSegmentation<pcl::PointXYZ> seg;
    seg.setOptimizeCoefficients(true);
    seg.setModelType(pcl::SACMODEL_PLANE);
    seg.setMethodType(pcl::SAC_RANSAC);
    seg.setDistanceThreshold(0.003);
    seg.setMaxIterations(200);
    seg.setInputCloud(cloud);
    seg.setIndices(std::make_shared<pcl::Indices>(*idx));
    pcl::PointIndices inliers;
    pcl::ModelCoefficients c;
    seg.segment(inliers, c);
    if (c.values.size() != 4) continue;
    const Eigen::Vector3d n(c.values[0], c.values[1], c.values[2]);
    const double nn = n.norm();
    const PlaneInW plane{-c.values[3] / nn * n / nn, n / nn};
    results[f.Key()] = FeatureResultFromPlane(f, plane);
  }
  const auto t2 = Clock::now();
  nlohmann::json doc;
  doc["read_s"] = Seconds(t0, t1);
  doc["inspect_s"] = Seconds(t1, t2);
  doc["cpu_s"] = CpuSeconds() - c0;
  doc["figures"] = FiguresJson(part, results);
  WriteJson(out, doc);
  return 0;
}
#endif

std::string LoadAverage() {
  std::ifstream in("/proc/loadavg");
  std::string a;
  in >> a;
  return a.empty() ? "?" : a;
}

struct ChildResult {
  bool ok = false;
  double wall_s = 0;
  double max_rss_mb = 0;
  nlohmann::json doc;
};

ChildResult RunChild(const std::vector<std::string>& args,
                     const std::string& out) {
  ChildResult r;
  fs::remove(out);
  const auto t0 = Clock::now();
  const pid_t pid = fork();
  if (pid == 0) {
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    execv("/proc/self/exe", argv.data());
    _exit(127);
  }
  int status = 0;
  struct rusage ru {};
  wait4(pid, &status, 0, &ru);
  r.wall_s = Seconds(t0, Clock::now());
  r.max_rss_mb = ru.ru_maxrss / 1024.0;
  r.ok = WIFEXITED(status) && WEXITSTATUS(status) == 0 && fs::exists(out);
  if (r.ok) r.doc = nlohmann::json::parse(ReadTextFile(out));
  return r;
}

// Largest |figure - truth| over cycles: linear (um) and E_B (um/m).
std::pair<double, double> Errors(const nlohmann::json& got,
                                 const nlohmann::json& truth) {
  double lin = 0, ang = 0;
  for (size_t i = 0; i < truth.size(); ++i) {
    for (const char* k : {"E_X", "E_Y", "E_Z", "E_TTP", "E_B"}) {
      const auto& g = got[i][k];
      const double e =
          g.is_null() ? INFINITY
                      : std::abs(g.get<double>() - truth[i][k].get<double>());
      (std::strcmp(k, "E_B") ? lin : ang) =
          std::max(std::strcmp(k, "E_B") ? lin : ang, e);
    }
  }
  return {lin, ang};
}

}  // namespace

int main(int argc, char** argv) {
  if (argc >= 4 && std::string(argv[1]) == "--ours")
    return RunOurs(argv[2], argv[3]);
#ifdef TTP_HAVE_PCL
  if (argc >= 5 && std::string(argv[1]) == "--pcl")
    return RunPcl(argv[2], argv[3], argv[4]);
#endif
  const int points = argc >= 2 ? std::atoi(argv[1]) : 1000000;
  const PartSpec part;
  const fs::path dir = fs::temp_directory_path() / "ttp_bench_inspect";
  fs::create_directories(dir);
  const auto g0 = Clock::now();
  const PartMesh mesh = BuildPartMesh(part, Stage::kFinished);
  SynthOptions so;
  so.points = points;
  so.noise_um = 0.5;
  so.stray_fraction = 0.002;
  so.sampling = SynthSampling::kScanner;
  so.seed = 2026;
  const SynthPiece s =
      SynthesizePiece(part, mesh, RandomDeviations(part, so), so);
  const std::string ply = (dir / "piece.ply").string();
  WritePointCloud(ply, s.cloud, CloudFormat::kPlyBinary);
  const nlohmann::json truth = InspectionToJson(s.truth)["figures"];
  fmt::print(
      "cloud: {} points ({} on the piece, 0.5 um noise, 0.2 % strays, "
      "scanner sampling, random pose), binary PLY of doubles, {:.1f} "
      "MB; made in {:.2f} s\n",
      s.cloud.size(), points, fs::file_size(ply) / 1e6,
      Seconds(g0, Clock::now()));

  const ChildResult ours =
      RunChild({"bench_inspect", "--ours", ply, (dir / "ours.json").string()},
               (dir / "ours.json").string());
  if (!ours.ok) {
    fmt::print("ours: FAILED\n");
    return 0;
  }
  const auto [ours_lin, ours_ang] = Errors(ours.doc["figures"], truth);
  fmt::print(
      "ours: wall {:.3f} s (read {:.3f} s + align/segment/fit {:.3f} s; CPU "
      "{:.3f} s; whole process {:.3f} s), peak memory {:.0f} MB; max |error| "
      "{:.4f} um linear, {:.3f} um/m E_B (targets <= 0.5 s, <= 500 MB, <= "
      "0.05 um)\n",
      ours.doc["read_s"].get<double>() + ours.doc["inspect_s"].get<double>(),
      ours.doc["read_s"].get<double>(), ours.doc["inspect_s"].get<double>(),
      ours.doc["cpu_s"].get<double>(), ours.wall_s, ours.max_rss_mb, ours_lin,
      ours_ang);

#ifdef TTP_HAVE_PCL
  // PCL's PLY reader needs float properties: a float copy (not timed).
  {
    const std::string fply = (dir / "piece-float.ply").string();
    std::string out = "ply\nformat binary_little_endian 1.0\nelement vertex " +
                      std::to_string(s.cloud.size()) +
                      "\nproperty float x\nproperty float y\nproperty float "
                      "z\nend_header\n";
    const size_t head = out.size();
    out.resize(head + 12 * s.cloud.size());
    for (Eigen::Index i = 0; i < s.cloud.size(); ++i) {
      const float v[3] = {static_cast<float>(s.cloud.xyz_mm(0, i)),
                          static_cast<float>(s.cloud.xyz_mm(1, i)),
                          static_cast<float>(s.cloud.xyz_mm(2, i))};
      std::memcpy(&out[head + 12 * i], v, 12);
    }
    WriteFileAtomic(fply, out);
    nlohmann::json pose;
    for (int i = 0; i < 3; ++i) {
      pose["t"].push_back(s.translation(i));
      pose["R"].push_back(
          {s.rotation(i, 0), s.rotation(i, 1), s.rotation(i, 2)});
    }
    WriteJson((dir / "pose.json").string(), pose);
    const ChildResult pcl =
        RunChild({"bench_inspect", "--pcl", fply, (dir / "pose.json").string(),
                  (dir / "pcl.json").string()},
                 (dir / "pcl.json").string());
    if (!pcl.ok) {
      fmt::print("PCL: FAILED\n");
      return 0;
    }
    const auto [pcl_lin, pcl_ang] = Errors(pcl.doc["figures"], truth);
    const double pcl_s =
        pcl.doc["read_s"].get<double>() + pcl.doc["inspect_s"].get<double>();
    const double ours_s =
        ours.doc["read_s"].get<double>() + ours.doc["inspect_s"].get<double>();
    fmt::print(
        "PCL (handed the pose; float cloud): wall {:.3f} s (read {:.3f} s + "
        "crop/RANSAC {:.3f} s; CPU {:.3f} s), peak memory {:.0f} MB; max "
        "|error| {:.4f} um linear, {:.3f} um/m E_B\n",
        pcl_s, pcl.doc["read_s"].get<double>(),
        pcl.doc["inspect_s"].get<double>(), pcl.doc["cpu_s"].get<double>(),
        pcl.max_rss_mb, pcl_lin, pcl_ang);
    fmt::print(
        "time ratio ours / PCL: wall {:.2f}, CPU {:.2f} (ours also finds the "
        "pose; load average at the run: {})\n",
        ours_s / pcl_s,
        ours.doc["cpu_s"].get<double>() / pcl.doc["cpu_s"].get<double>(),
        LoadAverage());
  }
#else
  fmt::print("PCL: not built (PCL not found)\n");
#endif
  return 0;
}
