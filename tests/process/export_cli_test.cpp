// `skinspec export` run as a child process on databases the store made: what it prints in both
// formats, and the files and sessions it refuses with exit status 2.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "skinspec/records/cgats.hpp"
#include "skinspec/records/export.hpp"
#include "skinspec/records/record_json.hpp"
#include "skinspec/spectral/colour.hpp"
#include "skinspec/store/store.hpp"
#include "support/data.hpp"
#include "skinspec/testkit/process.hpp"
#include "skinspec/testkit/store_samples.hpp"

namespace skinspec {
namespace {

using namespace skinspec::store;
using ::testing::HasSubstr;
using ::testing::IsEmpty;
using Json = nlohmann::json;

constexpr int kBadInput = 2;

template <typename T>
T value_of(Result<T> result) {
  if (!result) throw std::runtime_error(result.error().message);
  return std::move(*result);
}

testing::ProcessResult skinspec(const std::vector<std::string>& args) {
  return testing::run_process(SKINSPEC_TEST_BIN_DIR "/skinspec", args);
}

using testing::lines_of;

std::vector<std::string> fields_of(const std::string& line) {
  std::vector<std::string> fields(1);
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted && c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
      fields.back() += '"';
      ++i;
    } else if (c == '"') {
      quoted = !quoted;
    } else if (c == ',' && !quoted) {
      fields.emplace_back();
    } else {
      fields.back() += c;
    }
  }
  return fields;
}

class ExportTest : public ::testing::Test {
 protected:
  // Two sessions: the first with a white reading and two samples (one fitted twice), the
  // second with one fitted sample. Returns the store, still open (as skinspecd would hold it).
  Store make_database() {
    auto store = value_of(Store::open(path_));
    const Id white_standard = value_of(store.add_white_standard(testing::sample_white_standard(1)));
    const Id instrument = value_of(store.ensure_instrument(testing::sample_instrument(1)));
    auto session = testing::sample_session(0);
    session.subject = "S-1000, left";
    session.white_standard_id = white_standard;
    first_ = value_of(store.create_session(session));
    auto white = testing::sample_measurement(first_, 0);
    white.kind = MeasurementKind::white;
    white.reflectance = {};
    white.instrument_id = instrument;
    white_id_ = value_of(store.record_measurement(white, std::nullopt)).measurement_id;
    auto sample = testing::sample_measurement(first_, 1);
    sample.white_measurement_id = white_id_;
    sample.instrument_id = instrument;
    const auto ids = value_of(store.record_measurement(sample, testing::sample_fit(1)));
    sample_id_ = ids.measurement_id;
    auto refit = testing::sample_fit(2);
    refit.measurement_id = sample_id_;
    value_of(store.add_fit(refit));
    value_of(store.record_measurement(testing::sample_measurement(first_, 3), std::nullopt));
    RejectedReading rejected;
    rejected.session_id = first_;
    rejected.instrument_id = instrument;
    rejected.quality_code = 19;
    rejected.quality = "overload";
    rejected.reason = "bad_reading: quality 19: overload";
    rejected.raw_reply = "19,0\r\n";
    value_of(store.record_rejected_reading(rejected));
    second_ = value_of(store.create_session(testing::sample_session(4)));
    value_of(store.record_measurement(testing::sample_measurement(second_, 4), testing::sample_fit(4)));
    return store;
  }

  testing::ScratchDirectory dir_;
  std::string path_ = dir_.file("skinspec.db");
  Id first_ = 0, second_ = 0, white_id_ = 0, sample_id_ = 0;
};

