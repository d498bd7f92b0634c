#include <fmt/format.h>

#include "ttp/geometry/features.h"
#include "ttp/plan/plan.h"

namespace ttp::plan {

std::string DialTemplateCsv(const PartSpec& part) {
  std::string out =
      "# Dial gauge readings (um). Facets: distance to the segment's "
      "reference\n"
      "# facet, positive towards the axis. Strips: depth relative to the\n"
      "# reference strip, positive downwards. Leave a reading empty-free:\n"
      "# delete rows you did not measure.\n"
      "feature,reading_um\n";
  for (int cycle = 1; cycle <= part.cycles(); ++cycle) {
    const int j = IndexForCycle(part, cycle);
    for (Segment s : {Segment::kX1, Segment::kX2, Segment::kY1, Segment::kY2})
      out += FacetId(s, j) + ",\n";
    out += StripId(j) + ",\n";
  }
  return out;
}

std::string DialSheetHtml(const PartSpec& part) {
  const int ref = part.reference_index;
  std::string rows;
  for (int cycle = 1; cycle <= part.cycles(); ++cycle) {
    const int j = IndexForCycle(part, cycle);
    for (Segment s : {Segment::kX1, Segment::kX2, Segment::kY1, Segment::kY2})
      rows += fmt::format(
          "<tr><td>{}</td><td>{}</td><td>{}</td><td>{:.0f}&deg;</td>"
          "<td>{}</td><td class=fill></td></tr>\n",
          cycle, FacetId(s, j), FacetId(s, ref), FacetPhiDeg(part, s, j),
          "gauge radial, table turned by C; + = towards the axis");
    rows += fmt::format(
        "<tr><td>{}</td><td>{}</td><td>{}</td><td>y = {:.2f} mm</td>"
        "<td>{}</td><td class=fill></td></tr>\n",
        cycle, StripId(j), StripId(ref), StripY(part, j),
        "gauge vertical on the strip at x = +20 mm; + = deeper");
  }
  return fmt::format(R"(<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<title>Thermal test piece: dial gauge sheet</title>
<style>
body {{ font-family: sans-serif; margin: 2em; }}
table {{ border-collapse: collapse; width: 100%; }}
td, th {{ border: 1px solid #444; padding: 4px 8px; }}
td.fill {{ width: 8em; }}
@media print {{ body {{ margin: 0.5cm; }} }}
</style></head><body>
<h1>Thermal test piece &mdash; dial gauge and micrometer sheet</h1>
<p>Gauge resolution 1 um or better. Facets: set the gauge to zero on the
segment's reference facet ({}-{}), then turn the table by C to the facet named
and read; the reading is positive when the facet is nearer the axis than the
reference. Strips: zero on strip Z{}, positive when the strip is deeper.
Type the readings into the CSV template (<code>feature,reading_um</code>) and
run <code>ttp inspect dial_readings.csv</code> (the file of <code>ttp plan
dial</code>, filled in).</p>
<table><tr><th>cycle</th><th>feature</th><th>zero on</th><th>where</th>
<th>how</th><th>reading (um)</th></tr>
{}</table></body></html>
)",
                     "S", ref, ref, rows);
}

}  // namespace ttp::plan
