// Opening databases made by earlier versions (every one of them), and files the store must
// refuse without changing a byte: a newer schema, not SQLite, not skinspec's, damaged,
// read-only. A full disk fails a write whole.

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <vector>

#include <nlohmann/json.hpp>

#include "skinspec/store/store.hpp"
#include "skinspec/testkit/store_samples.hpp"

namespace skinspec {
namespace {

using namespace skinspec::store;
using ::testing::HasSubstr;
using Kind = StoreError::Kind;

template <typename T>
T value_of(Result<T> result) {
  if (!result) throw std::runtime_error(result.error().message);
  return std::move(*result);
}

// Rows as a skinspec of each earlier schema version wrote them, by hand, with the spectra in
// their documented encoding: 400 nm -> 0.5, 700 nm -> 0.25 (little-endian float64 pairs).
// `job_column` is what a version >= 2 adds at the end of a measurement row.
std::string rows_written_by_version(const std::string& job_column) {
  return R"sql(
INSERT INTO instruments VALUES (1, 'PR-650', '60950', '', 'serial:/dev/ttyUSB0', 1700000000000000, 1700000000000000);
INSERT INTO white_standards VALUES (1, 'Spectralon', 'cert 7',
  X'0000000000007940000000000000E03F0000000000E08540000000000000D03F', 1700000000000001);
INSERT INTO sessions VALUES (1, 'S-1', 'forearm', 'op', 'first', 1, 'open', 1700000000000002, 1700000000000002, NULL);
INSERT INTO measurements VALUES (1, 1, 'white', 'w', 1, NULL, 0, 0, 'OK', 'W/(sr m2 nm)', '{}', 1,
  X'0000000000007940000000000000E03F0000000000E08540000000000000D03F', NULL, NULL, '[]', X'303030302C300D0A',
  1700000000000003, 1700000000000004, 1700000000000005)sql" +
         job_column + R"sql();
INSERT INTO measurements VALUES (2, 1, 'sample', 's', 1, 1, 1, 0, 'OK', 'W/(sr m2 nm)', '{"averages":2}', 2,
  X'0000000000007940000000000000E03F0000000000E08540000000000000D03F', NULL,
  X'0000000000007940000000000000E03F0000000000E08540000000000000D03F', '["old white"]', X'00FF',
  1700000000000006, 1700000000000007, 1700000000000008)sql" +
         job_column + R"sql();
INSERT INTO fits VALUES (1, 2, 'forearm', 0.1, 7, 3, 2, 1, 0.01, 0.2, 0.3, 0.2, NULL, 0.012, 0.03, 0.9, 14, 1,
  'converged', '{"site":"forearm"}', 'skinspec 0.1.0', 'abc123',
  X'0000000000007940000000000000E03F0000000000E08540000000000000D03F',
  X'0000000000007940000000000000E03F0000000000E08540000000000000D03F', 0, 1700000000000009);
)sql";
}

// Version 2 had jobs; a finished one that produced nothing stored.
const std::string kVersion2Job = R"sql(
INSERT INTO jobs VALUES (1, 'measure', '{"kind":"sample"}', '', 1, 'k-1', 'failed', 'bad_reading: quality 19', '{}',
  1700000000000010, 1700000000000011, 1700000000000012);
)sql";

// Jobs as versions 2 and 3 ended them, their errors free text; job 9 left failed by a writer
// that died after storing its measurement (3) and fit (2) but before storing the job's end.
const std::string kVersion3Jobs = R"sql(
INSERT INTO jobs VALUES (2, 'measure', '{}', '', 1, NULL, 'cancelled', 'cancelled by request', '{}', 1, 2, 3);
INSERT INTO jobs VALUES (3, 'measure', '{}', '', 1, NULL, 'cancelled', 'the service stopped', '{}', 1, NULL, 3);
INSERT INTO jobs VALUES (4, 'measure', '{}', '', 1, NULL, 'failed',
  'no_white_reference: measure the white standard of session 1 first', '{}', 1, 2, 3);