TEST_F(ExportTest, JsonHoldsTheSessionItsSpectraFitsAndProvenance) {
  auto store = make_database();
  const auto result = skinspec({"export", "--db", path_, "--session", std::to_string(first_)});
  ASSERT_EQ(result.exit_status, 0) << result.describe();
  const auto lines = lines_of(result.out);
  ASSERT_EQ(lines.size(), 1u);
  const auto json = Json::parse(lines[0]);
  EXPECT_EQ(json["session"]["id"], first_);
  EXPECT_EQ(json["session"]["subject"], "S-1000, left");
  EXPECT_EQ(json["session"]["state"], "open");
  EXPECT_EQ(json["white_standard"]["name"], testing::sample_white_standard(1).name);
  EXPECT_EQ(json["white_standard"]["reflectance"].get<std::vector<double>>(),
            testing::sample_white_standard(1).reflectance.values);
  ASSERT_EQ(json["instruments"].size(), 1u);
  EXPECT_EQ(json["instruments"][0]["serial_number"], "609501");
  EXPECT_EQ(json["instruments"][0]["spectral_configuration"]["step_nm"], 4);  // stored JSON, embedded as JSON
  ASSERT_EQ(json["measurements"].size(), 3u);

  const auto& sample = json["measurements"][1];
  const auto expected = testing::sample_measurement(first_, 1);
  EXPECT_EQ(sample["id"], sample_id_);
  EXPECT_EQ(sample["kind"], "sample");
  EXPECT_EQ(sample["session_id"], first_);
  EXPECT_EQ(sample["quality"]["code"], expected.quality_code);
  EXPECT_EQ(sample["provenance"]["white_measurement_id"], white_id_);
  EXPECT_EQ(sample["provenance"]["settings"]["integration_ms"], 101);
  // Numbers come back bit for bit.
  EXPECT_EQ(sample["radiance"]["wavelength_nm"].get<std::vector<double>>(), expected.radiance.wavelength_nm);
  EXPECT_EQ(sample["radiance"]["values"].get<std::vector<double>>(), expected.radiance.values);
  EXPECT_EQ(sample["reflectance"]["values"].get<std::vector<double>>(), expected.reflectance.values);
  EXPECT_EQ(sample["radiance_sd"]["values"].get<std::vector<double>>(), expected.radiance_sd.values);
  EXPECT_TRUE(sample["provenance"]["raw_reply_base64"].get<std::string>().starts_with("MDAwMCwwDQo"));  // "0000,0\r\n"
  EXPECT_EQ(sample["provenance"]["started_at"], "2023-11-14T22:13:21.000123Z");

  ASSERT_EQ(sample["fits"].size(), 2u);
  const auto& fit = sample["fits"][0];
  for (const char* field : {"name",      "site",           "params",          "stderr",
                            "rmse",      "max_abs_error",  "delta_e00_d65",   "iterations",
                            "converged", "wavelength_nm",  "measured",        "fitted",
                            "id",        "measurement_id", "samples_ignored", "solver_summary",
                            "options",   "model_version",  "tables_digest",   "created_at"})
    EXPECT_TRUE(fit.contains(field)) << field;
  EXPECT_EQ(fit["params"]["melanin"], testing::sample_fit(1).params[1].value);
  EXPECT_TRUE(fit["stderr"]["bilirubin"].is_null());  // undetermined
  EXPECT_EQ(fit["tables_digest"], "3f2a9c0d");
  EXPECT_EQ(fit["solver_summary"], testing::sample_fit(1).solver_summary);
  EXPECT_EQ(fit["options"]["lateral_diffusion"], true);
  EXPECT_EQ(fit["fitted"].get<std::vector<double>>(), testing::sample_fit(1).fitted);
  EXPECT_TRUE(json["measurements"][0]["reflectance"].is_null());
  EXPECT_TRUE(json["measurements"][2]["fits"].empty());
  EXPECT_EQ(sample["fit_id"], sample["fits"][1]["id"]);  // the latest
  EXPECT_TRUE(json["measurements"][2]["fit_id"].is_null());

  ASSERT_EQ(json["rejected_readings"].size(), 1u);
  const auto& rejected = json["rejected_readings"][0];
  EXPECT_EQ(rejected["quality"]["code"], 19);
  EXPECT_EQ(rejected["quality"]["text"], "overload");
  EXPECT_EQ(rejected["reason"], "bad_reading: quality 19: overload");
  EXPECT_EQ(rejected["raw_reply_base64"], "MTksMA0K");  // "19,0\r\n"
  EXPECT_EQ(rejected["attempt"], 1);
}

TEST_F(ExportTest, WithoutASessionEverySessionIsOneJsonLineOldestFirst) {
  auto store = make_database();
  const auto result = skinspec({"export", "--db", path_});
  ASSERT_EQ(result.exit_status, 0) << result.describe();
  const auto lines = lines_of(result.out);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(Json::parse(lines[0])["session"]["id"], first_);
  EXPECT_EQ(Json::parse(lines[1])["session"]["id"], second_);
}

