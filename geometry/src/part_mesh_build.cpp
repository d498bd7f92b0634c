// BuildPartMesh: the piece as a stack of prismatic z-bands. Every band's
// cross-section is "base disc minus a union of convex removal regions"
// (notches, facet half-planes, strips, mark, bolt holes). All region
// boundaries of all bands go into ONE constrained Delaunay triangulation with
// exact intersections, so each triangle is entirely inside or outside every
// region: membership is decided exactly at the triangle's centroid, and the
// solid is the union of vertical prisms over triangles. Horizontal faces sit
// where membership changes between bands, walls where it changes across a
// triangulation edge; both share the triangulation's vertices, so the mesh is
// closed and manifold without any welding.
#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_exact_constructions_kernel.h>
#include <CGAL/Triangulation_face_base_with_info_2.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <unordered_map>

#include "ttp/geometry/constants.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/part_mesh.h"

namespace ttp {
bool PartMeshOptions::IsValid(std::string* error) const {
  const auto fail = [error](const std::string& message) {
    if (error) *error = message;
    return false;
  };
  if (!(chord_error_mm > 0) || !std::isfinite(chord_error_mm))
    return fail("PartMeshOptions.chord_error_mm: must be a positive length");
  if (!(facet_overrun_mm >= 0) || !std::isfinite(facet_overrun_mm))
    return fail("PartMeshOptions.facet_overrun_mm: must be a length >= 0");
  return true;
}

namespace {

using K = CGAL::Epeck;
using Point2 = K::Point_2;
using Vb = CGAL::Triangulation_vertex_base_with_info_2<int, K>;
using Fb0 = CGAL::Constrained_triangulation_face_base_2<K>;
using Fb = CGAL::Triangulation_face_base_with_info_2<int, K, Fb0>;
using Tds = CGAL::Triangulation_data_structure_2<Vb, Fb>;
using Cdt =
    CGAL::Constrained_Delaunay_triangulation_2<K, Tds,
                                               CGAL::Exact_intersections_tag>;

enum class RegionKind {
  kBase,  // the disc of a band (blank, reference cylinder, rim)
  kSmallNotch,
  kBigNotch,
  kFacet,
  kStrip,
  kMark,
  kBoltHole,
};

// A convex polygon (counter-clockwise) of the W plane.
struct Region {
  RegionKind kind;
  std::string wall_tag;  // id given to walls on its boundary
  std::string floor_tag;
  std::vector<Point2> polygon;
  Eigen::Vector2d box_min, box_max;
  // Regular polygons (circles): sector lookup instead of scanning all edges.
  bool regular = false;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double inner_radius = 0, outer_radius = 0;
  Eigen::Vector2d facet_normal = Eigen::Vector2d::Zero();
  int cycle = -1;  // strips: later cycles own overlaps
};

struct Band {
  double z_bottom, z_top;
  int base = -1;
  std::vector<int> removals;
};

Region MakePolygon(RegionKind kind, const std::vector<Eigen::Vector2d>& pts) {
  Region r;
  r.kind = kind;
  r.box_min = r.box_max = pts.front();
  for (const Eigen::Vector2d& p : pts) {
    r.polygon.emplace_back(p.x(), p.y());
    r.box_min = r.box_min.cwiseMin(p);
    r.box_max = r.box_max.cwiseMax(p);
  }
  return r;
}

// Inscribed regular polygon whose chords stay within chord_error_mm.
Region MakeCircle(RegionKind kind, const Eigen::Vector2d& centre, double radius,
                  double chord_error_mm) {
  const double half_angle =
      std::acos(std::max(-1.0, 1.0 - chord_error_mm / radius));
  const int n = std::max(8, static_cast<int>(std::ceil(M_PI / half_angle)));
  std::vector<Eigen::Vector2d> pts;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * M_PI * i / n;
    pts.push_back(centre + radius * Eigen::Vector2d(std::cos(a), std::sin(a)));
  }
  Region r = MakePolygon(kind, pts);
  r.regular = true;
  r.centre = centre;
  r.outer_radius = radius;
  r.inner_radius = radius * std::cos(M_PI / n);
  return r;
}

Region MakeRect(RegionKind kind, double x0, double x1, double y0, double y1) {
  return MakePolygon(kind, {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}});
}