INSERT INTO jobs VALUES (5, 'measure', '{}', '', 1, NULL, 'failed', 'database: disk I/O error', '{}', 1, 2, 3);
INSERT INTO jobs VALUES (6, 'measure', '{}', '', 1, NULL, 'failed', 'the meter caught fire', '{}', 1, 2, 3);
INSERT INTO jobs VALUES (7, 'measure', '{}', '', 1, NULL, 'failed', '', '{}', 1, 2, 3);
INSERT INTO jobs VALUES (8, 'measure', '{}', '', 1, NULL, 'succeeded', '', '{"measurement_id":2}', 1, 2, 3);
INSERT INTO jobs VALUES (9, 'measure', '{"kind":"sample"}', '', 1, NULL, 'failed',
  'interrupted: the program running it stopped before it finished', '{}', 1, 2, 1700000000000020);
INSERT INTO measurements VALUES (3, 1, 'sample', 's', 1, 1, 1, 0, 'OK', 'W/(sr m2 nm)', '{}', 1,
  X'0000000000007940000000000000E03F0000000000E08540000000000000D03F', NULL,
  X'0000000000007940000000000000E03F0000000000E08540000000000000D03F', '["white_stale: old"]', X'00',
  1700000000000016, 1700000000000017, 1700000000000018, 9);
INSERT INTO fits VALUES (2, 3, 'forearm', 0.1, 7, 3, 2, 1, 0.01, 0.2, 0.3, 0.2, NULL, 0.012, 0.03, 0.9, 14, 1,
  'converged', '{"site":"forearm"}', 'skinspec 0.1.0', 'abc123',
  X'0000000000007940000000000000E03F0000000000E08540000000000000D03F',
  X'0000000000007940000000000000E03F0000000000E08540000000000000D03F', 0, 1700000000000019);
)sql";

// Version 4's jobs: the error a JSON object, in the last column.
const std::string kVersion4Job = R"sql(
INSERT INTO jobs VALUES (1, 'measure', '{"kind":"sample"}', '', 1, 'k-1', 'failed', '{}', 1700000000000010,
  1700000000000011, 1700000000000012, '{"code":"bad_reading","message":"quality 19"}');
)sql";

// Version 5's rows: sessions with their model, fits with their parameters by name as JSON.
const std::string kVersion5Rows = R"sql(
INSERT INTO instruments VALUES (1, 'PR-650', '60950', '', 'serial:/dev/ttyUSB0', 1700000000000000, 1700000000000000);
INSERT INTO white_standards VALUES (1, 'Spectralon', 'cert 7',
  X'0000000000007940000000000000E03F0000000000E08540000000000000D03F', 1700000000000001);
INSERT INTO sessions VALUES (1, 'S-1', 'forearm', 'op', 'first', 1, 'open', 1700000000000002, 1700000000000002, NULL,
  'paper');
INSERT INTO measurements VALUES (1, 1, 'white', 'w', 1, NULL, 0, 0, 'OK', 'W/(sr m2 nm)', '{}', 1,
  X'0000000000007940000000000000E03F0000000000E08540000000000000D03F', NULL, NULL, '[]', X'303030302C300D0A',
  1700000000000003, 1700000000000004, 1700000000000005, NULL);
INSERT INTO measurements VALUES (2, 1, 'sample', 's', 1, 1, 1, 0, 'OK', 'W/(sr m2 nm)', '{"averages":2}', 2,
  X'0000000000007940000000000000E03F0000000000E08540000000000000D03F', NULL,
  X'0000000000007940000000000000E03F0000000000E08540000000000000D03F', '["old white"]', X'00FF',
  1700000000000006, 1700000000000007, 1700000000000008, NULL);
INSERT INTO fits VALUES (1, 2, 'forearm', 'paper',
  '[{"name":"surface_reflectance","value":0.1,"standard_error":0.01},{"name":"melanin","value":7,"standard_error":0.2},
    {"name":"oxyhemoglobin","value":3,"standard_error":0.3},{"name":"deoxyhemoglobin","value":2,"standard_error":0.2},
    {"name":"bilirubin","value":1,"standard_error":null}]',
  '{}', 0.012, 0.03, 0.9, 14, 1, 'converged', '{"site":"forearm"}', 'skinspec 0.1.0', 'abc123', '',
  X'0000000000007940000000000000E03F0000000000E08540000000000000D03F',
  X'0000000000007940000000000000E03F0000000000E08540000000000000D03F', 0, 1700000000000009);
)sql";