TEST_F(ExportTest, CsvHasOneRowPerWavelengthOfEachMeasurementAndFit) {
  auto store = make_database();
  const auto result = skinspec({"export", "--db", path_, "--format", "csv"});
  ASSERT_EQ(result.exit_status, 0) << result.describe();
  auto lines = lines_of(result.out);
  ASSERT_GE(lines.size(), 2u);
  // A comment line first, the columns' units beneath which their names stand.
  const auto units = fields_of(lines[0]);
  lines.erase(lines.begin());
  const auto header = fields_of(lines[0]);
  EXPECT_EQ(header.front(), "session_id");
  EXPECT_EQ(header.back(), "fitted");
  ASSERT_EQ(units.size(), header.size()) << result.out.substr(0, 2000);
  std::map<std::string, std::string> unit_of;
  for (std::size_t i = 0; i < header.size(); ++i) unit_of[header[i]] = units[i];
  EXPECT_EQ(units[0], "# units");
  // A parameter's unit is its model's.
  for (const auto model : kModelKinds)
    for (const auto& p : model_spec(model).params) EXPECT_EQ(unit_of[std::string(p.name)], p.unit) << p.name;
  EXPECT_EQ(unit_of["melanin"], "x 1 % melanosomes in the epidermis");
  EXPECT_EQ(unit_of["surface_reflectance"], "fraction");
  EXPECT_EQ(unit_of["rmse"], "reflectance (fraction)");
  EXPECT_EQ(unit_of["delta_e00_d65"], "CIEDE2000");
  EXPECT_EQ(unit_of["wavelength_nm"], "nm");
  EXPECT_EQ(unit_of["radiance"], "as in units");
  EXPECT_EQ(unit_of["reflectance"], "fraction");
  EXPECT_EQ(unit_of["fitted"], "fraction");
  EXPECT_EQ(unit_of["subject"], "");
  // white (no fit), sample x 2 fits, unfitted sample; second session's fitted sample: 5 x 101.
  ASSERT_EQ(lines.size(), 1u + 5u * 101u);
  const auto column = [&](const std::string& name) {
    return static_cast<std::size_t>(std::find(header.begin(), header.end(), name) - header.begin());
  };
  const auto expected = testing::sample_measurement(first_, 1);
  int checked = 0;
  for (std::size_t i = 1; i < lines.size(); ++i) {
    const auto row = fields_of(lines[i]);
    ASSERT_EQ(row.size(), header.size()) << lines[i];
    EXPECT_EQ(row[column("subject")], row[0] == std::to_string(first_) ? "S-1000, left" : "S-1004");
    if (row[column("measurement_id")] != std::to_string(sample_id_) || row[column("wavelength_nm")] != "400") continue;
    EXPECT_EQ(std::stod(row[column("radiance")]), expected.radiance.values[5]);
    EXPECT_EQ(row[column("units")], expected.units);
    EXPECT_EQ(std::stod(row[column("reflectance")]), expected.reflectance.values[5]);
    EXPECT_EQ(row[column("tables_digest")], "3f2a9c0d");
    const int n = row[column("fit_id")] == "1" ? 1 : 2;
    EXPECT_EQ(std::stod(row[column("melanin")]), testing::sample_fit(n).params[1].value);
    // The paper model's fit leaves the other model's columns empty.
    EXPECT_EQ(row[column("model")], "paper");
    EXPECT_EQ(row[column("total_hemoglobin")], "");
    EXPECT_EQ(row[column("constants_digest")], "77aa01be");
    EXPECT_EQ(std::stod(row[column("fitted")]), testing::sample_fit(n).fitted[5]);
    EXPECT_EQ(row[column("iterations")], std::to_string(testing::sample_fit(n).iterations));
    // How the solver ended where the fit recorded it (sample_fit: the even ones).
    EXPECT_EQ(row[column("termination")], n == 2 ? "function_tolerance" : "");
    ++checked;
  }
  EXPECT_EQ(checked, 2);

  const auto one = skinspec({"export", "--db", path_, "--session", std::to_string(second_), "--format", "csv"});
  ASSERT_EQ(one.exit_status, 0) << one.describe();
  EXPECT_EQ(lines_of(one.out).size(), 2u + 101u);
  EXPECT_EQ(lines_of(one.out)[1], lines[0]);
}

