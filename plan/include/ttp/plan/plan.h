// Measurement planning (measurements.md): where to touch the
// finished piece, for a CMM (point list + DMIS program), for on-machine
// probing (NC program, one linear axis per point) and for a dial gauge
// (printable sheet + CSV template).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "ttp/gcode/program.h"
#include "ttp/geometry/config.h"
#include "ttp/geometry/features.h"

namespace ttp::plan {

struct PlanOptions {
  int facet_columns = 3;          // across the facet (tangential)
  int facet_rows = 2;             // up the facet (z)
  int strip_points_per_side = 3;  // each side of the small notch
  int flank_points = 4;
  int top_points_per_segment = 3;
  int cylinder_points = 8;      // on the 199 datum circle
  double edge_margin_mm = 1.5;  // from every edge of a feature
  // Throws InputError("PlanOptions", 0, field, ...) naming the bad field.
  void Validate() const;
};

// One point to touch: nominal surface point and outward normal in W. The
// probe travels along -normal_w (the approach vector).
struct PlannedPoint {
  int id = 0;           // 1-based, in plan order
  FeatureId feature;    // a test feature or a datum (TOP, FLANK+-Y, CYL199)
  Eigen::Vector3d point_w_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal_w = Eigen::Vector3d::UnitZ();
};

// Datums first (TOP, FLANK+Y, FLANK-Y, CYL199), then strips and facets in
// feature order. Deterministic.
std::vector<PlannedPoint> PlanPoints(const PartSpec& part,
                                     const PlanOptions& options = {});

// CSV: point_id,feature,x_mm,y_mm,z_mm,approach_i,approach_j,approach_k
// (approach = direction of probe travel = -outward normal).
std::string PointsToCsv(const std::vector<PlannedPoint>& points);
// Reads a point list written by PointsToCsv (InputError on bad rows, and
// on a feature name that FeatureId::Parse does not know).
std::vector<PlannedPoint> PointsFromCsv(const std::string& text,
                                        const std::string& source);

// DMIS 5.x program measuring every feature with its planned points:
// WriteDmisProgram (plan/dmis_writer.h) with the default DmisOptions
// (FEAT/PLANE for planes, FEAT/CIRCLE for CYL199; PTMEAS with the outward
// normal as DMIS expects) and OUTPUT of the actual features, labels as
// ttp::inspect reads them back (X1_5, Z3, TOP, FLANK_PY, FLANK_NY, CYL199).
std::string PointsToDmis(const std::vector<PlannedPoint>& points,
                         const PartSpec& part);

// The on-machine probing program: ttp/plan/probe_program.h.

// Dial gauge: a printable HTML sheet (which facet or strip, where to set
// zero, which way the reading counts) and the CSV template to fill in
// (`feature,reading_um`, features of talc-log.md section 5).
std::string DialSheetHtml(const PartSpec& part);
std::string DialTemplateCsv(const PartSpec& part);

}  // namespace ttp::plan
