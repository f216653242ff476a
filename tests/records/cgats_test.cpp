// CGATS spectral tables (records/cgats.hpp): what is read from the forms ArgyllCMS and other
// programs write, what is refused and where, and a session written out and read back.

#include "skinspec/records/cgats.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <sstream>

#include "skinspec/testkit/store_samples.hpp"

namespace skinspec::records {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

// As ArgyllCMS's spotread or chartread write a .ti3: comments, keywords, extra fields.
constexpr std::string_view kArgyllTi3 = R"(CTI3   

DESCRIPTOR "Argyll Calibration Target chart information 3"
ORIGINATOR "Argyll chartread"
CREATED "Tue Dec  1 10:00:00 2026"
KEYWORD "DEVICE_CLASS"
DEVICE_CLASS "OUTPUT"
KEYWORD "SPECTRAL_BANDS"
SPECTRAL_BANDS "4"
SPECTRAL_START_NM "400.000000"
SPECTRAL_END_NM "700.000000"
SPECTRAL_NORM "100.000000"
# a comment line

NUMBER_OF_FIELDS 8
BEGIN_DATA_FORMAT
SAMPLE_ID SAMPLE_LOC XYZ_X XYZ_Y XYZ_Z SPEC_400 SPEC_500
SPEC_600 
END_DATA_FORMAT

NUMBER_OF_SETS 2
BEGIN_DATA
1 "A1" 10.5 11.0 9.2 20.0 40.0 60.0
2 "A2" 5.0 6.0 7.0 10 20 30   # trailing comment
END_DATA
)";

TEST(CgatsTest, ReadsTheSpectraOfAnArgyllTable) {
  // SPEC_700 is missing above; add it to make the table whole.
  std::string text(kArgyllTi3);
  text.replace(text.find("SPEC_600 "), 9, "SPEC_600 SPEC_700");
  text.replace(text.find("NUMBER_OF_FIELDS 8"), 18, "NUMBER_OF_FIELDS 9");
  text.replace(text.find("60.0\n"), 5, "60.0 80.0\n");
  text.replace(text.find("30   #"), 6, "30 35 #");
  const auto spectra = parse_cgats(text);
  ASSERT_TRUE(spectra) << spectra.error().line << ": " << spectra.error().message;
  ASSERT_EQ(spectra->size(), 2u);
  const auto& first = (*spectra)[0];
  EXPECT_EQ(first.sample_id, "1");
  EXPECT_EQ(first.line, 23u);
  EXPECT_THAT(first.wavelength_nm, ElementsAre(400, 500, 600, 700));
  EXPECT_THAT(first.reflectance, ElementsAre(0.2, 0.4, 0.6, 0.8));
  EXPECT_EQ(first.fields[1], (std::pair<std::string, std::string>{"SAMPLE_LOC", "A1"}));
  EXPECT_THAT((*spectra)[1].reflectance, ElementsAre(0.1, 0.2, 0.3, 0.35));
  EXPECT_EQ((*spectra)[1].line, 24u);
}

TEST(CgatsTest, AMissingBandIsAnErrorAtTheFormat) {
  const auto read = parse_cgats(kArgyllTi3);
  ASSERT_FALSE(read);
  EXPECT_EQ(read.error().line, 16u);
  EXPECT_THAT(read.error().message, HasSubstr("SPEC_700"));
}

std::string spectral_table(std::string_view sets, std::string_view extra_keywords = "") {
  return "CGATS.17\n" + std::string(extra_keywords) +
         "SPECTRAL_BANDS 3\nSPECTRAL_START_NM 400\nSPECTRAL_END_NM 600\n"
         "BEGIN_DATA_FORMAT\nSAMPLE_NAME SPEC_400 SPEC_500 SPEC_600\nEND_DATA_FORMAT\n"
         "BEGIN_DATA\n" +
         std::string(sets) + "END_DATA\n";
}

TEST(CgatsTest, WithoutANormTheValuesAreTakenAsTheyAreAndTheNameIsTheId) {
  const auto read = parse_cgats(spectral_table("\"left cheek\" 0.25 0.5 0.75\n"));
  ASSERT_TRUE(read) << read.error().message;
  ASSERT_EQ(read->size(), 1u);
  EXPECT_EQ((*read)[0].sample_id, "left cheek");
  EXPECT_THAT((*read)[0].reflectance, ElementsAre(0.25, 0.5, 0.75));
}

TEST(CgatsTest, ABadValueIsAnErrorAtItsLineNamingTheField) {
  const auto read = parse_cgats(spectral_table("a 0.1 0.2 0.3\nb 0.1 x 0.3\n"));
  ASSERT_FALSE(read);
  EXPECT_EQ(read.error().line, 10u);
  EXPECT_THAT(read.error().message, HasSubstr("SPEC_500"));
  EXPECT_THAT(read.error().message, HasSubstr("'x'"));
}

TEST(CgatsTest, ASetWithTooFewValuesIsAnErrorAtItsLine) {
  const auto read = parse_cgats(spectral_table("a 0.1 0.2 0.3\nb 0.1 0.2\n"));
  ASSERT_FALSE(read);
  EXPECT_EQ(read.error().line, 10u);
  EXPECT_THAT(read.error().message, HasSubstr("3 values where the format names 4 fields"));
}

TEST(CgatsTest, CountsThatDisagreeWithTheTableAreErrors) {
  const auto sets = parse_cgats(spectral_table("a 0.1 0.2 0.3\n", "NUMBER_OF_SETS 2\n"));
  ASSERT_FALSE(sets);
  EXPECT_EQ(sets.error().line, 2u);
  EXPECT_THAT(sets.error().message, HasSubstr("NUMBER_OF_SETS is 2 but the data holds 1"));
  const auto fields = parse_cgats(spectral_table("a 0.1 0.2 0.3\n", "NUMBER_OF_FIELDS 5\n"));
  ASSERT_FALSE(fields);
  EXPECT_THAT(fields.error().message, HasSubstr("NUMBER_OF_FIELDS is 5 but 4 fields are named"));
}