// Version 6's: the same with each session's and job's bench ('' as the rows above were written
// before benches, which the checks below expect) and a bench that stopped.
std::string rows_with_benches(std::string rows) {
  for (const std::string row_end : {"'paper');", "quality 19\"}');"}) {
    const auto at = rows.find(row_end);
    if (at == std::string::npos) throw std::logic_error("no row ending " + row_end);
    rows.insert(at + row_end.size() - 2, ", ''");
  }
  return rows +
         "INSERT INTO benches VALUES ('bench-a', 'pc-1', 4321, 1700000000000020, 1700000000000021, 15000, "
         "'{\"model\":\"pr650\"}', 1700000000000022);\n";
}

const std::map<int, std::string> kRowsAtVersion = {
    {1, rows_written_by_version("")},
    {2, rows_written_by_version(", NULL") + kVersion2Job},
    {3, rows_written_by_version(", NULL") + kVersion2Job + kVersion3Jobs},
    {4, rows_written_by_version(", NULL") + kVersion4Job},
    {5, kVersion5Rows + kVersion4Job},
    {6, rows_with_benches(kVersion5Rows + kVersion4Job)},
    {7, rows_with_benches(kVersion5Rows + kVersion4Job)},   // 7 changed nothing in a SQLite file
    {8, rows_with_benches(kVersion5Rows + kVersion4Job)},   // 8 only admitted imported measurements
    {9, rows_with_benches(kVersion5Rows + kVersion4Job)},   // 9 added maps, none of which these rows hold
    {10, rows_with_benches(kVersion5Rows + kVersion4Job)},  // 10 added the audit trail, a new table
};

// What every version's rows must read back as under the current schema.
void expect_rows_of_earlier_version(Store& store) {
  const SpectralSamples spectrum{{400, 700}, {0.5, 0.25}};
  const auto white = value_of(store.white_standard(1));
  EXPECT_EQ(white.reflectance, spectrum);
  EXPECT_EQ(white.certificate, "cert 7");
  const auto detail = value_of(store.session_detail(1));
  EXPECT_EQ(detail.session.notes, "first");
  EXPECT_EQ(detail.session.white_standard_id, 1);
  EXPECT_EQ(detail.session.bench, "") << "opened before benches: any bench's";
  ASSERT_GE(detail.measurements.size(), 2u);  // and what the test added since
  const auto& sample = detail.measurements[1];
  EXPECT_EQ(sample.kind, MeasurementKind::sample);
  EXPECT_EQ(sample.white_measurement_id, 1);
  EXPECT_EQ(sample.reflectance, spectrum);
  EXPECT_TRUE(sample.radiance_sd.empty());
  EXPECT_EQ(sample.raw_reply, std::string("\x00\xff", 2));
  EXPECT_EQ(sample.warnings, std::vector<std::string>{"old white"});
  EXPECT_FALSE(sample.job_id);
  EXPECT_EQ(sample.finished_at, Time(std::chrono::microseconds(1700000000000007)));
  ASSERT_GE(detail.fits.size(), 1u);
  // Fits before version 5 are the paper model's: its five parameters by name, a standard error
  // stored as NULL read as one the fit could not bound, and nothing judged.
  EXPECT_EQ(detail.session.model, "paper");
  const auto& fit = detail.fits[0];
  EXPECT_EQ(fit.model, "paper");
  EXPECT_EQ(fit.params, (std::vector<FitParam>{{"surface_reflectance", 0.1, 0.01},
                                               {"melanin", 7, 0.2},
                                               {"oxyhemoglobin", 3, 0.3},
                                               {"deoxyhemoglobin", 2, 0.2},
                                               {"bilirubin", 1, std::numeric_limits<double>::infinity()}}));
  EXPECT_EQ(fit.assessment, "{}");
  EXPECT_EQ(fit.constants_digest, "");
  EXPECT_EQ(detail.fits[0].tables_digest, "abc123");
  EXPECT_EQ(detail.fits[0].measured, std::vector<double>({0.5, 0.25}));
}

