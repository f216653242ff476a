#include "skinspec/spectral/spectra_csv.hpp"
#include "skinspec/spectral/utf8.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace skinspec {
namespace {

using ::testing::HasSubstr;

// A file in the documented format: three spectra on a grid that covers 400-700 nm.
constexpr std::string_view kThreeSubjects =
    "wavelength_nm, subject_1 ,subject_2,subject_3\n"
    "400,0.30,0.25,0.20\n"
    "550, 0.45 ,+4e-1,0.35\n"
    "700,0.60,0.55,0.50\n";

std::expected<std::vector<NamedSpectrum>, InputError> parse(std::string_view bytes, const SpectraLimits& limits = {}) {
  return parse_spectra_csv(bytes, "data.csv", limits);
}

// The error a refused input gives; fails the test when the input is accepted.
InputError error_of(std::string_view bytes, const SpectraLimits& limits = {}) {
  const auto result = parse(bytes, limits);
  if (result) {
    ADD_FAILURE() << "accepted:\n" << bytes;
    return {};
  }
  return result.error();
}

TEST(SpectraCsv, ParsesNamesAndValuesOfEveryColumn) {
  const auto spectra = parse(kThreeSubjects);
  ASSERT_TRUE(spectra) << spectra.error().what();
  ASSERT_EQ(spectra->size(), 3u);
  EXPECT_EQ((*spectra)[0].name, "subject_1");
  EXPECT_EQ((*spectra)[1].name, "subject_2");
  EXPECT_EQ((*spectra)[2].name, "subject_3");
  for (const auto& named : *spectra) {
    ASSERT_EQ(named.spectrum.size(), 3u);
    EXPECT_DOUBLE_EQ(named.spectrum.wavelengths()[1], 550.0);
  }
  EXPECT_DOUBLE_EQ((*spectra)[0].spectrum.values()[1], 0.45);
  EXPECT_DOUBLE_EQ((*spectra)[1].spectrum.values()[1], 0.4);
  EXPECT_DOUBLE_EQ((*spectra)[2].spectrum.values()[2], 0.5);
}

TEST(SpectraCsv, AcceptsByteOrderMarkAndCrlf) {
  const auto spectra = parse("\xEF\xBB\xBFwavelength_nm,a\r\n400,0.1\r\n700,0.2\r\n");
  ASSERT_TRUE(spectra) << spectra.error().what();
  ASSERT_EQ(spectra->size(), 1u);
  EXPECT_EQ((*spectra)[0].name, "a");
  EXPECT_DOUBLE_EQ((*spectra)[0].spectrum.values()[1], 0.2);
}

TEST(SpectraCsv, AcceptsCrLineEndsAndBlankLinesAnywhere) {
  const auto spectra = parse("\r\nwavelength_nm,a\r\r400,0.1\r \t\r700,0.2\r\n\n  \n");
  ASSERT_TRUE(spectra) << spectra.error().what();
  EXPECT_EQ((*spectra)[0].spectrum.size(), 2u);
}

// Spreadsheets quote a name holding a comma; an open quote is refused at the line it opens on.
TEST(SpectraCsv, ReadsQuotedFieldsAndRefusesAnOpenQuote) {
  const auto spectra = parse("wavelength_nm,\"cheek, left\"\n\"400\",0.1\n700,0.2\n");
  ASSERT_TRUE(spectra) << spectra.error().what();
  EXPECT_EQ((*spectra)[0].name, "cheek, left");
  const auto open = error_of("wavelength_nm,a\n400,0.1\n700,\"0.2\n");
  EXPECT_EQ(open.source, "data.csv");
  EXPECT_EQ(open.line, 3u);
  EXPECT_THAT(open.message, HasSubstr("not closed"));
  // A name over two lines: a byte that is not UTF-8 on the second is named on that line.
  const auto defect = error_of("wavelength_nm,\"a\nb\xff\"\n400,0.1\n700,0.2\n");
  EXPECT_EQ(defect.line, 2u);
  EXPECT_EQ(defect.column, 2u);
}

TEST(SpectraCsv, LeavesTheWavelengthRangeToTheCaller) {
  const auto spectra = parse("wavelength_nm,a\n300,0.1\n900,0.2\n");
  ASSERT_TRUE(spectra) << spectra.error().what();
  EXPECT_DOUBLE_EQ((*spectra)[0].spectrum.first_nm(), 300.0);
  EXPECT_DOUBLE_EQ((*spectra)[0].spectrum.last_nm(), 900.0);
}

TEST(SpectraCsv, RefusesEmptyInput) {
  const auto empty = error_of("");
  EXPECT_EQ(empty.line, 1u);
  EXPECT_THAT(empty.message, HasSubstr("empty"));
  const auto byte_order_mark_only = error_of("\xEF\xBB\xBF");
  EXPECT_THAT(byte_order_mark_only.message, HasSubstr("empty"));
  const auto blank = error_of("\n \t\r\n\n");
  EXPECT_EQ(blank.line, 1u);
  EXPECT_THAT(blank.message, HasSubstr("only blank or comment lines"));
}

TEST(SpectraCsv, SaysTheHeaderIsMissingWhenTheFirstLineHoldsNumbers) {
  const auto e = error_of("\n\n400,0.1\n700,0.2\n");
  EXPECT_EQ(e.line, 3u);
  EXPECT_EQ(e.column, 1u);
  EXPECT_THAT(e.message, HasSubstr("header is missing"));
  EXPECT_THAT(e.message, HasSubstr("400"));
}

TEST(SpectraCsv, RefusesAFirstColumnOtherThanWavelength) {
  const auto e = error_of("wavelength,a\n400,0.1\n700,0.2\n");
  EXPECT_EQ(e.what(), "data.csv:1:1: the first column is named 'wavelength'; it must be 'wavelength_nm'");
  // The byte order mark is not counted as a character of the line.
  const auto with_mark = error_of("\xEF\xBB\xBFnm,a\n400,0.1\n700,0.2\n");
  EXPECT_EQ(with_mark.line, 1u);
  EXPECT_EQ(with_mark.column, 1u);
  EXPECT_THAT(with_mark.message, HasSubstr("'nm'"));
}

TEST(SpectraCsv, RefusesEmptyColumnNames) {
  const auto e = error_of("wavelength_nm,a,,b\n400,0.1,0.1,0.1\n700,0.2,0.2,0.2\n");
  EXPECT_EQ(e.line, 1u);
  EXPECT_EQ(e.column, 17u);
  EXPECT_THAT(e.message, HasSubstr("column 3 has an empty name"));
  const auto trailing_comma = error_of("wavelength_nm,a, \n400,0.1,0.1\n700,0.2,0.2\n");
  EXPECT_EQ(trailing_comma.column, 17u);
}

TEST(SpectraCsv, RefusesDuplicatedColumnNames) {
  const auto e = error_of("wavelength_nm,a,b,a\n400,0.1,0.1,0.1\n700,0.2,0.2,0.2\n");
  EXPECT_EQ(e.line, 1u);
  EXPECT_EQ(e.column, 19u);
  EXPECT_THAT(e.message, HasSubstr("duplicated column name 'a' (also column 2)"));
  const auto second_wavelength = error_of("wavelength_nm,wavelength_nm\n400,400\n700,700\n");
  EXPECT_EQ(second_wavelength.column, 15u);
}

TEST(SpectraCsv, RefusesAHeaderWithoutSpectra) {
  const auto e = error_of("wavelength_nm\n400\n700\n");
  EXPECT_EQ(e.line, 1u);
  EXPECT_EQ(e.column, 0u);
  EXPECT_THAT(e.message, HasSubstr("no spectrum"));
}

TEST(SpectraCsv, RefusesRowsWithTooManyCells) {
  const auto e = error_of("wavelength_nm,a\n400,0.1\n550,0.2,0.3\n700,0.3\n");
  EXPECT_EQ(e.line, 3u);
  EXPECT_EQ(e.column, 9u);  // the first cell the header has no name for
  EXPECT_THAT(e.message, HasSubstr("3 cells where the header has 2"));
}

TEST(SpectraCsv, RefusesRowsWithTooFewCells) {
  const auto e = error_of("wavelength_nm,a,b\n400,0.1,0.1\n\n550,0.2\n700,0.3,0.3\n");
  EXPECT_EQ(e.line, 4u);
  EXPECT_EQ(e.column, 0u);
  EXPECT_THAT(e.message, HasSubstr("2 cells where the header has 3"));
  EXPECT_THAT(e.message, HasSubstr("'b'"));
}

TEST(SpectraCsv, LocatesCellsThatAreNotNumbers) {
  const auto e = error_of(
      "wavelength_nm,subject_1,subject_2,subject_3\n"
      "400,0.4,0.3,0.2\n"
      "500,0.4,0.3,0.2\n"
      "600,0.4,0.3,0.2\n"
      "700,0.4,0.3,abc\n");
  EXPECT_EQ(e.what(), "data.csv:5:13: 'abc' is not a number in column 'subject_3'");
}

TEST(SpectraCsv, RefusesNonFiniteAndEmptyCells) {
  struct Case {
    std::string_view row;
    std::size_t column;
    std::string_view says;
  };
  for (const auto& [row, column, says] :
       {Case{"550,nan", 5, "not a finite number in column 'a'"}, Case{"550, inf", 5, "not a finite number"},
        Case{"550,-inf", 5, "not a finite number"}, Case{"550,1e999", 5, "out of range"}, Case{"550,", 5, "empty cell"},
        Case{"x5,0.1", 1, "in column 'wavelength_nm'"}}) {
    SCOPED_TRACE(row);
    const auto e = error_of("wavelength_nm,a\n400,0.1\n" + std::string(row) + "\n700,0.2\n");
    EXPECT_EQ(e.line, 3u);
    EXPECT_EQ(e.column, column);
    EXPECT_THAT(e.message, HasSubstr(std::string(says)));
  }
}

TEST(SpectraCsv, RefusesRepeatedWavelengthsNamingBoth) {
  const auto e = error_of("wavelength_nm,a\n400,0.1\n550,0.2\n\n 550,0.3\n700,0.4\n");
  EXPECT_EQ(e.line, 5u);
  EXPECT_EQ(e.column, 1u);
  EXPECT_THAT(e.message, HasSubstr("wavelength 550 nm repeats 550 nm on line 3"));
}

TEST(SpectraCsv, RefusesDecreasingWavelengthsNamingBoth) {
  const auto e = error_of("wavelength_nm,a\n400,0.1\n550,0.2\n500.5,0.3\n700,0.4\n");
  EXPECT_EQ(e.line, 4u);
  EXPECT_EQ(e.column, 1u);
  EXPECT_THAT(e.message, HasSubstr("wavelength 500.5 nm is below 550 nm on line 3"));
}

TEST(SpectraCsv, RefusesFewerThanTwoRows) {
  const auto header_only = error_of("wavelength_nm,a\n\n");
  EXPECT_EQ(header_only.line, 1u);
  EXPECT_THAT(header_only.message, HasSubstr("0 data rows"));
  const auto one_row = error_of("wavelength_nm,a\n\n400,0.1\n\n");
  EXPECT_EQ(one_row.line, 3u);
  EXPECT_THAT(one_row.message, HasSubstr("1 data row below the header"));
}

TEST(SpectraCsv, RefusesAGridThatDoesNotCoverTheVisible) {
  const auto short_red = error_of("wavelength_nm,a\n400,0.1\n690,0.2\n");
  EXPECT_EQ(short_red.what(), "data.csv: the wavelengths cover 400-690 nm but 400-700 nm is needed");
  const auto short_blue = error_of("wavelength_nm,a\n410,0.1\n700,0.2\n");
  EXPECT_THAT(short_blue.message, HasSubstr("cover 410-700 nm"));
}

TEST(SpectraCsv, RefusesValuesOutsideTheLimitsNamingThem) {
  const auto negative = error_of("wavelength_nm,a,b\n400,0.1,0.1\n550,0.2,-0.05\n700,0.3,0.3\n");
  EXPECT_EQ(negative.line, 3u);
  EXPECT_EQ(negative.column, 9u);
  EXPECT_THAT(negative.message, HasSubstr("value -0.05 in column 'b' is outside the allowed range [0, 1.5]"));
  const auto too_bright = error_of("wavelength_nm,a\n400,1.6\n700,0.3\n");
  EXPECT_EQ(too_bright.what(), "data.csv:2:5: value 1.6 in column 'a' is outside the allowed range [0, 1.5]");
}

TEST(SpectraCsv, LimitsAreConfigurable) {
  constexpr std::string_view percent = "wavelength_nm,a\n450,55\n650,98\n";
  EXPECT_FALSE(parse(percent));
  const SpectraLimits percent_visible{
      .min_value = 0.0, .max_value = 100.0, .must_cover_from_nm = 450.0, .must_cover_to_nm = 650.0};
  const auto spectra = parse(percent, percent_visible);
  ASSERT_TRUE(spectra) << spectra.error().what();
  EXPECT_DOUBLE_EQ((*spectra)[0].spectrum.values()[1], 98.0);

  const auto above = error_of("wavelength_nm,a\n450,55\n650,120\n", percent_visible);
  EXPECT_EQ(above.line, 3u);
  EXPECT_THAT(above.message, HasSubstr("[0, 100]"));
  const auto narrow = error_of("wavelength_nm,a\n450,55\n600,98\n", percent_visible);
  EXPECT_THAT(narrow.message, HasSubstr("450-650 nm is needed"));
}

// ---------------------------------------------------------------------------------------------
// The scale of the values: fractions, percent, or auto (reflectance_scale.hpp).

std::expected<SpectraFile, InputError> read_as(std::string_view bytes, ScaleRequest scale) {
  return parse_spectra_file(bytes, "data.csv", SpectraLimits{.scale = scale});
}

InputError refused_as(std::string_view bytes, ScaleRequest scale) {
  const auto result = read_as(bytes, scale);
  if (result) {
    ADD_FAILURE() << "accepted as " << to_string(scale) << ":\n" << bytes;
    return {};
  }
  return result.error();
}

// Dark skin in percent: below 1.5 at 400 nm, above it everywhere else.
constexpr std::string_view kDarkPercent = "wavelength_nm,dark,light\n400,1.2,20.5\n550,4.5,35\n700,22,61.25\n";

TEST(SpectraCsvScale, AutoReadsPercentWhenMostValuesExceedOnePointFive) {
  const auto file = read_as(kDarkPercent, ScaleRequest::automatic);
  ASSERT_TRUE(file) << file.error().what();
  EXPECT_EQ(file->scale.scale, ReflectanceScale::percent);
  EXPECT_TRUE(file->scale.automatic);
  EXPECT_EQ(describe(file->scale), "percent (auto)");
  EXPECT_DOUBLE_EQ(file->spectra[0].spectrum.values()[0], 0.012);
  EXPECT_DOUBLE_EQ(file->spectra[1].spectrum.values()[2], 0.6125);

  const auto fractions = read_as(kThreeSubjects, ScaleRequest::automatic);
  ASSERT_TRUE(fractions) << fractions.error().what();
  EXPECT_EQ(describe(fractions->scale), "fraction (auto)");
  EXPECT_DOUBLE_EQ(fractions->spectra[0].spectrum.values()[1], 0.45);
}

TEST(SpectraCsvScale, PercentAskedForDividesEveryValueThenChecksTheRange) {
  const auto file = read_as(kDarkPercent, ScaleRequest::percent);
  ASSERT_TRUE(file) << file.error().what();
  EXPECT_EQ(describe(file->scale), "percent");
  EXPECT_DOUBLE_EQ(file->spectra[0].spectrum.values()[1], 0.045);
  // Fractions read as percent are taken at their word: a hundredth of them.
  const auto small = read_as(kThreeSubjects, ScaleRequest::percent);
  ASSERT_TRUE(small) << small.error().what();
  EXPECT_DOUBLE_EQ(small->spectra[0].spectrum.values()[1], 0.0045);
  const auto above = refused_as("wavelength_nm,a\n400,20\n700,150.5\n", ScaleRequest::percent);
  EXPECT_EQ(above.what(),
            "data.csv:3:5: value 150.5 in column 'a' is outside the allowed range [0, 150]; values read as percent");
}

TEST(SpectraCsvScale, FractionsAskedForRefuseAPercentFileAtItsFirstValueAboveOnePointFive) {
  const auto refused = refused_as(kDarkPercent, ScaleRequest::fraction);
  EXPECT_EQ(refused.what(), "data.csv:2:9: value 20.5 in column 'light' is outside the allowed range [0, 1.5]");
  EXPECT_FALSE(parse(kDarkPercent)) << "fractions are what a caller gets unless it asks";
}

TEST(SpectraCsvScale, AutoReadsFractionsWithAFewStrayValuesAndRefusesThem) {
  // One typing error among fractions: too few values above 1.5 for percent.
  const auto refused = refused_as("wavelength_nm,a\n400,0.1\n550,1.51\n700,0.2\n", ScaleRequest::automatic);
  EXPECT_EQ(refused.line, 3u);
  EXPECT_EQ(refused.column, 5u);
  EXPECT_EQ(refused.message,
            "value 1.51 in column 'a' is outside the allowed range [0, 1.5]; values read as fraction (auto), as "
            "fewer than half of them exceed 1.5");
  // Exactly half above 1.5 is percent.
  const auto half = read_as("wavelength_nm,a\n400,1\n700,2\n", ScaleRequest::automatic);
  ASSERT_TRUE(half) << half.error().what();
  EXPECT_EQ(half->scale.scale, ReflectanceScale::percent);
}

TEST(SpectraCsvScale, AutoRefusesAColumnOfFractionsAmongPercent) {
  const auto refused =
      refused_as("wavelength_nm,a,b,c\n400,20,0.2,30\n550,30,0.3,40\n700,40,0.4,50\n", ScaleRequest::automatic);
  EXPECT_EQ(refused.what(),
            "data.csv:1:17: spectrum 'b' stays at or below 1.5 while the file holds percent elsewhere: its values are "
            "on another scale");
  // Above 150 percent is no reflectance either way.
  const auto bright = refused_as("wavelength_nm,a\n400,20\n700,151\n", ScaleRequest::automatic);
  EXPECT_EQ(bright.line, 3u);
  EXPECT_THAT(bright.message, HasSubstr("[0, 150]; values read as percent (auto)"));
}

TEST(ReflectanceScale, RequestsByName) {
  for (const auto request : {ScaleRequest::automatic, ScaleRequest::fraction, ScaleRequest::percent})
    EXPECT_EQ(parse_scale_request(to_string(request)), request);
  EXPECT_EQ(to_string(ScaleRequest::automatic), "auto");
  EXPECT_FALSE(parse_scale_request("Percent"));
  EXPECT_FALSE(parse_scale_request(""));
  EXPECT_EQ(scale_request_names(), "auto, fraction or percent");
}

TEST(ReflectanceScale, AutoCountsEveryValueOfEverySpectrum) {
  const std::vector<double> fractions = {0.2, 0.3, 0.4}, percent = {1.0, 20, 40}, bright = {20, 30, 40},
                            stray = {0.1, 3.0, 0.2};
  const auto decide = [](std::vector<std::span<const double>> spectra) {
    return decide_scale(ScaleRequest::automatic, spectra);
  };
  EXPECT_EQ(decide({fractions})->scale, ReflectanceScale::fraction);
  EXPECT_EQ(decide({percent})->scale, ReflectanceScale::percent);
  EXPECT_EQ(decide({stray})->scale, ReflectanceScale::fraction);
  // Six of nine values above 1.5, every spectrum above it somewhere: percent.
  EXPECT_EQ(decide({percent, stray, bright})->scale, ReflectanceScale::percent);
  // Three of nine: fractions, whose range then refuses the values above 1.5.
  EXPECT_EQ(decide({percent, stray, fractions})->scale, ReflectanceScale::fraction);
  // Six of nine: percent, but the fractions are on another scale.
  const auto mixed = decide({bright, bright, fractions});
  ASSERT_FALSE(mixed);
  EXPECT_EQ(mixed.error().spectrum, 2u);
  EXPECT_EQ(decide({})->scale, ReflectanceScale::fraction);
  EXPECT_EQ(decide_scale(ScaleRequest::fraction, std::vector<std::span<const double>>{percent})->scale,
            ReflectanceScale::fraction);
  EXPECT_FALSE(decide_scale(ScaleRequest::percent, std::vector<std::span<const double>>{fractions})->automatic);
}

}  // namespace
}  // namespace skinspec