// The CGATS export is read by ArgyllCMS's own spec2cie, which writes CIE values beside the
// spectra: the spectra come back as stored, and its XYZ under D65 agree with skinspec's.
TEST_F(ExportTest, CgatsIsReadByArgyllsSpec2cie) {
  auto store = make_database();
  const auto result = skinspec({"export", "--db", path_, "--session", std::to_string(first_), "--format", "cgats"});
  ASSERT_EQ(result.exit_status, 0) << result.describe();
  // The unit of the spectra in a comment, which ArgyllCMS's reader passes over.
  EXPECT_THAT(result.out, HasSubstr("\n# SPEC_nnn: reflectance at nnn nm in percent"));
  const auto ti3 = dir_.file("session.ti3"), converted = dir_.file("cie.ti3");
  std::ofstream(ti3, std::ios::binary) << result.out;
  const auto argyll = testing::run_process(SKINSPEC_TEST_SPEC2CIE, {"-i", "D65", "-o", "1931_2", ti3, converted});
  ASSERT_EQ(argyll.exit_status, 0) << argyll.describe();
  const auto read = records::parse_cgats(testing::file_bytes(converted));
  ASSERT_TRUE(read) << read.error().line << ": " << read.error().message;
  // The white has no reflectance; the two samples do.
  ASSERT_EQ(read->size(), 2u);
  const auto detail = value_of(store.session_detail(first_));
  const auto d65 = *testing::colorimetry().illuminant("D65");
  for (std::size_t i = 0; i < 2; ++i) {
    const auto& stored = detail.measurements[i + 1];
    const auto& back = (*read)[i];
    EXPECT_EQ(back.sample_id, std::to_string(stored.id));
    EXPECT_EQ(back.sample_name, stored.label);
    EXPECT_EQ(back.wavelength_nm, stored.reflectance.wavelength_nm);
    ASSERT_EQ(back.reflectance.size(), stored.reflectance.values.size());
    for (std::size_t k = 0; k < back.reflectance.size(); ++k)
      EXPECT_NEAR(back.reflectance[k], stored.reflectance.values[k], 1e-6);  // Argyll prints 6 digits
    std::map<std::string, double> cie;
    for (const auto& [name, text] : back.fields)
      if (name.starts_with("XYZ_")) cie[name] = std::stod(text);
    ASSERT_EQ(cie.size(), 3u) << "spec2cie wrote no XYZ";
    const auto reflectance = Spectrum::create(stored.reflectance.wavelength_nm, stored.reflectance.values);
    ASSERT_TRUE(reflectance) << reflectance.error();
    const auto own = testing::colorimetry().xyz(*reflectance, d65);
    EXPECT_NEAR(cie["XYZ_X"], 100 * own.x, 0.3);
    EXPECT_NEAR(cie["XYZ_Y"], 100 * own.y, 0.3);
    EXPECT_NEAR(cie["XYZ_Z"], 100 * own.z, 0.3);
  }
}

TEST_F(ExportTest, TheServiceSendsTheSameCgats) {
  auto store = make_database();
  std::ostringstream out;
  ASSERT_TRUE(records::export_session(store, first_, records::ExportFormat::cgats, out));
  const auto command = skinspec({"export", "--db", path_, "--session", std::to_string(first_), "--format", "cgats"});
  EXPECT_EQ(command.out, out.str());
  // One session at a time (ArgyllCMS reads one table), and one with a reflectance.
  const auto all = skinspec({"export", "--db", path_, "--format", "cgats"});
  EXPECT_EQ(all.exit_status, kBadInput) << all.describe();
  EXPECT_THAT(all.err, HasSubstr("give --session ID"));
  EXPECT_THAT(all.out, IsEmpty());
  const Id empty = value_of(store.create_session(testing::sample_session(9)));
  const auto none = skinspec({"export", "--db", path_, "--session", std::to_string(empty), "--format", "cgats"});
  EXPECT_EQ(none.exit_status, kBadInput) << none.describe();
  EXPECT_THAT(none.err, HasSubstr("holds no reflectance spectrum"));
}