// What the jobs of versions 2 and 3 read back as: free text became {code, message}.
void expect_jobs_of_earlier_version(Store& store, int version) {
  if (version < 2) return;
  const auto job = value_of(store.job(1));
  EXPECT_EQ(job.state, JobState::failed);
  EXPECT_EQ(job.error, (JobError{JobErrorCode::bad_reading, "quality 19"}));
  EXPECT_EQ(job.idempotency_key, "k-1");
  EXPECT_EQ(job.bench, "");
}

class StoreMigrationTest : public ::testing::Test {
 protected:
  testing::ScratchDirectory dir_;
  std::string path_ = dir_.file("skinspec.db");
};

TEST_F(StoreMigrationTest, EveryEarlierVersionOpensWithItsRowsIntact) {
  for (int version = 1; version < current_schema_version(); ++version) {
    SCOPED_TRACE("from schema version " + std::to_string(version));
    const auto path = dir_.file("v" + std::to_string(version) + ".db");
    ASSERT_TRUE(create_database_at_version(path, version));
    ASSERT_EQ(testing::sqlite_integer(path, "PRAGMA user_version"), version);
    ASSERT_TRUE(kRowsAtVersion.contains(version)) << "add the rows a version-" << version << " database holds";
    testing::sqlite_execute(path, kRowsAtVersion.at(version));

    {
      auto store = value_of(Store::open(path));
      EXPECT_EQ(store.schema_version(), current_schema_version());
      expect_rows_of_earlier_version(store);
      expect_jobs_of_earlier_version(store, version);
      // What the newer versions added works on the old rows.
      Job job;
      job.kind = "measure";
      job.session_id = 1;
      const auto created = value_of(store.create_job(job));
      value_of(store.update_job(created.job.id, {.state = JobState::running}));
      auto m = testing::sample_measurement(1, 1);
      m.white_measurement_id = 1;
      const auto ids = value_of(store.complete_measurement_job(created.job.id, m, testing::sample_fit(1), "{}")).ids;
      EXPECT_EQ(value_of(store.measurement(ids.measurement_id)).job_id, created.job.id);
      auto imported = testing::sample_measurement(1, 2);
      imported.kind = MeasurementKind::imported;
      imported.radiance = {};
      imported.radiance_sd = {};
      const auto imported_id = value_of(store.record_measurement(imported, std::nullopt)).measurement_id;
      EXPECT_EQ(value_of(store.measurement(imported_id)).kind, MeasurementKind::imported);
      EXPECT_EQ(value_of(store.sessions({.site = "forearm"})).sessions.size(), 1u);
      RejectedReading rejected;
      rejected.session_id = 1;
      rejected.job_id = created.job.id;
      rejected.instrument_id = 1;
      rejected.quality_code = 19;
      rejected.raw_reply = std::string("19,0\r\n\x00", 7);
      const auto rejected_id = value_of(store.record_rejected_reading(rejected));
      EXPECT_EQ(value_of(store.rejected_reading(rejected_id)).raw_reply, rejected.raw_reply);
      EXPECT_EQ(value_of(store.session_detail(1)).rejected_readings.size(), 1u);
      const Id map = testing::store_sample_map(store, 1, "arm", testing::sample_map_bytes(1000, 1));
      EXPECT_EQ(value_of(store.map(map)).session_id, 1);
    }
    EXPECT_EQ(testing::sqlite_integer(path, "PRAGMA user_version"), current_schema_version());
    EXPECT_EQ(testing::sqlite_text(path, "PRAGMA integrity_check"), "ok");
    EXPECT_EQ(testing::sqlite_text(path, "PRAGMA foreign_key_check"), "");
    // Opening again migrates nothing and changes nothing.
    auto again = value_of(Store::open(path));
    expect_rows_of_earlier_version(again);
    expect_jobs_of_earlier_version(again, version);
  }
}

