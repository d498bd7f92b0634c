#include <gtest/gtest.h>

#include "ttp/geometry/features.h"
#include "ttp/plan/plan.h"

namespace ttp::plan {
namespace {

TEST(DialSheetTest, TemplateAndSheetListEveryNonReferenceFeature) {
  const PartSpec part;
  const std::string csv = DialTemplateCsv(part);
  const std::string html = DialSheetHtml(part);
  int rows = 0;
  for (const NominalFeature& f : TestFeatures(part)) {
    const bool ref = f.index == part.reference_index;
    const bool in_csv = csv.find("\n" + f.id + ",\n") != std::string::npos;
    EXPECT_EQ(in_csv, !ref) << f.id;
    if (!ref) {
      ++rows;
      EXPECT_NE(html.find("<td>" + f.id + "</td>"), std::string::npos) << f.id;
    }
  }
  EXPECT_EQ(rows, 40);
  EXPECT_NE(csv.find("feature,reading_um\n"), std::string::npos);
  EXPECT_EQ(html.find("http"), std::string::npos) << "must print offline";
}

}  // namespace
}  // namespace ttp::plan
