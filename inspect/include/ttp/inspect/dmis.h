// DMIS output files (DMIS 3.0-5.x, the subset a CMM writes for feature
// results): `UNITS/` (MM, CM, METER, INCH, FEET; ANGDEC, ANGRAD) and actual
// features `FA(label) = FEAT/PLANE|CIRCLE|POINT|CYLNDR|SPHERE, ..., CART,
// ...`. `$` continues a statement on the next line, `$$` starts a comment.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "ttp/geometry/config.h"
#include "ttp/geometry/figures.h"

namespace ttp::inspect {

struct DmisFeature {
  std::string label;  // the text inside FA(...)
  std::string type;   // PLANE, CIRCLE, POINT, CYLNDR, SPHERE
  Eigen::Vector3d point_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();  // normal or axis
  double diameter_mm = 0;  // circles, cylinders, spheres
  int line = 0;            // where the statement starts
};

struct DmisResults {
  std::string source;
  std::vector<DmisFeature> features;  // in millimetres
};

// Parses the actual features; InputError names file, line and the word for
// unknown units, polar (POL) coordinates, missing or non-numeric values.
DmisResults ParseDmisOutput(const std::string& text, const std::string& source);

// The test feature id a DMIS label stands for: "X1-5", "X1_5", "x1_5" ->
// "X1-5"; "Z3", "STRIP_3" -> "Z3"; datums "TOP", "FLANK_PY"/"FLANK+Y",
// "FLANK_NY"/"FLANK-Y", "CYL199". Empty if the label is none of them.
std::string TestFeatureIdForDmisLabel(const std::string& label);

struct DmisImport {
  FeatureResults results;
  bool aligned_from_datums = false;  // false: reported frame taken as W
  std::vector<std::string> warnings;
};

// Facet and strip planes -> per-feature results. If the datums TOP (plane),
// FLANK+Y and FLANK-Y (planes) and CYL199 (circle or cylinder) are among the
// results, W is built from them as test-piece.md section 5 says (the mark's
// half-turn ambiguity is left to the CMM program's alignment); otherwise the
// reported frame is taken as W and a warning says so. Variances come from
// the CMM's MPE (1.2 um + L/400, thesis 7.3) taken as a uniform bound over
// the feature's extent.
DmisImport DmisToFeatureResults(const DmisResults& dmis, const PartSpec& part);

}  // namespace ttp::inspect