TEST_F(StoreMigrationTest, VersionThreeJobErrorsBecomeCodesAndMessages) {
  ASSERT_TRUE(create_database_at_version(path_, 3));
  testing::sqlite_execute(path_, kRowsAtVersion.at(3));
  auto store = value_of(Store::open(path_));
  const auto error_of = [&](Id id) { return value_of(store.job(id)).error; };
  EXPECT_EQ(error_of(2), (JobError{JobErrorCode::cancelled, "cancelled by request"}));
  EXPECT_EQ(error_of(3), (JobError{JobErrorCode::stopped, "the service stopped"}));
  EXPECT_EQ(error_of(4), (JobError{JobErrorCode::no_white, "measure the white standard of session 1 first"}));
  EXPECT_EQ(error_of(5), (JobError{JobErrorCode::store, "disk I/O error"}));
  EXPECT_EQ(error_of(6), (JobError{JobErrorCode::internal, "the meter caught fire"}));
  EXPECT_EQ(error_of(7), (JobError{JobErrorCode::internal, "no reason was recorded"}));
  EXPECT_FALSE(error_of(8));
  EXPECT_EQ(value_of(store.job(8)).result, R"({"measurement_id":2})");
  EXPECT_EQ(
      testing::sqlite_integer(path_, "SELECT count(*) FROM jobs WHERE error IS NOT NULL AND NOT json_valid(error)"), 0);
  EXPECT_THAT(testing::sqlite_text(path_, "SELECT sql FROM sqlite_schema WHERE name = 'jobs'"),
              HasSubstr("json_valid(error)"));
}

// A job whose measurement a version-3 writer stored before dying ends succeeded and names it:
// every stored measurement's job has succeeded with its ids.
TEST_F(StoreMigrationTest, AVersionThreeJobLeftFailedWithItsMeasurementStoredSucceeds) {
  ASSERT_TRUE(create_database_at_version(path_, 3));
  testing::sqlite_execute(path_, kRowsAtVersion.at(3));
  auto store = value_of(Store::open(path_));
  const auto job = value_of(store.job(9));
  EXPECT_EQ(job.state, JobState::succeeded);
  EXPECT_FALSE(job.error);
  EXPECT_EQ(job.finished_at, Time(std::chrono::microseconds(1700000000000020)));
  const auto result = nlohmann::json::parse(job.result);
  EXPECT_EQ(result["measurement_id"], 3);
  EXPECT_EQ(result["fit_id"], 2);
  EXPECT_EQ(result["white_measurement_id"], 1);
  EXPECT_EQ(result["readings"], 1);
  EXPECT_EQ(result["warnings"], nlohmann::json::array({"white_stale: old"}));
  EXPECT_EQ(result["recovered"], true);
  EXPECT_EQ(
      testing::sqlite_integer(path_,
                              "SELECT count(*) FROM measurements m JOIN jobs j ON j.id = m.job_id "
                              "WHERE j.state <> 'succeeded' OR json_extract(j.result, '$.measurement_id') <> m.id"),
      0);
  EXPECT_EQ(value_of(store.job(1)).state, JobState::failed);  // nothing stored: stays failed
}

TEST_F(StoreMigrationTest, AnEmptyFileBecomesACurrentDatabase) {
  std::ofstream(path_).close();
  auto store = value_of(Store::open(path_));
  EXPECT_EQ(store.schema_version(), current_schema_version());
  EXPECT_TRUE(value_of(store.instruments()).empty());
}

TEST_F(StoreMigrationTest, TheCurrentVersionBuiltStepByStepMatchesANewDatabase) {
  const auto stepwise = dir_.file("stepwise.db");
  ASSERT_TRUE(create_database_at_version(stepwise, 1));
  {
    value_of(Store::open(stepwise));
  }
  {
    value_of(Store::open(path_));
  }
  const std::string schema =
      "SELECT group_concat(type || ' ' || name || ' ' || coalesce(sql, ''), char(10)) "
      "FROM (SELECT * FROM sqlite_schema ORDER BY name)";
  EXPECT_EQ(testing::sqlite_text(stepwise, schema), testing::sqlite_text(path_, schema));
}

