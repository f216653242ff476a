// Other programs' spectra files read for import (records/import.hpp): the example files of each
// layout, the format recognised, and the defects that refuse a file with its line and column.

#include "skinspec/records/import.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "skinspec/records/import_file.hpp"
#include "support/data.hpp"
#include "skinspec/testkit/store_samples.hpp"

namespace skinspec::records {
namespace {

using ::testing::HasSubstr;

std::vector<ImportedSpectrum> read_ok(std::string_view bytes, ImportFormat format) {
  auto read = read_import(bytes, "f.csv", format);
  if (!read) throw std::runtime_error(read.error().what());
  return std::move(*read);
}

InputError read_refused(std::string_view bytes, ImportFormat format = ImportFormat::csv) {
  auto read = read_import(bytes, "f.csv", format);
  if (read) throw std::runtime_error("read a file it should refuse");
  return read.error();
}

TEST(ImportTest, KonicaMinoltaRowsInPercentBecomeFractionsNamedByTheirFirstColumn) {
  const auto text = testing::data_file("examples/import-rows-percent.csv");
  EXPECT_EQ(recognise_import_format(text), ImportFormat::csv);
  const auto spectra = read_ok(text, ImportFormat::csv);
  ASSERT_EQ(spectra.size(), 3u);
  EXPECT_EQ(spectra[0].sample_id, "forearm P-01");
  EXPECT_EQ(spectra[2].sample_id, "cheek P-01");
  EXPECT_EQ(spectra[1].line, 3u);
  ASSERT_EQ(spectra[0].reflectance.wavelength_nm.size(), 31u);
  EXPECT_EQ(spectra[0].reflectance.wavelength_nm.front(), 400);
  EXPECT_EQ(spectra[0].reflectance.wavelength_nm.back(), 700);
  EXPECT_DOUBLE_EQ(spectra[0].reflectance.values[0], 0.2503);
}

TEST(ImportTest, ColumnsOfFractionsAreReadAsTheyAre) {
  const auto text = testing::data_file("examples/import-columns.csv");
  const auto spectra = read_ok(text, recognise_import_format(text));
  ASSERT_EQ(spectra.size(), 2u);
  EXPECT_EQ(spectra[1].sample_id, "subject-7 right");
  EXPECT_EQ(spectra[1].line, 3u);
  EXPECT_DOUBLE_EQ(spectra[1].reflectance.values[0], 0.28026);
  EXPECT_EQ(spectra[1].reflectance.wavelength_nm[1], 410);
}

TEST(ImportTest, AnArgyllTableIsRecognisedWithItsInstrument) {
  const auto text = testing::data_file("examples/import-argyll.ti3");
  ASSERT_EQ(recognise_import_format(text), ImportFormat::cgats);
  EXPECT_EQ(recognise_import_format("\xEF\xBB\xBF" + text), ImportFormat::cgats);
  const auto spectra = read_ok(text, ImportFormat::cgats);
  ASSERT_EQ(spectra.size(), 2u);
  EXPECT_EQ(spectra[0].sample_id, "1");
  EXPECT_EQ(spectra[0].instrument, "X-Rite i1 Pro 2");
  EXPECT_EQ(spectra[0].line, 21u);
  EXPECT_DOUBLE_EQ(spectra[0].reflectance.values[0], 0.250261);  // 25.0261 over SPECTRAL_NORM 100
}

TEST(ImportTest, DefectsAreNamedByLineAndColumn) {
  struct Case {
    std::string text;
    std::size_t line, column;
    std::string says;
  };
  const std::vector<Case> cases = {
      {"", 0, 0, "no header"},
      {"wavelength_nm,a\n", 1, 0, "no header and data rows"},
      {"wavelength_nm,a\n400,0.1\n500,x\n", 3, 2, "'x' is not a number"},
      {"wavelength_nm,a\n400,0.1\n400,0.2\n", 3, 1, "must increase"},
      {"wavelength_nm,a,b\n400,0.1,0.2\n500,0.3\n", 3, 0, "2 fields where the header has 3"},
      {"wavelength_nm,a,\n400,0.1,0.2\n500,0.3,0.3\n", 1, 3, "without a name"},
      {"id,400nm,500nm\nP1,10,20\nP2,30,200\n", 3, 3, "200 is not a reflectance (-5 to 150 percent"},
      {"id,400nm,500nm\nP1,0.1,-0.2\n", 2, 3, "-0.2 is not a reflectance"},
      {"id,500nm,400nm\nP1,0.1,0.2\n", 1, 3, "must increase from column to column"},
      {"id,comment\nP1,x\n", 1, 0, "the header names no wavelengths"},
      {"id,400,500\n\"P1,0.1,0.2\n", 2, 0, "not closed"},
      {"wavelength_nm,a\n400,0.1\n", 2, 0, "at least two wavelengths"},
      {"id,400,500\nP\xE9,0.1,0.2\n", 2, 0, "not UTF-8"},
      {"id,400nm,500nm\nP1,40,50\nP2,0.4,0.5\n", 3, 0, "spectrum 'P2' stays at or below 1.5"},
      {"id,400,500\rP1,0.1,0.2\r", 1, 0, "carriage return alone"},
      {std::string("id,400,500\nP1,0.1,0.2\nP\0,0.1,0.2\n", 33), 3, 0, "not UTF-8"},
  };
  for (const auto& c : cases) {
    const auto error = read_refused(c.text);
    EXPECT_EQ(error.source, "f.csv");
    EXPECT_EQ(error.line, c.line) << c.text;
    EXPECT_EQ(error.column, c.column) << c.text;
    EXPECT_THAT(error.message, HasSubstr(c.says)) << c.text;
  }
  const auto cgats = read_refused(
      "CTI3\nSPECTRAL_BANDS 2\nBEGIN_DATA_FORMAT\nSAMPLE_ID\nEND_DATA_FORMAT\n"
      "BEGIN_DATA\n1\nEND_DATA\n",
      ImportFormat::cgats);
  EXPECT_THAT(cgats.message, HasSubstr("no SPECTRAL_START_NM"));
  // Radiance, or percent without SPECTRAL_NORM 100, is no reflectance.
  const auto radiance = read_refused(
      "CTI3\nSPECTRAL_BANDS 2\nSPECTRAL_START_NM 400\nSPECTRAL_END_NM 500\nBEGIN_DATA_FORMAT\nSAMPLE_ID SPEC_400 "
      "SPEC_500\nEND_DATA_FORMAT\nBEGIN_DATA\n1 0.3 0.4\n2 30 40\nEND_DATA\n",
      ImportFormat::cgats);
  EXPECT_EQ(radiance.line, 10u);
  EXPECT_THAT(radiance.message, HasSubstr("30 at 400 nm is not a reflectance"));
  EXPECT_THAT(read_refused("CTI3\nBEGIN_DATA_FORMAT\nSAMPLE_ID\nEND_DATA_FORMAT\nBEGIN_DATA\n1\nEND_DATA\n",
                           ImportFormat::cgats)
                  .message,
              HasSubstr("no spectra"));
}

TEST(ImportTest, QuotedFieldsCommentsAndBlankLinesAreRead) {
  const auto spectra = read_ok(
      "\xEF\xBB\xBF# exported by \"a program\n\n\"Data Name\",\"400 nm\",\"500 nm\"\r\n\"P \"\"A\"\", "
      "left\",0.1,0.2\r\n\n#12,0.3,0.4\n",
      ImportFormat::csv);
  // A '#' line before the header is a comment, unparsed; after it, a sample named #12.
  ASSERT_EQ(spectra.size(), 2u);
  EXPECT_EQ(spectra[1].sample_id, "#12");
  EXPECT_EQ(spectra[0].sample_id, "P \"A\", left");
  EXPECT_EQ(spectra[0].line, 4u);
  EXPECT_EQ(spectra[0].reflectance.values[1], 0.2);
}

// The scale asked for (reflectance_scale.hpp): auto, as above, or said; a CGATS file gives its own.
TEST(ImportTest, AScaleAskedForIsHowTheValuesAreRead) {
  const auto text = testing::data_file("examples/import-rows-percent.csv");
  const auto as_auto = read_ok(text, ImportFormat::csv);
  EXPECT_EQ(as_auto[0].scale, ReflectanceScale::percent);
  const auto as_percent = read_import(text, "f.csv", ImportFormat::csv, ScaleRequest::percent);
  ASSERT_TRUE(as_percent) << as_percent.error().what();
  EXPECT_EQ((*as_percent)[2].reflectance.values, as_auto[2].reflectance.values);
  EXPECT_EQ((*as_percent)[2].scale, ReflectanceScale::percent);
  // The first value of the first spectrum, on line 2 after three text columns.
  const auto as_fractions = read_import(text, "f.csv", ImportFormat::csv, ScaleRequest::fraction);
  ASSERT_FALSE(as_fractions);
  EXPECT_EQ(as_fractions.error().what(), "f.csv:2:4: 25.03 is not a reflectance (-0.05 to 1.5)");

  const auto columns = testing::data_file("examples/import-columns.csv");
  EXPECT_EQ(read_ok(columns, ImportFormat::csv)[0].scale, ReflectanceScale::fraction);
  const auto columns_in_percent = read_import(columns, "f.csv", ImportFormat::csv, ScaleRequest::percent);
  ASSERT_TRUE(columns_in_percent) << columns_in_percent.error().what();
  EXPECT_DOUBLE_EQ((*columns_in_percent)[1].reflectance.values[0], 0.0028026);

  // A stray value among fractions is refused, not taken for percent; dark skin in percent is not.
  EXPECT_EQ(read_refused("id,400nm,500nm,600nm\nP1,0.1,2.5,0.3\n").what(),
            "f.csv:2:3: 2.5 is not a reflectance (-0.05 to 1.5); values read as fraction (auto), as fewer than half "
            "of them exceed 1.5");
  const auto dark = read_ok("id,400nm,500nm,600nm\nP1,1.2,4.5,12\n", ImportFormat::csv);
  EXPECT_EQ(dark[0].scale, ReflectanceScale::percent);
  EXPECT_DOUBLE_EQ(dark[0].reflectance.values[0], 0.012);

  const auto argyll = testing::data_file("examples/import-argyll.ti3");
  EXPECT_EQ(read_ok(argyll, ImportFormat::cgats)[0].scale, std::nullopt);
  const auto cgats_in_percent = read_import(argyll, "f.ti3", ImportFormat::cgats, ScaleRequest::percent);
  ASSERT_FALSE(cgats_in_percent);
  EXPECT_EQ(cgats_in_percent.error().what(),
            "f.ti3: scale percent is for CSV files: a CGATS file gives its own (SPECTRAL_NORM)");
}

TEST(ImportTest, AnImportedSpectrumBecomesAMeasurementWithItsProvenance) {
  ImportedSpectrum s{"P-1", 7, "CM-700d", {{400, 500}, {0.3, 0.4}}, ReflectanceScale::percent};
  const auto m = imported_measurement(s, 12, "lab.csv", ImportFormat::csv, store::Time(std::chrono::seconds(5)));
  EXPECT_EQ(m.session_id, 12);
  EXPECT_EQ(m.kind, store::MeasurementKind::imported);
  EXPECT_EQ(m.label, "P-1");
  EXPECT_TRUE(m.radiance.empty());
  EXPECT_EQ(m.reflectance.values, (std::vector<double>{0.3, 0.4}));
  const auto source = nlohmann::json::parse(m.settings)["source"];
  EXPECT_EQ(source["file"], "lab.csv");
  EXPECT_EQ(source["format"], "csv");
  EXPECT_EQ(source["line"], 7);
  EXPECT_EQ(source["instrument"], "CM-700d");
  EXPECT_EQ(source["scale"], "percent");
  s.scale = std::nullopt;  // CGATS
  EXPECT_TRUE(
      nlohmann::json::parse(imported_measurement(s, 12, "lab.ti3", ImportFormat::cgats, {}).settings)["source"]["scale"]
          .is_null());
  EXPECT_EQ(nlohmann::json::parse(import_job_result(3, "lab.csv", ImportFormat::csv, ReflectanceScale::fraction)),
            (nlohmann::json{{"imported", 3}, {"source", "lab.csv"}, {"format", "csv"}, {"scale", "fraction"}}));
  EXPECT_EQ(parse_import_format("cgats"), ImportFormat::cgats);
  EXPECT_FALSE(parse_import_format("xlsx"));
}

// ---- A file imported into a session: fitted and stored in one transaction, or nothing of it.

class ImportFileTest : public ::testing::Test {
 protected:
  ImportFileTest() : store_(testing::value_of(store::Store::open(dir_.file("lab.db")))) {
    auto session = testing::sample_session(1);
    session.model = "extended";
    session_ = testing::value_of(store_.create_session(session));
  }