namespace skinspec {
namespace {

TEST(SpectraCsvComments, SkipsCommentLinesAnywhere) {
  const auto spectra =
      parse_spectra_csv("# measured 2026-11-21\nwavelength_nm,a\n400,0.1\n  # lamp warm\n700,0.2\n", "c.csv");
  ASSERT_TRUE(spectra) << spectra.error().what();
  ASSERT_EQ(spectra->size(), 1u);
  EXPECT_EQ((*spectra)[0].spectrum.size(), 2u);
}

}  // namespace
}  // namespace skinspec

namespace skinspec {
namespace {

// Bytes that are not UTF-8, wherever they are, are refused at their line and column, and the
// message shows them escaped (never raw) with the text before them.
struct NotUtf8 {
  const char* label;
  std::string bytes;
  std::size_t line, column;
  std::string shown;  // the escaped bytes the message must contain
};

const NotUtf8 kNotUtf8[] = {
    {"in the header", "wavelength_nm,\xff\xfe\n400,0.3\n500,0.3\n600,0.3\n700,0.3\n", 1, 15, "\\xff\\xfe"},
    {"in a name", "wavelength_nm,a,sub\xe9ject\n400,0.3,0.3\n700,0.3,0.3\n", 1, 20, "\\xe9"},
    {"in a comment", "# lamp \xc0\xaf warm\nwavelength_nm,a\n400,0.3\n700,0.3\n", 1, 8, "\\xc0\\xaf"},
    {"in a comment after the data", "wavelength_nm,a\n400,0.3\n700,0.3\n# \xf8\x88\x80\x80\x80\n", 4, 3,
     "\\xf8\\x88\\x80\\x80\\x80"},
    {"in a value",
     "wavelength_nm,a\n400,0.3\n550,0.\x80"
     "3\n700,0.3\n",
     3, 7, "\\x80"},
    {"a lone continuation byte", "wavelength_nm,a\n400,0.3\n\x80\n700,0.3\n", 3, 1, "\\x80"},
    {"an overlong encoding", "wavelength_nm,a\xe0\x80\xaf\n400,0.3\n700,0.3\n", 1, 16, "\\xe0\\x80\\xaf"},
    {"a surrogate", "wavelength_nm,a\n400,0.3\n700,0.3\xed\xa0\x80\n", 3, 8, "\\xed\\xa0\\x80"},
    {"a sequence cut off by the line end", "wavelength_nm,\xe2\x82\r\n400,0.3\r\n700,0.3\r\n", 1, 15, "\\xe2\\x82"},
    {"on a blank-looking line", "wavelength_nm,a\n400,0.3\n \xff \n700,0.3\n", 3, 2, "\\xff"},
};

TEST(SpectraCsvUtf8, RefusesBytesThatAreNotUtf8WhereverTheyAre) {
  for (const auto& [label, bytes, line, column, shown] : kNotUtf8) {
    SCOPED_TRACE(label);
    const auto e = error_of(bytes);
    EXPECT_EQ(e.line, line);
    EXPECT_EQ(e.column, column);
    EXPECT_THAT(e.message, HasSubstr(shown + " is not UTF-8 text"));
    EXPECT_TRUE(utf8::is_valid(e.what())) << e.what();
    EXPECT_EQ(e.what().find('\x1b'), std::string::npos);
  }
}

TEST(SpectraCsvUtf8, QuotesTheTextBeforeTheBadBytes) {
  EXPECT_EQ(error_of("wavelength_nm,\xff\xfe\n400,0.3\n700,0.3\n").what(),
            "data.csv:1:15: \\xff\\xfe is not UTF-8 text (after 'wavelength_nm,'); the file must be saved as UTF-8");
  // A long line is quoted from a character boundary shortly before the defect.
  // Here 24 bytes back falls inside the two bytes of the é, so the quote starts after it.
  const auto long_name =
      error_of("wavelength_nm," + std::string(40, 'a') + "\xc3\xa9" + std::string(23, 'b') + "\xff\n");
  EXPECT_THAT(long_name.message, HasSubstr("(after ...'" + std::string(23, 'b') + "')"));
}

TEST(SpectraCsvUtf8, KeepsUtf8NamesAsTheyAre) {
  const std::string names = "Probandin_\xc3\x84,\xe6\x97\xa5\xe6\x9c\xac,\xf0\x9f\x96\x90";
  const auto spectra = parse("\xEF\xBB\xBFwavelength_nm," + names + "\n400,0.1,0.2,0.3\n700,0.2,0.3,0.4\n");
  ASSERT_TRUE(spectra) << spectra.error().what();
  ASSERT_EQ(spectra->size(), 3u);
  EXPECT_EQ((*spectra)[0].name, "Probandin_\xc3\x84");
  EXPECT_EQ((*spectra)[1].name, "\xe6\x97\xa5\xe6\x9c\xac");
  EXPECT_EQ((*spectra)[2].name, "\xf0\x9f\x96\x90");
}

TEST(SpectraCsvUtf8, EscapesControlCharactersInQuotedNamesAndCells) {
  const auto duplicate = error_of("wavelength_nm,a\x1b[2J,a\x1b[2J\n400,0.1,0.1\n700,0.2,0.2\n");
  EXPECT_THAT(duplicate.message, HasSubstr("duplicated column name 'a\\x1b[2J'"));
  const auto cell = error_of(
      "wavelength_nm,a\n400,0.1\n550,0\x07"
      "1\n700,0.2\n");
  EXPECT_THAT(cell.message, HasSubstr("'0\\x071' is not a number"));
  const auto first = error_of("wave\tlength,a\n400,0.1\n700,0.2\n");
  EXPECT_THAT(first.message, HasSubstr("'wave\\tlength'"));
}

TEST(SpectraCsvUtf8, TheSourceNameIsEscapedToo) {
  const auto e = parse_spectra_csv("", "dir/\xff\x1b.csv");
  ASSERT_FALSE(e);
  EXPECT_THAT(e.error().what(), ::testing::StartsWith("dir/\\xff\\x1b.csv:1: "));
}

}  // namespace
}  // namespace skinspec