// Each migration is one transaction: one that fails leaves the database at the version before.
TEST_F(StoreMigrationTest, AFailedMigrationLeavesThePreviousVersionWhole) {
  ASSERT_TRUE(create_database_at_version(path_, 1));
  testing::sqlite_execute(path_, kRowsAtVersion.at(1) + "CREATE TABLE jobs (x);");
  const auto opened = Store::open(path_);
  ASSERT_FALSE(opened);
  EXPECT_THAT(opened.error().message, HasSubstr("jobs"));
  EXPECT_EQ(testing::sqlite_integer(path_, "PRAGMA user_version"), 1);
  EXPECT_EQ(testing::sqlite_integer(path_, "SELECT count(*) FROM sqlite_schema WHERE name = 'sessions_by_site'"), 0);
  EXPECT_EQ(testing::sqlite_integer(path_,
                                    "SELECT count(*) FROM pragma_table_info('measurements') "
                                    "WHERE name = 'job_id'"),
            0);
  EXPECT_EQ(testing::sqlite_integer(path_, "SELECT count(*) FROM measurements"), 2);
}

// Version 8 edits the text of the measurements' kind check in place: a table whose check is not
// the one version 7 left is not edited blindly, and the file stays at version 7.
TEST_F(StoreMigrationTest, AKindCheckOtherThanVersion7sIsNotEditedBlindly) {
  ASSERT_TRUE(create_database_at_version(path_, 7));
  testing::sqlite_execute(path_,
                          "PRAGMA writable_schema = ON; UPDATE sqlite_schema SET sql = replace(sql, "
                          "'''dark''))', '''dark'', ''reference''))') WHERE name = 'measurements'; "
                          "PRAGMA writable_schema = OFF;");
  const auto opened = Store::open(path_);
  ASSERT_FALSE(opened);
  EXPECT_EQ(opened.error().kind, Kind::corrupt);
  EXPECT_THAT(opened.error().message, HasSubstr("kind check"));
  EXPECT_EQ(testing::sqlite_integer(path_, "PRAGMA user_version"), 7);
}

TEST_F(StoreMigrationTest, CreatingAtAVersionChecksItsArguments) {
  EXPECT_EQ(create_database_at_version(path_, 0).error().kind, Kind::invalid_argument);
  EXPECT_EQ(create_database_at_version(path_, current_schema_version() + 1).error().kind, Kind::invalid_argument);
  ASSERT_TRUE(create_database_at_version(path_, 1));
  EXPECT_EQ(create_database_at_version(path_, 1).error().kind, Kind::conflict);
}

// ---- Files the store refuses ----

class StoreBadInputTest : public StoreMigrationTest {
 protected:
  // A current database holding one session with a measurement and its fit, closed.
  void make_database(const std::string& path) {
    auto store = value_of(Store::open(path));
    const Id session = value_of(store.create_session(testing::sample_session(1)));
    for (int n = 0; n < 20; ++n)
      value_of(store.record_measurement(testing::sample_measurement(session, n), testing::sample_fit(n)));
  }

  // Opens `path` read-write and read-only, expecting `kind` both times, no change to it and
  // nothing created beside it (no -wal, -shm or -lock).
  void expect_refused_unchanged(const std::string& path, Kind kind, const std::string& message) {
    const auto before = testing::file_bytes(path);
    const auto files = files_beside(path);
    for (const bool read_only : {false, true}) {
      SCOPED_TRACE(read_only ? "read-only" : "read-write");
      OpenOptions options;
      options.mode = read_only ? OpenMode::read_only : OpenMode::read_write;
      const auto opened = Store::open(path, options);
      ASSERT_FALSE(opened);
      EXPECT_EQ(opened.error().kind, kind) << opened.error().message;
      EXPECT_THAT(opened.error().message, HasSubstr(message));
      EXPECT_THAT(opened.error().message, HasSubstr(path));
      EXPECT_EQ(testing::file_bytes(path), before) << "the file changed";
      EXPECT_EQ(files_beside(path), files);
    }
  }

