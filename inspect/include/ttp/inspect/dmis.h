// DMIS files. Output files (DMIS 3.0-5.x, the subset a CMM writes for
// feature results): `UNITS/` (MM, CM, METER, INCH, FEET; ANGDEC, ANGRAD)
// and actual features `FA(label) = FEAT/PLANE|CIRCLE|POINT|CYLNDR|SPHERE,
// ..., CART, ...`. Programs: every statement read into major word, label
// and arguments and checked against a table of DMIS 5 statements and their
// argument forms, the order of labels (a datum measured before it is
// used), and, for a program of this piece, the point patterns and the
// probe's path against the part's solid. `$` continues a statement on the
// next line, `$$` starts a comment.
#pragma once

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "ttp/geometry/config.h"
#include "ttp/geometry/figures.h"
#include "ttp/geometry/part_mesh.h"

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

// DMIS labels of features: DmisLabel / FeatureIdForDmisLabel
// (ttp/geometry/features.h).

struct DmisImport {
  FeatureResults results;
  bool aligned_from_datums = false;  // false: reported frame taken as W
  std::vector<std::string> warnings;
};

// Facet and strip planes -> per-feature results. If the datums TOP (plane),
// FLANK+Y and FLANK-Y (planes) and CYL199 (circle or cylinder) are among the
// results, W is built from them as test-piece.md section 5 says; the
// mark decides the half-turn when the points MARK (in the engraved line)
// and MARK_OPP (the same place turned by 180 deg) are reported: the stylus
// ball sinks into the groove, so MARK must lie at least 5 um below
// MARK_OPP. Reported the other way round the piece was aligned turned by
// 180 deg (X1 measured as X2...): refused; no depth either way: a warning
// (without the two points the half-turn is the CMM program's alignment).
// Without all four datums the
// reported frame is taken as W and a warning says so.
//
// A DMIS result carries no touch count, so a plane's variance comes from
// the CMM's MPE and the touches the CMM program took (DmisImportOptions).
struct DmisImportOptions {
  // MPE = a + L / b (L = the feature's distance from W's origin, mm) bounds
  // each touch; as a uniform bound its standard uncertainty is MPE/sqrt(3)
  // (thesis 7.3: a = 1.2 um, b = 400 mm).
  double cmm_mpe_um = 1.2;
  double cmm_mpe_l_mm = 400.0;
  // The touches of each plane: the point list of the program that measured
  // the piece (`ttp plan cmm` writes it as cmm_points.csv); empty: the
  // program `ttp plan cmm` writes with its default options.
  std::string points_csv_path;
  // A program of one's own: this many touches per plane (at least 3), in
  // the pattern of `ttp plan cmm`'s program (its covariance times
  // planned / n); 0: the point list's touches.
  int touches_per_plane = 0;
  // Ceres style: false with "DmisImportOptions.<field>: <problem>".
  bool IsValid(std::string* error) const;
  void Validate() const;  // InputError naming the command-line option
};

// Planes are fitted by least squares through independent touches of
// standard uncertainty u, and read as test-piece.md section 4 says: a
// facet's d is the plane's distance to W's origin (n . p), so the plane's
// tilt counts in it through the touches' height; its angle is the normal's
// turn about Z; a strip's depth is taken at (0, y_k), its angle along X.
// A feature without three planned touches off one line counts as one touch
// (or touches_per_plane) for the distance and two at its ends for the
// angle.
DmisImport DmisToFeatureResults(const DmisResults& dmis, const PartSpec& part,
                                const DmisImportOptions& options = {});

// ------------------------------------------------------------ programs

// One statement: `F(TOP) = FEAT/PLANE,CART,...` has label_type "F", label
// "TOP", major "FEAT", args {"PLANE", "CART", ...}. Words are upper case
// except quoted strings, which keep their quotes.
struct DmisStatement {
  int line = 0;            // where it starts
  std::string label_type;  // left of '=', empty when none
  std::string label;
  std::string major;  // before '/'
  std::vector<std::string> args;
};

