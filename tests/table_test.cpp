#include "skinspec/fit/table.hpp"

#include <gtest/gtest.h>

#include "support/data.hpp"

namespace skinspec {
namespace {

constexpr std::string_view kHeader =
    "# title: t\n# source: s\n# licence: l\n# units: u\n";

std::expected<Table, InputError> parse(std::string body) {
  return parse_table(std::string(kHeader) + body, "t.csv", {});
}

TEST(Table, ParsesMetadataColumnsAndRows) {
  constexpr std::string_view required[] = {"a"};
  const auto t = parse_table(std::string(kHeader) + "wavelength_nm,a\r\n400,1.5\r\n410,+2e-1\r\n", "t.csv", required);
  ASSERT_TRUE(t) << t.error().what();
  EXPECT_EQ(t->meta("source"), "s");
  EXPECT_EQ(t->rows(), 2u);
  EXPECT_DOUBLE_EQ(t->column("a")[1], 0.2);
}

TEST(Table, RefusesATableWithoutCitation) {
  const auto t = parse_table("# title: t\nwavelength_nm,a\n400,1\n", "t.csv", {});
  ASSERT_FALSE(t);
  EXPECT_NE(t.error().message.find("source"), std::string::npos);
}

TEST(Table, LocatesBadCells) {
  const auto t = parse("wavelength_nm,a\n400,1\n410,x\n");
  ASSERT_FALSE(t);
  EXPECT_EQ(t.error().line, 7u);
  EXPECT_EQ(t.error().column, 5u);
  EXPECT_EQ(t.error().what(), "t.csv:7:5: 'x' is not a number");
}

TEST(Table, RefusesRaggedRowsDuplicatesAndDisorder) {
  EXPECT_FALSE(parse("wavelength_nm,a\n400,1,2\n"));
  EXPECT_FALSE(parse("wavelength_nm,a,a\n400,1,2\n"));
  EXPECT_FALSE(parse("wavelength_nm,a\n400,1\n400,2\n"));
  EXPECT_FALSE(parse("wavelength_nm,a\n"));
  EXPECT_FALSE(parse(""));
  EXPECT_FALSE(parse("wavelength_nm,a\n400,nan\n"));
  constexpr std::string_view required[] = {"b"};
  EXPECT_FALSE(parse_table(std::string(kHeader) + "wavelength_nm,a\n400,1\n", "t.csv", required));
}

TEST(Table, EveryShippedTableLoads) {
  for (const char* name : {"optics/hemoglobin_prahl.csv", "optics/bilirubin_photochemcad.csv",
                           "optics/melanosome_jacques2013.csv", "optics/skin_baseline_jacques1998.csv",
                           "optics/scattering_salomatina.csv", "colour/cie1931_2deg_cmf.csv",
                           "colour/cie_illuminants.csv"}) {
    const auto t = parse_table(testing::data_file(name), name, {});
    EXPECT_TRUE(t) << (t ? "" : t.error().what());
  }
}

}  // namespace
}  // namespace skinspec
