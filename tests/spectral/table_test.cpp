#include "skinspec/spectral/table.hpp"

#include <gtest/gtest.h>

#include "support/data.hpp"

namespace skinspec {
namespace {

constexpr std::string_view kHeader = "# title: t\n# source: s\n# licence: l\n# units: u\n";

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
  for (const char* name :
       {"optics/hemoglobin_prahl.csv", "optics/bilirubin_photochemcad.csv", "optics/melanosome_jacques2013.csv",
        "optics/skin_baseline_jacques1998.csv", "optics/scattering_salomatina.csv", "colour/cie1931_2deg_cmf.csv",
        "colour/cie_illuminants.csv"}) {
    const auto t = parse_table(testing::data_file(name), name, {});
    EXPECT_TRUE(t) << (t ? "" : t.error().what());
  }
}

}  // namespace
}  // namespace skinspec

namespace skinspec {
namespace {

TEST(TableUtf8, RefusesBytesThatAreNotUtf8InMetadataHeaderAndCells) {
  struct Case {
    const char* label;
    std::string bytes;
    std::size_t line, column;
    const char* shown;
  };
  const Case cases[] = {
      {"metadata", "# title: t\n# source: Jacques \xe9t al.\n# licence: l\n# units: u\nwavelength_nm,a\n400,1\n", 2, 19,
       "\\xe9"},
      {"header", std::string(kHeader) + "wavelength_nm,\xc0\xae\n400,1\n", 5, 15, "\\xc0\\xae"},
      {"key", std::string(kHeader) + "site,a\nforearm\xed\xb0\x80,1\n", 6, 8, "\\xed\\xb0\\x80"},
      {"cell", std::string(kHeader) + "wavelength_nm,a\n400,1\n410,\xff\n", 7, 5, "\\xff"},
  };
  for (const auto& [label, bytes, line, column, shown] : cases) {
    SCOPED_TRACE(label);
    const auto t = parse_table(bytes, "t.csv", {});
    ASSERT_FALSE(t);
    EXPECT_EQ(t.error().line, line);
    EXPECT_EQ(t.error().column, column);
    EXPECT_NE(t.error().message.find(std::string(shown) + " is not UTF-8 text"), std::string::npos) << t.error().what();
  }
}

TEST(TableUtf8, QuotesKeysAndColumnsPrintably) {
  const auto t = parse(
      "site,a\nfore\x1b"
      "arm,1\nfore\x1b"
      "arm,2\n");
  ASSERT_FALSE(t);
  EXPECT_EQ(t.error().what(), "t.csv:7:1: duplicated key 'fore\\x1barm'");
}

}  // namespace
}  // namespace skinspec