// Export reads beside a live writer without disturbing it: no lock taken, no recovery run.
TEST_F(ExportTest, ExportingBesideAWriterChangesNothing) {
  auto store = make_database();
  Job job;
  job.kind = "measure";
  job.session_id = first_;
  const Id job_id = value_of(store.create_job(job)).job.id;
  value_of(store.update_job(job_id, {.state = JobState::running}));
  const auto result = skinspec({"export", "--db", path_, "--session", std::to_string(first_)});
  ASSERT_EQ(result.exit_status, 0) << result.describe();
  EXPECT_EQ(value_of(store.session(first_)).state, SessionState::open);
  EXPECT_EQ(value_of(store.job(job_id)).state, JobState::running);
  EXPECT_TRUE(store.record_measurement(testing::sample_measurement(first_, 9), testing::sample_fit(9)));
}

// The trail of changes made through the service, as `GET /api/v1/audit` shows its entries but
// oldest first; a change made outside a request (here: no AuditScope) is not in it.
TEST_F(ExportTest, TheAuditTrailIsExportedOldestFirstAsJsonLinesOrCsv) {
  auto store = value_of(Store::open(path_));
  {
    AuditScope scope(Actor{"ana", "127.0.0.1", "POST /api/v1/sessions"});
    value_of(store.create_session(testing::sample_session(0)));
  }
  value_of(store.create_session(testing::sample_session(1)));
  {
    AuditScope scope(Actor{"", "::1", R"(PATCH /api/v1/sessions/1?note="a, b")"});
    value_of(store.create_session(testing::sample_session(2)));
  }
  const auto stored = value_of(store.audit(std::nullopt, 10));
  ASSERT_EQ(stored.size(), 2u);

  const auto json = skinspec({"export", "--db", path_, "--audit"});
  ASSERT_EQ(json.exit_status, 0) << json.describe();
  const auto lines = lines_of(json.out);
  ASSERT_EQ(lines.size(), 2u) << json.out;
  EXPECT_EQ(Json::parse(lines[0]), records::to_json(stored[1]));
  EXPECT_EQ(Json::parse(lines[1]), records::to_json(stored[0]));
  EXPECT_EQ(Json::parse(lines[0])["token"], "ana");
  EXPECT_EQ(Json::parse(lines[0])["change"], "creating a session");
  EXPECT_TRUE(Json::parse(lines[1])["token"].is_null());

  const auto csv = skinspec({"export", "--db", path_, "--audit", "--format", "csv"});
  ASSERT_EQ(csv.exit_status, 0) << csv.describe();
  const auto rows = lines_of(csv.out);
  ASSERT_EQ(rows.size(), 3u) << csv.out;
  EXPECT_EQ(rows[0], "id,at,token,address,request,change");
  const auto last = fields_of(rows[2]);
  ASSERT_EQ(last.size(), 6u) << rows[2];
  EXPECT_EQ(last[0], std::to_string(stored[0].id));
  EXPECT_EQ(last[1], Json::parse(lines[1])["at"].get<std::string>());
  EXPECT_EQ(last[2], "");
  EXPECT_EQ(last[3], "::1");
  EXPECT_EQ(last[4], R"(PATCH /api/v1/sessions/1?note="a, b")");
  EXPECT_EQ(last[5], "creating a session");

  for (const auto& refused : {std::vector<std::string>{"--format", "cgats"}, {"--session", "1"}}) {
    auto args = std::vector<std::string>{"export", "--db", path_, "--audit"};
    args.insert(args.end(), refused.begin(), refused.end());
    const auto result = skinspec(args);
    EXPECT_EQ(result.exit_status, kBadInput) << result.describe();
    EXPECT_THAT(result.out, IsEmpty());
  }
}

TEST_F(ExportTest, AnUnknownSessionIsBadInputWithNothingOnStdout) {
  auto store = make_database();
  for (const char* format : {"json", "csv", "cgats"}) {
    const auto result = skinspec({"export", "--db", path_, "--session", "999", "--format", format});
    EXPECT_EQ(result.exit_status, kBadInput) << result.describe();
    EXPECT_THAT(result.out, IsEmpty());
    EXPECT_THAT(result.err, HasSubstr("session 999 does not exist"));
  }
}

// ---- Files export refuses: exit status 2, a message naming the file, nothing on stdout, and
// the file and its directory exactly as they were (no byte changed, no -wal, -shm or -lock).