bool LeftOf(const Point2& a, const Point2& b, const Point2& c) {
  return CGAL::orientation(a, b, c) == CGAL::LEFT_TURN;
}

// Exact membership of a point that lies on no region boundary.
bool Contains(const Region& r, const Point2& p, const Eigen::Vector2d& p_d) {
  constexpr double kMargin = 1e-6;
  if ((p_d.array() < r.box_min.array() - kMargin).any() ||
      (p_d.array() > r.box_max.array() + kMargin).any()) {
    return false;
  }
  const int n = static_cast<int>(r.polygon.size());
  if (r.regular) {
    const Eigen::Vector2d d = p_d - r.centre;
    const double dist = d.norm();
    if (dist < r.inner_radius - kMargin) return true;
    if (dist > r.outer_radius + kMargin) return false;
    double a = std::atan2(d.y(), d.x());
    if (a < 0) a += 2 * M_PI;
    const int sector = static_cast<int>(std::floor(a / (2 * M_PI) * n));
    for (int k = sector - 1; k <= sector + 1; ++k) {
      const int i = ((k % n) + n) % n;
      if (!LeftOf(r.polygon[i], r.polygon[(i + 1) % n], p)) return false;
    }
    return true;
  }
  for (int i = 0; i < n; ++i) {
    if (!LeftOf(r.polygon[i], r.polygon[(i + 1) % n], p)) return false;
  }
  return true;
}

[[noreturn]] void Bad(const std::string& field, const std::string& why) {
  throw InputError("part", 0, "part." + field, why);
}

void ValidatePart(const PartSpec& p, const PartMeshOptions& o) {
  const auto positive = [](double v, const char* field) {
    if (!(v > 0) || !std::isfinite(v)) Bad(field, "must be positive");
  };
  positive(p.blank_diameter_mm, "blank_diameter_mm");
  positive(p.blank_height_mm, "blank_height_mm");
  positive(p.rim_diameter_mm, "rim_diameter_mm");
  positive(p.small_notch_half_width_mm, "small_notch_half_width_mm");
  positive(p.big_notch_half_width_mm, "big_notch_half_width_mm");
  positive(p.facet_pre_distance_mm, "facet_pre_distance_mm");
  positive(p.facet_final_distance_mm, "facet_final_distance_mm");
  positive(p.facet_step_deg, "facet_step_deg");
  positive(p.strip_width_mm, "strip_width_mm");
  positive(p.mark_depth_mm, "mark_depth_mm");
  positive(p.mark_width_mm, "mark_width_mm");
  positive(p.bolt_hole_diameter_mm, "bolt_hole_diameter_mm");
  positive(p.bolt_hole_depth_mm, "bolt_hole_depth_mm");
  std::string error;
  if (!o.IsValid(&error)) {
    const size_t colon = error.find(':');
    throw InputError("part mesh options", 0, error.substr(0, colon),
                     error.substr(colon + 2));
  }
  if (!(p.face_depth_mm >= 0) || p.face_depth_mm >= p.blank_height_mm) {
    Bad("face_depth_mm", "must be in [0, blank_height_mm)");
  }
  const double h = p.height_mm();
  const double blank_r = p.blank_diameter_mm / 2;
  if (p.rim_diameter_mm > p.blank_diameter_mm) {
    Bad("rim_diameter_mm", "larger than the blank");
  }
  if (p.facets_per_segment < 1) Bad("facets_per_segment", "must be >= 1");
  if (p.facet_pre_distance_mm < p.facet_final_distance_mm) {
    Bad("facet_pre_distance_mm", "smaller than facet_final_distance_mm");
  }
  if (p.facet_pre_distance_mm >= p.rim_diameter_mm / 2) {
    Bad("facet_pre_distance_mm", "facets do not cut the rim");
  }
  if (p.ref_cylinders.empty()) Bad("ref_cylinders", "empty");
  for (const RefCylinder& c : p.ref_cylinders) {
    positive(c.diameter_mm, "ref_cylinders.diameter_mm");
    if (c.diameter_mm > p.blank_diameter_mm) {
      Bad("ref_cylinders.diameter_mm", "larger than the blank");
    }
    if (!(c.z_bottom_mm < c.z_top_mm) || c.z_bottom_mm < -h - 1e-9 ||
        c.z_top_mm > 0) {
      Bad("ref_cylinders", "z range empty or outside the piece");
    }
  }
  for (const auto& [value, field] :
       {std::pair{p.small_notch_floor_z_mm, "small_notch_floor_z_mm"},
        {p.big_notch_floor_z_mm, "big_notch_floor_z_mm"},
        {p.facet_bottom_z_mm, "facet_bottom_z_mm"},
        {p.strip_floor_z_mm, "strip_floor_z_mm"}}) {
    if (!(value > -h && value < 0)) Bad(field, "not inside the piece height");
  }
  if (p.mark_depth_mm >= h) Bad("mark_depth_mm", "deeper than the piece");
  if (p.bolt_hole_depth_mm >= h) {
    Bad("bolt_hole_depth_mm", "deeper than the piece");
  }
  if (p.bolt_circle_diameter_mm / 2 + p.bolt_hole_diameter_mm / 2 >= blank_r) {
    Bad("bolt_circle_diameter_mm", "holes outside the blank");
  }
  if (!(p.mark_r_start_mm < p.mark_r_end_mm) || p.mark_r_start_mm < 0) {
    Bad("mark_r_start_mm", "mark r range empty");
  }
  if (p.mark_r_end_mm >= p.rim_diameter_mm / 2) {
    Bad("mark_r_end_mm", "mark runs off the piece");
  }
}

}  // namespace