  static std::vector<std::string> files_beside(const std::string& path) {
    std::vector<std::string> names;
    for (const auto& entry : std::filesystem::directory_iterator(std::filesystem::path(path).parent_path()))
      names.push_back(entry.path().filename().string());
    std::ranges::sort(names);
    return names;
  }
};

TEST_F(StoreBadInputTest, ANewerSchemaIsRefusedAndLeftUnchanged) {
  make_database(path_);
  testing::sqlite_execute(path_, "PRAGMA user_version = " + std::to_string(current_schema_version() + 1));
  expect_refused_unchanged(path_, Kind::newer_schema, "written by a newer skinspec");
  EXPECT_EQ(testing::sqlite_integer(path_, "PRAGMA user_version"), current_schema_version() + 1);
}

TEST_F(StoreBadInputTest, AFileThatIsNotSqliteIsRefused) {
  std::ofstream(path_) << "wavelength_nm,forearm\n400,0.3\n";
  expect_refused_unchanged(path_, Kind::corrupt, "not a SQLite database");
  std::string noise(8192, '\0');
  for (std::size_t i = 0; i < noise.size(); ++i) noise[i] = static_cast<char>((i * 2654435761u) >> 13);
  std::ofstream(path_, std::ios::binary | std::ios::trunc) << noise;
  expect_refused_unchanged(path_, Kind::corrupt, "not a SQLite database");
}

TEST_F(StoreBadInputTest, AnotherProgramsSqliteDatabaseIsRefused) {
  testing::sqlite_execute(path_, "CREATE TABLE photos (id INTEGER PRIMARY KEY, name TEXT); PRAGMA user_version = 3;");
  expect_refused_unchanged(path_, Kind::corrupt, "not a skinspec one");
  // In WAL mode, where a plain read-only SQLite connection would leave a -wal and -shm behind.
  const auto wal = dir_.file("wal.db");
  testing::sqlite_execute(wal, "PRAGMA journal_mode = WAL; CREATE TABLE photos (id INTEGER PRIMARY KEY);");
  expect_refused_unchanged(wal, Kind::corrupt, "not a skinspec one");
}

// SQLite reads a file shorter than its header as an empty database; a writer would fill it.
TEST_F(StoreBadInputTest, AFileShorterThanTheHeaderIsRefused) {
  for (const std::string bytes : {"x", "SQLite format"}) {
    SCOPED_TRACE(bytes);
    std::ofstream(path_, std::ios::trunc) << bytes;
    expect_refused_unchanged(path_, Kind::corrupt, "not a SQLite database");
  }
}

TEST_F(StoreBadInputTest, ADamagedDatabaseIsRefused) {
  make_database(path_);
  const auto page_size = testing::sqlite_integer(path_, "PRAGMA page_size");
  const auto pages = testing::sqlite_integer(path_, "PRAGMA page_count");
  ASSERT_GT(pages, 8);
  {
    // Garbage over a page in the middle of the file, where the tables' rows are.
    std::fstream file(path_, std::ios::binary | std::ios::in | std::ios::out);
    file.seekp(static_cast<std::streamoff>(page_size * (pages / 2)));
    file << std::string(static_cast<std::size_t>(page_size), '\x5a');
  }
  expect_refused_unchanged(path_, Kind::corrupt, "damaged");

  // A damaged header: no longer recognisable as SQLite.
  make_database(dir_.file("second.db"));
  {
    std::fstream file(dir_.file("second.db"), std::ios::binary | std::ios::in | std::ios::out);
    file << "not SQLite at all";
  }
  expect_refused_unchanged(dir_.file("second.db"), Kind::corrupt, "not a SQLite database");
}