// A directory's files and their bytes.
std::map<std::string, std::string> directory_state(const std::filesystem::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& entry : std::filesystem::directory_iterator(dir))
    files[entry.path().filename().string()] = testing::file_bytes(entry.path().string());
  return files;
}

class ExportRefusesTest : public ExportTest {
 protected:
  void expect_refused_untouched(const std::string& path, const std::string& message) {
    const auto before = directory_state(dir_.path());
    for (const char* format : {"json", "csv", "cgats"}) {
      SCOPED_TRACE(format);
      const auto result = skinspec({"export", "--db", path, "--format", format});
      EXPECT_EQ(result.exit_status, kBadInput) << result.describe();
      EXPECT_THAT(result.out, IsEmpty());
      EXPECT_THAT(result.err, HasSubstr(path));
      EXPECT_THAT(result.err, HasSubstr(message));
      EXPECT_TRUE(directory_state(dir_.path()) == before) << "a file changed, or one was added, beside " << path;
    }
  }

  // A closed database of the store's own making, as a lab would keep it.
  void make_closed_database() {
    {
      make_database();
    }
    ASSERT_FALSE(std::filesystem::exists(path_ + "-wal"));
  }

  void overwrite(std::int64_t offset, const std::string& bytes) {
    std::fstream file(path_, std::ios::binary | std::ios::in | std::ios::out);
    file.seekp(static_cast<std::streamoff>(offset));
    file << bytes;
  }
};

TEST_F(ExportRefusesTest, AMissingFile) {
  const auto missing = dir_.file("nothing.db");
  expect_refused_untouched(missing, "no database file");
  EXPECT_FALSE(std::filesystem::exists(missing));
}

TEST_F(ExportRefusesTest, AnEmptyFile) {
  std::ofstream(path_).flush();
  expect_refused_untouched(path_, "an empty file");
}

TEST_F(ExportRefusesTest, ForeignFiles) {
  // One byte: SQLite would read it as an empty database, and a writer would fill it.
  std::ofstream(path_) << "x";
  expect_refused_untouched(path_, "not a SQLite database");
  std::ofstream(path_, std::ios::trunc) << "wavelength_nm,a\n400,0.5\n";
  expect_refused_untouched(path_, "not a SQLite database");
  std::string noise(20000, '\0');
  std::uint32_t state = 12345;
  for (auto& byte : noise) byte = static_cast<char>((state = state * 1103515245u + 12345u) >> 23);
  std::ofstream(path_, std::ios::binary | std::ios::trunc) << noise;
  expect_refused_untouched(path_, "not a SQLite database");
}

TEST_F(ExportRefusesTest, AnotherProgramsSqliteDatabase) {
  testing::sqlite_execute(path_,
                          "PRAGMA journal_mode = WAL; CREATE TABLE photos (id INTEGER PRIMARY KEY, name TEXT);"
                          "INSERT INTO photos VALUES (1, 'cat');");
  expect_refused_untouched(path_, "not a skinspec one");
}

TEST_F(ExportRefusesTest, AnotherProgramsEmptySqliteDatabase) {
  testing::sqlite_execute(path_, "CREATE TABLE t (x); DROP TABLE t;");
  ASSERT_GT(std::filesystem::file_size(path_), 0u);
  expect_refused_untouched(path_, "an empty SQLite database");
}

TEST_F(ExportRefusesTest, ADatabaseWithAPageZeroedInTheMiddle) {
  make_closed_database();
  const auto page_size = testing::sqlite_integer(path_, "PRAGMA page_size");
  const auto pages = testing::sqlite_integer(path_, "PRAGMA page_count");
  ASSERT_GE(pages, 8);
  overwrite(page_size * (pages / 2), std::string(static_cast<std::size_t>(page_size), '\0'));
  expect_refused_untouched(path_, "damaged");
}

TEST_F(ExportRefusesTest, ATruncatedDatabase) {
  make_closed_database();
  std::filesystem::resize_file(path_, std::filesystem::file_size(path_) / 2);
  expect_refused_untouched(path_, "damaged");
}

TEST_F(ExportRefusesTest, ANewerSchema) {
  make_closed_database();
  testing::sqlite_execute(path_, "PRAGMA user_version = " + std::to_string(current_schema_version() + 1));
  expect_refused_untouched(path_, "newer skinspec");
}