PartMesh BuildPartMesh(const PartSpec& p, Stage stage,
                       const PartMeshOptions& options) {
  ValidatePart(p, options);
  const double e = options.chord_error_mm;
  const double h = p.height_mm();
  // Removal regions reach well past the blank so that they cut through.
  const double far = p.blank_diameter_mm;
  std::vector<Region> regions;
  const auto add = [&](Region r) {
    regions.push_back(std::move(r));
    return static_cast<int>(regions.size()) - 1;
  };

  std::vector<double> z_levels = {-h, 0.0};
  std::vector<int> bolt_holes;
  for (double phi_deg : p.bolt_phi_deg) {
    const double phi = phi_deg * kDeg;
    Region r = MakeCircle(RegionKind::kBoltHole,
                          p.bolt_circle_diameter_mm / 2 *
                              Eigen::Vector2d(std::cos(phi), std::sin(phi)),
                          p.bolt_hole_diameter_mm / 2, e);
    r.wall_tag = r.floor_tag = "BOLT_HOLE";
    bolt_holes.push_back(add(std::move(r)));
  }
  const double bolt_top_z = -h + p.bolt_hole_depth_mm;
  z_levels.push_back(bolt_top_z);

  std::vector<Band> bands;
  if (stage == Stage::kBlank) {
    Region blank = MakeCircle(RegionKind::kBase, Eigen::Vector2d::Zero(),
                              p.blank_diameter_mm / 2, e);
    blank.wall_tag = "CYL_BLANK";
    const int base = add(std::move(blank));
    z_levels[1] = p.face_depth_mm;
    std::sort(z_levels.begin(), z_levels.end());
    for (size_t i = 0; i + 1 < z_levels.size(); ++i) {
      Band b{z_levels[i], z_levels[i + 1], base, {}};
      if ((b.z_bottom + b.z_top) / 2 < bolt_top_z) b.removals = bolt_holes;
      bands.push_back(b);
    }
  } else {
    const bool finished = stage == Stage::kFinished;
    std::vector<std::pair<int, const RefCylinder*>> cylinders;
    double cylinders_top = -h;
    for (const RefCylinder& c : p.ref_cylinders) {
      Region r = MakeCircle(RegionKind::kBase, Eigen::Vector2d::Zero(),
                            c.diameter_mm / 2, e);
      r.wall_tag = CylinderId(c.diameter_mm);
      cylinders.emplace_back(add(std::move(r)), &c);
      z_levels.push_back(c.z_bottom_mm);
      z_levels.push_back(c.z_top_mm);
      cylinders_top = std::max(cylinders_top, c.z_top_mm);
    }
    Region rim_region = MakeCircle(RegionKind::kBase, Eigen::Vector2d::Zero(),
                                   p.rim_diameter_mm / 2, e);
    rim_region.wall_tag = "RIM";
    const int rim = add(std::move(rim_region));

    const double hs = p.small_notch_half_width_mm;
    Region small = MakeRect(RegionKind::kSmallNotch, -hs, hs, -far, far);
    small.wall_tag = "NOTCH_SMALL_WALL";
    small.floor_tag = "NOTCH_SMALL";
    const int small_notch = add(std::move(small));
    const double hb = p.big_notch_half_width_mm;
    Region big = MakeRect(RegionKind::kBigNotch, -far, far, -hb, hb);
    big.floor_tag = "NOTCH_BIG";
    const int big_notch = add(std::move(big));

    std::vector<int> facets;
    const double d =
        finished ? p.facet_final_distance_mm : p.facet_pre_distance_mm;
    const double half = d * std::tan(p.facet_step_deg / 2 * kDeg);
    for (Segment s : kSegments) {
      for (int j = 1; j <= p.facets_per_segment; ++j) {
        const double phi = FacetPhiDeg(p, s, j) * kDeg;
        const Eigen::Vector2d n(std::cos(phi), std::sin(phi));
        const Eigen::Vector2d t(-n.y(), n.x());
        // Between neighbours a pass overruns the corner (harmless: that
        // area is inside the neighbour's cut); at a segment end the cutter
        // runs out into the notch.
        const double t_lo = j == 1 ? -far : -half - options.facet_overrun_mm;
        const double t_hi =
            j == p.facets_per_segment ? far : half + options.facet_overrun_mm;
        Region r = MakePolygon(RegionKind::kFacet,
                               {d * n + t_lo * t, (d + far) * n + t_lo * t,
                                (d + far) * n + t_hi * t, d * n + t_hi * t});
        r.wall_tag = FacetId(s, j);
        r.floor_tag = "OTHER";
        r.facet_normal = n;
        facets.push_back(add(std::move(r)));
      }
    }
    std::vector<int> strips;
    if (finished) {
      for (int k = 1; k <= p.facets_per_segment; ++k) {
        const double y = StripY(p, k);
        Region r = MakeRect(RegionKind::kStrip, -far, far,
                            y - p.strip_width_mm / 2, y + p.strip_width_mm / 2);
        r.wall_tag = "OTHER";
        r.floor_tag = StripId(k);
        r.cycle = CycleForIndex(p, k);
        strips.push_back(add(std::move(r)));
      }
      z_levels.push_back(p.strip_floor_z_mm);
    }
    const double mark_phi = p.mark_phi_deg * kDeg;
    const Eigen::Vector2d mu(std::cos(mark_phi), std::sin(mark_phi));
    const Eigen::Vector2d mv(-mu.y(), mu.x());
    const double mw = p.mark_width_mm / 2;
    Region mark_region = MakePolygon(
        RegionKind::kMark,
        {p.mark_r_start_mm * mu - mw * mv, p.mark_r_end_mm * mu - mw * mv,
         p.mark_r_end_mm * mu + mw * mv, p.mark_r_start_mm * mu + mw * mv});
    mark_region.wall_tag = mark_region.floor_tag = "MARK";
    const int mark = add(std::move(mark_region));

    z_levels.insert(z_levels.end(),
                    {p.small_notch_floor_z_mm, p.big_notch_floor_z_mm,
                     p.facet_bottom_z_mm, -p.mark_depth_mm});
    std::sort(z_levels.begin(), z_levels.end());
    z_levels.erase(
        std::unique(z_levels.begin(), z_levels.end(),
                    [](double a, double b) { return std::abs(a - b) < 1e-9; }),
        z_levels.end());
    for (size_t i = 0; i + 1 < z_levels.size(); ++i) {
      Band b{z_levels[i], z_levels[i + 1], -1, {}};
      const double z = (b.z_bottom + b.z_top) / 2;
      if (z > cylinders_top) {
        b.base = rim;
      } else {
        for (const auto& [index, c] : cylinders) {
          if (z > c->z_bottom_mm && z < c->z_top_mm) b.base = index;
        }
      }
      if (b.base < 0) {
        Bad("ref_cylinders",
            fmt::format("leave a gap at z = {:.3f} mm (no reference "
                        "cylinder and not above them)",
                        z));
      }
      if (z < bolt_top_z) {
        b.removals.insert(b.removals.end(), bolt_holes.begin(),
                          bolt_holes.end());
      }
      if (z > p.small_notch_floor_z_mm) b.removals.push_back(small_notch);
      if (z > p.big_notch_floor_z_mm) b.removals.push_back(big_notch);
      if (z > p.facet_bottom_z_mm) {
        b.removals.insert(b.removals.end(), facets.begin(), facets.end());
      }
      if (finished && z > p.strip_floor_z_mm) {
        b.removals.insert(b.removals.end(), strips.begin(), strips.end());
      }
      if (z > -p.mark_depth_mm) b.removals.push_back(mark);
      bands.push_back(b);
    }
  }

  // One triangulation holding every region boundary.
  // Point by point and segment by segment: CGAL's range insertion sorts
  // spatially with a shared random state, so the triangulation (and the
  // mesh) would depend on what ran before in the process.
  Cdt cdt;
  Cdt::Vertex_handle hint;
  for (const Region& r : regions) {
    std::vector<Cdt::Vertex_handle> corners;
    for (const Point2& point : r.polygon) {
      hint = cdt.insert(point, hint == Cdt::Vertex_handle() ? Cdt::Face_handle()
                                                            : hint->face());
      corners.push_back(hint);
    }
    for (size_t i = 0; i < corners.size(); ++i) {
      cdt.insert_constraint(corners[i], corners[(i + 1) % corners.size()]);
    }
  }
  // Canonical numbering (vertices by exact x then y, faces by their vertex
  // ids): the output must not depend on the triangulation's memory layout.
  std::vector<Cdt::Vertex_handle> cdt_vertices;
  for (auto v = cdt.finite_vertices_begin(); v != cdt.finite_vertices_end();
       ++v) {
    cdt_vertices.push_back(v);
  }
  std::sort(cdt_vertices.begin(), cdt_vertices.end(),
            [](Cdt::Vertex_handle a, Cdt::Vertex_handle b) {
              return CGAL::compare_xy(a->point(), b->point()) == CGAL::SMALLER;
            });
  std::vector<Eigen::Vector2d> vertex_xy;
  for (Cdt::Vertex_handle v : cdt_vertices) {
    v->info() = static_cast<int>(vertex_xy.size());
    // Round the exact value (a lazy number's approximation can differ in
    // the last bit depending on what was evaluated before).
    const auto exact = CGAL::exact(v->point());
    vertex_xy.emplace_back(CGAL::to_double(exact.x()),
                           CGAL::to_double(exact.y()));
  }
  const int region_count = static_cast<int>(regions.size());
  // Face corners as vertex ids, counter-clockwise, lowest id first.
  const auto corners = [](Cdt::Face_handle f) {
    std::array<int, 3> ids = {f->vertex(0)->info(), f->vertex(1)->info(),
                              f->vertex(2)->info()};
    std::rotate(ids.begin(), std::min_element(ids.begin(), ids.end()),
                ids.end());
    return ids;
  };
  std::vector<Cdt::Face_handle> faces;
  for (auto f = cdt.finite_faces_begin(); f != cdt.finite_faces_end(); ++f) {
    faces.push_back(f);
  }
  std::sort(faces.begin(), faces.end(),
            [&](Cdt::Face_handle a, Cdt::Face_handle b) {
              return corners(a) < corners(b);
            });
  for (size_t f = 0; f < faces.size(); ++f) faces[f]->info() = f;
  std::vector<char> inside(faces.size() * region_count);
  std::vector<char> in_band(faces.size() * bands.size());
  const int band_count = static_cast<int>(bands.size());
  for (size_t f = 0; f < faces.size(); ++f) {
    const Point2 c = CGAL::centroid(faces[f]->vertex(0)->point(),
                                    faces[f]->vertex(1)->point(),
                                    faces[f]->vertex(2)->point());
    const Eigen::Vector2d c_d(CGAL::to_double(c.x()), CGAL::to_double(c.y()));
    for (int r = 0; r < region_count; ++r) {
      inside[f * region_count + r] = Contains(regions[r], c, c_d);
    }
    for (int b = 0; b < band_count; ++b) {
      bool in = inside[f * region_count + bands[b].base];
      for (int r : bands[b].removals) {
        if (!in) break;
        if (inside[f * region_count + r]) in = false;
      }
      in_band[f * band_count + b] = in;
    }
  }
  const auto is_in = [&](int face, int band) {
    return face >= 0 && band >= 0 && band < band_count &&
           in_band[face * band_count + band];
  };

  PartMesh mesh;
  mesh.stage = stage;
  std::map<std::string, int> feature_index;
  const auto feature = [&](const std::string& id) {
    auto [it, added] =
        feature_index.emplace(id, static_cast<int>(mesh.feature_ids.size()));
    if (added) mesh.feature_ids.push_back(id);
    return it->second;
  };
  const int level_count = static_cast<int>(z_levels.size());
  std::unordered_map<long long, int> mesh_vertex;
  const auto vertex_id = [&](int id, int level) {
    const long long key = static_cast<long long>(id) * level_count + level;
    auto [it, added] =
        mesh_vertex.emplace(key, static_cast<int>(mesh.vertices.size()));
    if (added) {
      mesh.vertices.emplace_back(vertex_xy[id].x(), vertex_xy[id].y(),
                                 z_levels[level]);
    }
    return it->second;
  };
  const auto vertex = [&](Cdt::Vertex_handle v, int level) {
    return vertex_id(v->info(), level);
  };
  const auto emit = [&](int a, int b, int c, int tag) {
    mesh.triangles.push_back({a, b, c});
    mesh.triangle_feature.push_back(tag);
  };

  // Horizontal faces at each level, up where the band below is solid.
  for (int level = 0; level < level_count; ++level) {
    for (size_t f = 0; f < faces.size(); ++f) {
      const int face = static_cast<int>(f);
      const bool below = is_in(face, level - 1);
      const bool above = is_in(face, level);
      if (below == above) continue;
      std::string tag = "OTHER";
      if (below) {  // floor: what removed the band above
        if (level == band_count) {
          tag = "TOP";
        } else {
          const Band& band = bands[level];
          // Overlapping strips: the later cycle cut last.
          int best_cycle = -2;
          for (int r : band.removals) {
            const Region& region = regions[r];
            if (region.kind == RegionKind::kStrip &&
                inside[f * region_count + r] && region.cycle > best_cycle) {
              best_cycle = region.cycle;
              tag = region.floor_tag;
            }
          }
          if (best_cycle == -2) {
            bool found = false;
            for (RegionKind kind :
                 {RegionKind::kBigNotch, RegionKind::kSmallNotch,
                  RegionKind::kMark, RegionKind::kFacet}) {
              for (int r : band.removals) {
                if (!found && regions[r].kind == kind &&
                    inside[f * region_count + r]) {
                  tag = regions[r].floor_tag;
                  found = true;
                }
              }
            }
          }
        }
      } else {  // ceiling
        if (level == 0) {
          tag = "BOTTOM";
        } else {
          tag = "OTHER";
          for (int r : bands[level - 1].removals) {
            if (regions[r].kind == RegionKind::kBoltHole &&
                inside[f * region_count + r]) {
              tag = "BOLT_HOLE";
            }
          }
        }
      }
      const std::array<int, 3> ids = corners(faces[f]);
      const int a = vertex_id(ids[0], level);
      const int b = vertex_id(ids[1], level);
      const int c = vertex_id(ids[2], level);
      if (below) {
        emit(a, b, c, feature(tag));
      } else {
        emit(a, c, b, feature(tag));
      }
    }
  }

  // Walls: per band, across every edge whose two sides differ.
  std::vector<std::pair<std::array<int, 2>, Cdt::Edge>> edges;
  for (auto e = cdt.finite_edges_begin(); e != cdt.finite_edges_end(); ++e) {
    Cdt::Face_handle f = e->first;
    int k = e->second;
    // Seen from the finite face with the lower id: which side the iterator
    // reports depends on memory layout, and the side fixes the order in
    // which the wall's vertices are numbered.
    Cdt::Face_handle g = f->neighbor(k);
    if (cdt.is_infinite(f) || (!cdt.is_infinite(g) && g->info() < f->info())) {
      k = g->index(f);
      f = g;
    }
    const int a = f->vertex(Cdt::ccw(k))->info();
    const int b = f->vertex(Cdt::cw(k))->info();
    edges.push_back({{std::min(a, b), std::max(a, b)}, Cdt::Edge(f, k)});
  }
  std::sort(edges.begin(), edges.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  for (const auto& [key, edge] : edges) {
    Cdt::Face_handle f = edge.first;
    const int k = edge.second;
    Cdt::Face_handle g = f->neighbor(k);
    const int fi = f->info();
    const int gi = cdt.is_infinite(g) ? -1 : g->info();
    // f lies left of p -> q.
    Cdt::Vertex_handle p = f->vertex(Cdt::ccw(k));
    Cdt::Vertex_handle q = f->vertex(Cdt::cw(k));
    const Eigen::Vector2d edge_dir =
        (vertex_xy[q->info()] - vertex_xy[p->info()]).normalized();
    for (int b = 0; b < band_count; ++b) {
      const bool f_in = is_in(fi, b);
      const bool g_in = is_in(gi, b);
      if (f_in == g_in) continue;
      // Which region bounds the solid here: one containing the outer side,
      // or the base disc not containing it.
      const int outer = f_in ? gi : fi;
      // Outward normal of the wall.
      const Eigen::Vector2d normal =
          f_in ? Eigen::Vector2d(edge_dir.y(), -edge_dir.x())
               : Eigen::Vector2d(-edge_dir.y(), edge_dir.x());
      std::string tag = "OTHER";
      int best_rank = 100;
      const auto consider = [&](int r, int rank) {
        if (rank >= best_rank) return;
        const Region& region = regions[r];
        std::string t = region.wall_tag;
        if (region.kind == RegionKind::kFacet &&
            normal.dot(region.facet_normal) < 1 - 1e-9) {
          return;  // the end of a pass, not the facet plane
        }
        if (region.kind == RegionKind::kBigNotch) {
          t = std::abs(normal.y()) > 1 - 1e-9
                  ? (normal.y() < 0 ? "FLANK+Y" : "FLANK-Y")
                  : "OTHER";
        }
        best_rank = rank;
        tag = t;
      };
      const auto rank_of = [](RegionKind kind) {
        switch (kind) {
          case RegionKind::kFacet:
            return 0;
          case RegionKind::kBigNotch:
            return 1;
          case RegionKind::kSmallNotch:
            return 2;
          case RegionKind::kMark:
            return 3;
          case RegionKind::kBoltHole:
            return 4;
          case RegionKind::kStrip:
            return 5;
          case RegionKind::kBase:
            return 6;
        }
        return 7;
      };
      for (int r : bands[b].removals) {
        if (outer >= 0 && inside[outer * region_count + r]) {
          consider(r, rank_of(regions[r].kind));
        }
      }
      if (outer < 0 || !inside[outer * region_count + bands[b].base]) {
        consider(bands[b].base, rank_of(RegionKind::kBase));
      }
      const int p0 = vertex(p, b), q0 = vertex(q, b);
      const int p1 = vertex(p, b + 1), q1 = vertex(q, b + 1);
      const int t = feature(tag);
      if (f_in) {
        emit(p0, q0, q1, t);
        emit(p0, q1, p1, t);
      } else {
        emit(q0, p0, p1, t);
        emit(q0, p1, q1, t);
      }
    }
  }
  return mesh;
}

}  // namespace ttp