TEST(CgatsTest, BrokenStructureIsRefusedWithWhere) {
  struct Case {
    std::string text;
    std::size_t line;
    std::string says;
  };
  const std::vector<Case> cases = {
      {"", 0, "empty"},
      {"CTI3\nDESCRIPTOR \"open\n", 2, "not closed"},
      {"CTI3\nBEGIN_DATA_FORMAT\nSAMPLE_ID\n", 2, "no END_DATA_FORMAT"},
      {"CTI3\nBEGIN_DATA\n1\nEND_DATA\n", 2, "BEGIN_DATA before BEGIN_DATA_FORMAT"},
      {"CTI3\nBEGIN_DATA_FORMAT\nSAMPLE_ID\nEND_DATA_FORMAT\nBEGIN_DATA\n1\n", 5, "no END_DATA"},
      {"CTI3\nNUMBER_OF_SETS many\n", 2, "whole number"},
      {"CTI3\nDESCRIPTOR \"x\"\n", 1, "no BEGIN_DATA"},
      {spectral_table("a 1 2 3\n", "SPECTRAL_NORM 0\n"), 2, "SPECTRAL_NORM must be above 0"},
  };
  for (const auto& c : cases) {
    const auto read = parse_cgats(c.text);
    ASSERT_FALSE(read) << c.text;
    EXPECT_EQ(read.error().line, c.line) << c.text;
    EXPECT_THAT(read.error().message, HasSubstr(c.says)) << c.text;
  }
  std::string no_start = spectral_table("a 1 2 3\n");
  no_start.erase(no_start.find("SPECTRAL_START_NM 400\n"), 22);
  const auto read = parse_cgats(no_start);
  ASSERT_FALSE(read);
  EXPECT_THAT(read.error().message, HasSubstr("no SPECTRAL_START_NM"));
}

TEST(CgatsTest, TablesWithoutSpectraAreSkippedAndEveryOtherTableIsRead) {
  const std::string text = "CTI3\nBEGIN_DATA_FORMAT\nSAMPLE_ID RGB_R\nEND_DATA_FORMAT\nBEGIN_DATA\n1 0.5\nEND_DATA\n" +
                           spectral_table("a 0.1 0.2 0.3\n") + spectral_table("b 0.4 0.5 0.6 ");
  const auto read = parse_cgats(text);
  ASSERT_TRUE(read) << read.error().message;
  ASSERT_EQ(read->size(), 2u);
  EXPECT_EQ((*read)[0].sample_id, "a");
  EXPECT_EQ((*read)[1].sample_id, "b");
}

store::SessionDetail sample_detail() {
  store::SessionDetail detail;
  detail.session = testing::sample_session(1);
  detail.session.id = 7;
  for (int n = 0; n < 3; ++n) {
    auto m = testing::sample_measurement(7, n);
    m.id = 10 + n;
    detail.measurements.push_back(m);
  }
  detail.measurements[0].kind = store::MeasurementKind::white;
  detail.measurements[0].reflectance = {};  // a white has no reflectance of its own
  detail.measurements[2].label = "say \"cheek\"";
  return detail;
}

TEST(CgatsTest, ASessionWrittenOutReadsBackAsItsReflectances) {
  const auto detail = sample_detail();
  std::ostringstream out;
  ASSERT_TRUE(write_cgats(detail, out));
  const auto read = parse_cgats(out.str());
  ASSERT_TRUE(read) << read.error().line << ": " << read.error().message << "\n" << out.str();
  ASSERT_EQ(read->size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    const auto& stored = detail.measurements[i + 1];
    EXPECT_EQ((*read)[i].sample_id, std::to_string(stored.id));
    EXPECT_EQ((*read)[i].wavelength_nm, stored.reflectance.wavelength_nm);
    ASSERT_EQ((*read)[i].reflectance.size(), stored.reflectance.values.size());
    for (std::size_t k = 0; k < stored.reflectance.values.size(); ++k)
      EXPECT_NEAR((*read)[i].reflectance[k], stored.reflectance.values[k], 1e-15);
  }
  EXPECT_EQ((*read)[1].sample_name, "say 'cheek'");
}

TEST(CgatsTest, AGridCgatsCannotNameIsRefusedNamingTheMeasurement) {
  auto detail = sample_detail();
  detail.measurements[2].reflectance.wavelength_nm[3] += 0.5;
  std::ostringstream out;
  const auto written = write_cgats(detail, out);
  ASSERT_FALSE(written);
  EXPECT_THAT(written.error(), HasSubstr("measurement 12"));
  EXPECT_THAT(written.error(), HasSubstr("not evenly spaced"));
}

TEST(CgatsTest, MeasurementsOnTwoGridsAreTwoTables) {
  auto detail = sample_detail();
  auto& other = detail.measurements[2].reflectance;
  other.wavelength_nm.resize(31);
  other.values.resize(31);
  for (std::size_t i = 0; i < 31; ++i) other.wavelength_nm[i] = 400 + 10.0 * static_cast<double>(i);
  std::ostringstream out;
  ASSERT_TRUE(write_cgats(detail, out));
  const auto read = parse_cgats(out.str());
  ASSERT_TRUE(read) << read.error().message;
  ASSERT_EQ(read->size(), 2u);
  EXPECT_EQ((*read)[1].wavelength_nm.size(), 31u);
  EXPECT_EQ((*read)[1].wavelength_nm.back(), 700);
}

}  // namespace
}  // namespace skinspec::records