// Migrating would write; a command that only reads leaves that to skinspecd.
TEST_F(ExportRefusesTest, AnOlderSchema) {
  ASSERT_TRUE(create_database_at_version(path_, 1));
  testing::sqlite_execute(path_, "INSERT INTO sessions VALUES (1, 'S-9', 'palm', '', '', NULL, 'complete', 0, 0, 0)");
  expect_refused_untouched(path_, "schema version 1 is older");
  EXPECT_EQ(testing::sqlite_integer(path_, "PRAGMA user_version"), 1);
}

TEST_F(ExportRefusesTest, AnUnknownFormat) {
  make_closed_database();
  const auto format = skinspec({"export", "--db", path_, "--format", "xml"});
  EXPECT_EQ(format.exit_status, kBadInput) << format.describe();
  EXPECT_THAT(format.out, IsEmpty());
}

// ---- What export leaves behind when it succeeds: nothing.

TEST_F(ExportTest, AClosedDatabaseIsReadWithoutCreatingAnythingBesideIt) {
  {
    make_database();
  }
  const auto before = directory_state(dir_.path());
  EXPECT_FALSE(before.contains("skinspec.db-wal"));
  const auto result = skinspec({"export", "--db", path_});
  ASSERT_EQ(result.exit_status, 0) << result.describe();
  EXPECT_EQ(lines_of(result.out).size(), 2u);
  EXPECT_TRUE(directory_state(dir_.path()) == before);
}

// A writer in another process, committing all the while: every export is a whole, consistent
// snapshot, and once the writer is killed its committed rows are read from its log as it left it.
TEST_F(ExportTest, ExportsWhileAnotherProcessWritesAndAfterItDied) {
  // A reading every 20 ms: each export reads the whole database, which a writer at full speed
  // makes grow faster than exports under the sanitizers can read it.
  testing::BackgroundProcess writer(SKINSPEC_TEST_BIN_DIR "/store_crash_writer", {path_, "20"});
  ASSERT_TRUE(writer.started()) << writer.start_error();
  ASSERT_TRUE(writer.wait_for_stdout_line("committed 5 ", std::chrono::seconds(30))) << writer.err();
  std::size_t seen = 0;
  for (int round = 0; round < 5; ++round) {
    SCOPED_TRACE(round);
    const auto result = skinspec({"export", "--db", path_});
    ASSERT_EQ(result.exit_status, 0) << result.describe();
    const auto lines = lines_of(result.out);
    ASSERT_EQ(lines.size(), 1u);
    const auto measurements = Json::parse(lines[0])["measurements"];
    EXPECT_GE(measurements.size(), std::max<std::size_t>(seen, 5));
    for (const auto& m : measurements) EXPECT_EQ(m["fits"].size(), 1u) << "a measurement without its fit";
    seen = measurements.size();
  }
  writer.send_signal(SIGKILL);
  writer.wait(std::chrono::seconds(10));
  ASSERT_TRUE(std::filesystem::exists(path_ + "-wal"));
  const auto printed = writer.out();
  const auto reported = std::count(printed.begin(), printed.end(), '\n') - 1;  // less the "session" line
  const auto database = testing::file_bytes(path_), log = testing::file_bytes(path_ + "-wal");
  const auto result = skinspec({"export", "--db", path_, "--format", "csv"});
  ASSERT_EQ(result.exit_status, 0) << result.describe();
  EXPECT_TRUE(testing::file_bytes(path_) == database);
  EXPECT_TRUE(testing::file_bytes(path_ + "-wal") == log);
  // 101 rows per measurement (its fit on the same grid), below the units and the header; the last commit
  // may have landed without being reported.
  const auto stored = testing::sqlite_integer(path_, "SELECT count(*) FROM measurements");
  EXPECT_GE(stored, reported);
  EXPECT_EQ(static_cast<long long>(lines_of(result.out).size()), 2 + 101 * stored);
}

TEST_F(ExportTest, TheCommandIsListedWhenAnotherIsMistyped) {
  const auto result = skinspec({"exprot"});
  EXPECT_EQ(result.exit_status, kBadInput);
  EXPECT_THAT(result.err, HasSubstr("export"));
}

}  // namespace
}  // namespace skinspec