TEST_F(StoreBadInputTest, AReadOnlyFileIsNotWrittenButCanBeRead) {
  make_database(path_);
  const auto copy = dir_.file("read-only.db");
  std::filesystem::copy_file(path_, copy);
  ASSERT_EQ(::chmod(copy.c_str(), 0444), 0);
  const auto before = testing::file_bytes(copy);

  const auto opened = Store::open(copy);
  ASSERT_FALSE(opened);
  EXPECT_EQ(opened.error().kind, Kind::read_only);
  EXPECT_THAT(opened.error().message, HasSubstr("read-only"));
  EXPECT_EQ(testing::file_bytes(copy), before);

  {
    OpenOptions read_only;
    read_only.mode = OpenMode::read_only;
    auto reader = value_of(Store::open(copy, read_only));
    EXPECT_EQ(value_of(reader.session_detail(1)).measurements.size(), 20u);
    const auto refused = reader.record_measurement(testing::sample_measurement(1, 99), testing::sample_fit(99));
    ASSERT_FALSE(refused);
    EXPECT_EQ(refused.error().kind, Kind::read_only);
  }
  EXPECT_EQ(testing::sqlite_integer(copy, "SELECT count(*) FROM measurements"), 20);
  EXPECT_EQ(testing::file_bytes(copy), before);
}

// The size cap stands in for a full disk: SQLite fails the same way (SQLITE_FULL) at the page
// it cannot add. Whichever row that falls in, none of that transaction's rows remain.
TEST_F(StoreBadInputTest, AFullDiskFailsTheWholeMeasurementAndFit) {
  int failed_at_the_fit = 0;
  for (int extra_pages = 0; extra_pages < 6; ++extra_pages) {
    SCOPED_TRACE("cap " + std::to_string(extra_pages) + " pages past the empty database");
    const auto path = dir_.file("full-" + std::to_string(extra_pages) + ".db");
    {
      value_of(Store::open(path));
    }
    const auto empty_pages = testing::sqlite_integer(path, "PRAGMA page_count");
    OpenOptions options;
    options.max_pages = empty_pages + 12 + extra_pages;
    auto store = value_of(Store::open(path, options));
    const Id session = value_of(store.create_session(testing::sample_session(1)));

    int stored = 0;
    StoreError error;
    Measurement refused;
    for (int n = 0; n < 200; ++n) {
      auto m = testing::sample_measurement(session, n);
      m.raw_reply += std::string(static_cast<std::size_t>(1000 * (n % 4)), 'r');  // vary where the cap falls
      const auto recorded = store.record_measurement(m, testing::sample_fit(n));
      if (!recorded) {
        error = recorded.error();
        refused = m;
        break;
      }
      ++stored;
    }
    ASSERT_GT(stored, 0);
    EXPECT_EQ(error.kind, Kind::full) << error.message;
    EXPECT_THAT(error.message, HasSubstr("full"));
    EXPECT_THAT(error.message, HasSubstr("recording a measurement"));

    // Still usable: reads work, and a small write that fits still succeeds.
    const auto detail = value_of(store.session_detail(session));
    EXPECT_EQ(detail.measurements.size(), static_cast<std::size_t>(stored));
    EXPECT_EQ(detail.fits.size(), static_cast<std::size_t>(stored));
    EXPECT_EQ(testing::sqlite_integer(path, "SELECT count(*) FROM measurements"), stored);
    EXPECT_EQ(testing::sqlite_integer(path, "SELECT count(*) FROM fits"), stored);
    EXPECT_EQ(
        testing::sqlite_integer(path,
                                "SELECT count(*) FROM measurements m WHERE NOT EXISTS (SELECT 1 FROM fits f WHERE "
                                "f.measurement_id = m.id)"),
        0);
    EXPECT_EQ(testing::sqlite_text(path, "PRAGMA integrity_check"), "ok");

    // When the measurement alone still fits, it was the fit's row that failed, after the
    // measurement's had been written: and that row is gone too.
    if (store.record_measurement(refused, std::nullopt)) ++failed_at_the_fit;
  }
  EXPECT_GT(failed_at_the_fit, 0) << "no cap fell inside a fit; vary the sizes";
}

}  // namespace
}  // namespace skinspec
