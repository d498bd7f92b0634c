// Multi-dexel material model in the workpiece frame W (mm). Every ray is
// either vertical (+Z) or horizontal and holds the exact material intervals
// along it. Tool sweeps (flat end mills, conical engravers; tool axis +Z)
// along straight segments and about the C axis are cut analytically, so a
// surface position is exact to floating point whatever the ray spacing.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <utility>
#include <vector>

namespace ttp::verify {

// Distance from q to the segment a-b (to a when the segment has no length).
double SegmentDistance(const Eigen::Vector2d& q, const Eigen::Vector2d& a,
                       const Eigen::Vector2d& b);

// Tool body with its tip at the origin, axis +Z: radius at height h above
// the tip is min(radius, h * tan(half_angle)) for a cone (engraver), radius
// for a flat end mill; h in [0, length].
struct ToolShape {
  double radius_mm = 8.0;
  double length_mm = 60.0;
  double tan_half_angle = 0.0;  // 0 = flat end

  // Radius of the cross-section at height h above the tip (< 0: none).
  double RadiusAt(double h_mm) const;
  // Height above the tip where a point at distance d from the axis starts
  // to be inside the tool (d <= radius).
  double HeightFor(double d_mm) const;
};

struct Ray {
  Eigen::Vector3d origin;
  Eigen::Vector3d direction;  // unit; +Z or horizontal
  double length_mm = 0;
  int probe = -1;  // index of the feature probe, -1 = coarse grid only
  // Material as sorted disjoint intervals of the ray parameter s in
  // [0, length].
  std::vector<std::pair<double, double>> material;
  int last_cut_statement = -1;

  bool vertical() const { return direction.z() > 0.5; }
  double MaterialLength() const;
  // Removes [a, b]; returns the length removed.
  double Subtract(double a, double b);
};

// A sweep of the tool in W: straight from start to end (tip positions), or
// about the W Z axis (the C axis) from angle start to end at fixed radius and
// height (rotation).
struct Sweep {
  enum class Kind { kStraight, kRotation } kind = Kind::kStraight;
  ToolShape tool;
  Eigen::Vector3d start_w = Eigen::Vector3d::Zero();  // straight: tip start
  Eigen::Vector3d end_w = Eigen::Vector3d::Zero();
  // Rotation: tip at radius, height z, angle from theta_start to theta_end
  // (rad, either order, any span).
  double radius_mm = 0, z_mm = 0, theta_start_rad = 0, theta_end_rad = 0;

  static Sweep Straight(const ToolShape& tool, const Eigen::Vector3d& a,
                        const Eigen::Vector3d& b);
  static Sweep Rotation(const ToolShape& tool, double radius_mm, double z_mm,
                        double theta_start_rad, double theta_end_rad);
  // Axis-aligned bounds of the swept volume.
  void Bounds(Eigen::Vector3d* lo, Eigen::Vector3d* hi) const;
};

// Intervals of the ray parameter inside the swept volume (possibly
// overlapping; their union is the exact intersection).
std::vector<std::pair<double, double>> SweepIntervals(const Sweep& sweep,
                                                      const Ray& ray);

class DexelModel {
 public:
  // Adds a ray (its material already set by the caller); returns its index.
  int AddRay(Ray ray);
  // Builds the spatial index; call after the last AddRay.
  void Finalize(double cell_mm = 4.0);

  // Cuts the sweep from every ray; returns the largest length removed
  // from one ray and fills which rays lost material (if given).
  double Cut(const Sweep& sweep, int statement, std::vector<int>* touched);
  // Removes explicit intervals from every ray (building ideal stock).
  void SubtractEach(
      const std::function<std::vector<std::pair<double, double>>(const Ray&)>&
          intervals);

  const std::vector<Ray>& rays() const { return rays_; }
  std::vector<Ray>& mutable_rays() { return rays_; }

 private:
  std::vector<Ray> rays_;
  double cell_mm_ = 4.0;
  Eigen::Vector2d grid_lo_ = Eigen::Vector2d::Zero();
  int nx_ = 0, ny_ = 0;
  std::vector<std::vector<int>> cells_;
  std::vector<int> stamp_;
  int stamp_counter_ = 0;
};

// Helpers for ideal stock: intervals of a ray inside a convex polyhedron
// {p : n_i . p <= d_i for all i} (empty or one interval).
std::vector<std::pair<double, double>> ConvexIntervals(
    const std::vector<std::pair<Eigen::Vector3d, double>>& planes,
    const Ray& ray);
// Intervals of a ray inside {r(xy) >= radius, z0 <= z <= z1}.
std::vector<std::pair<double, double>> OutsideCylinderIntervals(
    double radius_mm, double z0_mm, double z1_mm, const Ray& ray);
// Intervals of a ray inside {r(xy) <= radius, z0 <= z <= z1}.
std::vector<std::pair<double, double>> InsideCylinderIntervals(double radius_mm,
                                                               double z0_mm,
                                                               double z1_mm,
                                                               const Ray& ray);

}  // namespace ttp::verify