struct DmisProgram {
  std::string source;
  std::vector<DmisStatement> statements;
  // DMIS limits a line to 80 characters and a statement to 256 (its
  // continuation lines joined): the ones beyond, by their first line.
  std::vector<int> long_lines;
  std::vector<int> long_statements;
};

// Splits a DMIS file into statements (joins `$` continuations, drops
// comments). InputError for a statement without a major word or with an
// unclosed quote or parenthesis, naming the line.
DmisProgram ParseDmisProgram(const std::string& text,
                             const std::string& source);

// The major words of the statement table (DMIS 5 forms), sorted.
std::vector<std::string> DmisKnownStatements();

struct DmisFinding {
  int line = 0;
  std::string check;    // which check: "statement", "labels", "path", ...
  std::string problem;  // what is wrong, with the numbers
};

// Standard checks, for any DMIS program or output file: lines of at most
// 80 characters, statements of at most 256; every statement is
// in the table with one of its argument forms and the label its form
// needs; DMISMN (program) or FILNAM (output) first and ENDFIL last;
// MEAS ... ENDMES blocks hold their declared number of PTMEAS; every label
// is defined before it is used (a feature measured or constructed before
// DATDEF, CONST, TRANS or OUTPUT use it, a datum defined before DATSET, a
// sensor before SNSLCT, a device before OPEN).
std::vector<DmisFinding> CheckDmisStandard(const DmisProgram& program);

struct DmisPathOptions {
  // Required distance of the stylus ball from the solid beyond its radius
  // on every move that is not a probing move.
  double margin_mm = 0.5;
  // The stylus shaft (vertical, above the ball) is checked on the travel
  // moves up to this length with this diameter (on a probing move it
  // follows the ball along the surface normal; the ball is checked).
  double shaft_length_mm = 30.0;
  double shaft_diameter_mm = 1.5;
  // Smallest spread of a plane's points in its second direction and of a
  // circle's points in angle.
  double min_plane_span_mm = 2.0;
  double min_circle_span_deg = 180.0;
  // false: the path is not traced against the piece (the other run checks
  // only; the path check then passes with no moves counted).
  bool check_path = true;
  // Ceres style: false with "DmisPathOptions.<field>: <problem>".
  bool IsValid(std::string* error) const;
};

struct DmisRunCheck {
  std::string name;
  bool passed = true;
  std::vector<DmisFinding> findings;
};

struct DmisProgramCheck {
  std::vector<DmisRunCheck> checks;  // in a fixed order
  int moves = 0;                     // straight moves checked
  int probe_points = 0;              // automatic PTMEAS
  double min_clearance_mm = 0;       // smallest ball clearance of a move
  std::string min_clearance_where;   // "line N"
  double path_length_mm = 0;
  bool Passed() const;
};

// Whether a program of this piece can run on a CMM: the standard checks,
// a sensor defined and selected before the first measurement; feeds and
// approach/retract distances set before the first automatic measurement;
// the part aligned from measured datums (DATSET from DATDEF) before any
// automatic move; every MEAS pattern non-degenerate (plane points spanning
// two directions, circle points spanning an angle); and every straight
// move of the stylus ball (GOTO, the approach to each PTMEAS along its
// vector at the SNSET distances, the retract) plus its shaft clear of the
// finished piece (`finished`: BuildPartMesh(part, kFinished)) and the
// adapter, coordinates after an alignment being W. Moves made in
// MODE/MAN are the operator's; after them the first automatic move must
// be a GOTO above the piece.
DmisProgramCheck CheckDmisProgram(const DmisProgram& program,
                                  const PartSpec& part,
                                  const PartMesh& finished,
                                  const DmisPathOptions& options = {});

nlohmann::json DmisProgramCheckToJson(const DmisProgramCheck& check);

}  // namespace ttp::inspect
