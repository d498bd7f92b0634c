#include "ttp/inspect/dial.h"

#include <cmath>
#include <limits>
#include <map>

#include "ttp/geometry/csv.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/limits.h"

namespace ttp::inspect {

bool DialOptions::IsValid(std::string* error) const {
  const char* bad =
      !(resolution_um >= 0) || !std::isfinite(resolution_um) ? "resolution_um"
      : !(repeatability_um >= 0) || !std::isfinite(repeatability_um)
          ? "repeatability_um"
          : nullptr;
  if (bad && error)
    *error = std::string("DialOptions.") + bad +
             ": must be a finite value >= 0 in um";
  return bad == nullptr;
}

void DialOptions::Validate() const {
  std::string error;
  if (IsValid(&error)) return;
  // The field as the options are known (resolution_um, repeatability_um).
  const size_t dot = error.find('.'), colon = error.find(':');
  throw InputError("DialOptions", 0, error.substr(dot + 1, colon - dot - 1),
                   "must be >= 0");
}

FeatureResults ReadDialReadings(const std::string& csv_text,
                                const std::string& source, const PartSpec& part,
                                const DialOptions& options) {
  options.Validate();
  const CsvTable table = ParseCsv(csv_text, source);
  const int feature_col = table.Require("feature");
  const int reading_col = table.Require("reading_um");
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double var_reading_mm2 =
      (options.resolution_um * options.resolution_um / 12.0 +
       options.repeatability_um * options.repeatability_um) *
      1e-6;

  if (table.rows.empty())
    throw InputError(source, 0, "reading_um",
                     "no readings (the file holds its header only): not a "
                     "measurement");
  FeatureResults results;
  std::map<FeatureId, int> seen_on_line;
  const std::vector<NominalFeature> nominal = TestFeatures(part);
  std::map<FeatureId, const NominalFeature*> by_id;
  for (const NominalFeature& f : nominal) by_id[f.Key()] = &f;

  for (const CsvRow& row : table.rows) {
    const std::string& id = table.Text(row, feature_col);
    const std::optional<FeatureId> key = FeatureId::Parse(id);
    auto it = key ? by_id.find(*key) : by_id.end();
    if (it == by_id.end())
      throw InputError(source, row.line, "feature",
                       "'" + id + "' is not a facet or strip of the piece");
    if (auto [pos, fresh] = seen_on_line.emplace(*key, row.line); !fresh)
      throw InputError(source, row.line, "feature",
                       id + " is read twice (first on line " +
                           std::to_string(pos->second) + ")");
    const double reading_um = table.Number(row, reading_col);
    if (std::abs(reading_um) > limits::kMaxReadingUm)
      throw InputError(
          source, row.line, "reading_um",
          table.Text(row, reading_col) + " um is beyond the limit of " +
              std::to_string(static_cast<int>(limits::kMaxReadingUm)) +
              " um (a thermal deviation, not a size)");
    const NominalFeature& f = *it->second;
    const bool reference = f.index == part.reference_index;
    if (reference && reading_um != 0.0)
      throw InputError(
          source, row.line, "reading_um",
          id + " is the reference (zero) of its " +
              (f.kind == FeatureKind::kStrip ? "strips" : "segment") +
              "; its reading must be 0");
    FeatureResult r;
    r.present = true;
    r.points = 1;
    r.angle_rad = nan;  // a gauge reads distances only
    r.var_angle_rad2 = nan;
    if (f.kind == FeatureKind::kStrip) {
      r.d_mm = -part.strip_floor_z_mm + reading_um * 1e-3;
    } else {
      r.d_mm = f.size_mm - reading_um * 1e-3;
    }
    r.var_d_mm2 = reference ? 0.0 : var_reading_mm2;
    results[f.Key()] = r;
  }
  // The references are the zero of the readings: present even if not listed.
  for (const NominalFeature& f : nominal) {
    if (f.index != part.reference_index || results.count(f.Key())) continue;
    FeatureResult r;
    r.present = true;
    r.d_mm = f.kind == FeatureKind::kStrip ? -part.strip_floor_z_mm : f.size_mm;
    r.angle_rad = nan;
    r.var_angle_rad2 = nan;
    results[f.Key()] = r;
  }
  return results;
}

}  // namespace ttp::inspect