  std::expected<ImportedFile, ImportFailure> import(std::string_view bytes, const ImportObserver& observer = {},
                                                    ScaleRequest scale = ScaleRequest::automatic) {
    return import_file(store_, testing::shipped_fitter(), session_, bytes, "lab.csv", recognise_import_format(bytes),
                       observer, std::nullopt, scale);
  }
  std::size_t stored_measurements() { return testing::value_of(store_.session_detail(session_)).measurements.size(); }

  testing::ScratchDirectory dir_;
  store::Store store_;
  store::Id session_ = 0;
};

TEST_F(ImportFileTest, EverySpectrumIsStoredWithItsFitAndProvenance) {
  const auto imported = import(testing::data_file("examples/import-rows-percent.csv"));
  ASSERT_TRUE(imported) << imported.error().message();
  ASSERT_EQ(imported->stored.size(), 3u);
  const auto detail = testing::value_of(store_.session_detail(session_));
  ASSERT_EQ(detail.measurements.size(), 3u);
  ASSERT_EQ(detail.fits.size(), 3u);
  const auto& m = detail.measurements[1];
  EXPECT_EQ(m.kind, store::MeasurementKind::imported);
  EXPECT_EQ(m.label, "forearm P-02");
  EXPECT_EQ(nlohmann::json::parse(m.settings)["source"]["line"], 3);
  EXPECT_EQ(nlohmann::json::parse(m.settings)["source"]["scale"], "percent");
  EXPECT_EQ(detail.fits[1].measurement_id, m.id);
  EXPECT_EQ(detail.fits[1].model, "extended");
  EXPECT_EQ(detail.fits[1].site, detail.session.site);
  EXPECT_EQ(*imported->stored[1].fit_id, detail.fits[1].id);
  const auto argyll = import(testing::data_file("examples/import-argyll.ti3"));
  ASSERT_TRUE(argyll) << argyll.error().message();
  EXPECT_EQ(stored_measurements(), 5u);
}

TEST_F(ImportFileTest, MeasurementsStoredAsTheyAreReadyAreStoredWholeOrNotAtAll) {
  std::vector<std::pair<store::Measurement, std::optional<store::Fit>>> rows;
  for (const auto& s : read_ok(testing::data_file("examples/import-rows-percent.csv"), ImportFormat::csv))
    rows.emplace_back(imported_measurement(s, session_, "lab.csv", ImportFormat::csv, store::Time{}), std::nullopt);
  ASSERT_EQ(rows.size(), 3u);
  struct Abandoned {};
  std::size_t given = 0;
  // Two stored, then the giver gives up: the exception leaves the store, and nothing stays.
  EXPECT_THROW((void)store_.record_measurements_as_ready([&]() -> const auto* {
    if (given == 2) throw Abandoned{};
    return &rows[given++];
  }),
               Abandoned);
  EXPECT_EQ(stored_measurements(), 0u);
  given = 0;
  const auto stored =
      store_.record_measurements_as_ready([&] { return given < rows.size() ? &rows[given++] : nullptr; });
  ASSERT_TRUE(stored) << stored.error().message;
  EXPECT_EQ(stored->size(), 3u);
  EXPECT_EQ(stored_measurements(), 3u);
}

TEST_F(ImportFileTest, AFileWithADefectOrASpectrumTheFitterRefusesStoresNothing) {
  std::string text = testing::data_file("examples/import-columns.csv");
  text.replace(text.find("0.28039"), 7, "0.2803x");
  const auto bad_value = import(text);
  ASSERT_FALSE(bad_value);
  EXPECT_TRUE(bad_value.error().bad_file());
  EXPECT_THAT(bad_value.error().message(), HasSubstr("lab.csv:4:3: '0.2803x' is not a number"));
  // A spectrum of 500-600 nm only: the fitter needs more.
  const auto narrow = import("wavelength_nm,a\n500,0.3\n550,0.3\n600,0.4\n");
  ASSERT_FALSE(narrow);
  EXPECT_TRUE(narrow.error().bad_file());
  EXPECT_THAT(narrow.error().message(), HasSubstr("lab.csv:2: spectrum 'a' cannot be fitted"));
  // Percent said to be fractions.
  const auto percent = import(testing::data_file("examples/import-rows-percent.csv"), {}, ScaleRequest::fraction);
  ASSERT_FALSE(percent);
  EXPECT_TRUE(percent.error().bad_file());
  EXPECT_THAT(percent.error().message(), HasSubstr("lab.csv:2:4: 25.03 is not a reflectance"));
  EXPECT_EQ(stored_measurements(), 0u);
}

TEST_F(ImportFileTest, AClosedSessionOrAStoppedImportStoresNothing) {
  const auto text = testing::data_file("examples/import-columns.csv");
  const auto stopped = import(text, [](std::size_t, std::size_t) { return false; });
  ASSERT_TRUE(stopped);
  EXPECT_TRUE(stopped->stopped);
  EXPECT_EQ(stored_measurements(), 0u);
  // Stopped once every spectrum is fitted, while the rows are being stored: still nothing.
  std::size_t heard_all_fitted = 0;
  const auto late = import(text, [&](std::size_t fitted, std::size_t total) {
    if (fitted < total) return true;
    ++heard_all_fitted;
    return false;
  });
  ASSERT_TRUE(late);
  EXPECT_TRUE(late->stopped);
  EXPECT_GE(heard_all_fitted, 1u);
  EXPECT_EQ(stored_measurements(), 0u);
  testing::value_of(store_.update_session(session_, {.notes = std::nullopt, .state = store::SessionState::complete}));
  const auto closed = import(text);
  ASSERT_FALSE(closed);
  EXPECT_FALSE(closed.error().bad_file());
  EXPECT_THAT(closed.error().message(), HasSubstr("not open"));
  EXPECT_EQ(stored_measurements(), 0u);
}

}  // namespace
}  // namespace skinspec::records
