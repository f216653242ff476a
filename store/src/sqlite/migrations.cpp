// The SQLite dialect of each schema version (schema.cpp binds them into the one list).

#include "sqlite/migrations.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <tuple>
#include <utility>
#include <vector>

namespace skinspec::store::sqlite {

namespace {

// Version 1: the core tables. Times are integer microseconds since the Unix epoch (UTC);
// spectra are BLOBs of float64 (wavelength, value) pairs (codec.hpp).
constexpr std::string_view kVersion1Sql = R"sql(
PRAGMA application_id = 1397445456;

CREATE TABLE instruments (
  id                     INTEGER PRIMARY KEY,
  model                  TEXT NOT NULL,
  serial_number          TEXT NOT NULL,
  spectral_configuration TEXT NOT NULL,
  connection             TEXT NOT NULL,
  created_at             INTEGER NOT NULL,
  last_seen_at           INTEGER NOT NULL,
  UNIQUE (model, serial_number)
);

CREATE TABLE white_standards (
  id          INTEGER PRIMARY KEY,
  name        TEXT NOT NULL,
  certificate TEXT NOT NULL,
  reflectance BLOB NOT NULL,
  created_at  INTEGER NOT NULL
);

CREATE TABLE sessions (
  id                INTEGER PRIMARY KEY,
  subject           TEXT NOT NULL,
  site              TEXT NOT NULL,
  operator_name     TEXT NOT NULL,
  notes             TEXT NOT NULL,
  white_standard_id INTEGER REFERENCES white_standards (id),
  state             TEXT NOT NULL CHECK (state IN ('open', 'complete', 'interrupted', 'aborted')),
  created_at        INTEGER NOT NULL,
  updated_at        INTEGER NOT NULL,
  ended_at          INTEGER
);
CREATE INDEX sessions_by_created ON sessions (created_at);

CREATE TABLE measurements (
  id                   INTEGER PRIMARY KEY,
  session_id           INTEGER NOT NULL REFERENCES sessions (id),
  kind                 TEXT NOT NULL CHECK (kind IN ('white', 'sample', 'dark')),
  label                TEXT NOT NULL,
  instrument_id        INTEGER REFERENCES instruments (id),
  white_measurement_id INTEGER REFERENCES measurements (id),
  simulated            INTEGER NOT NULL CHECK (simulated IN (0, 1)),
  quality_code         INTEGER NOT NULL,
  quality              TEXT NOT NULL,
  units                TEXT NOT NULL,
  settings             TEXT NOT NULL CHECK (json_valid(settings)),
  reading_count        INTEGER NOT NULL CHECK (reading_count >= 1),
  radiance             BLOB NOT NULL,
  radiance_sd          BLOB,
  reflectance          BLOB,
  warnings             TEXT NOT NULL CHECK (json_valid(warnings)),
  raw_reply            BLOB NOT NULL,
  started_at           INTEGER NOT NULL,
  finished_at          INTEGER NOT NULL,
  created_at           INTEGER NOT NULL
);
CREATE INDEX measurements_by_session ON measurements (session_id);

CREATE TABLE fits (
  id                     INTEGER PRIMARY KEY,
  measurement_id         INTEGER NOT NULL REFERENCES measurements (id),
  site                   TEXT NOT NULL,
  surface_reflectance    REAL NOT NULL,
  melanin                REAL NOT NULL,
  oxyhemoglobin          REAL NOT NULL,
  deoxyhemoglobin        REAL NOT NULL,
  bilirubin              REAL NOT NULL,
  se_surface_reflectance REAL,
  se_melanin             REAL,
  se_oxyhemoglobin       REAL,
  se_deoxyhemoglobin     REAL,
  se_bilirubin           REAL,
  rmse                   REAL NOT NULL,
  max_abs_error          REAL NOT NULL,
  delta_e00_d65          REAL NOT NULL,
  iterations             INTEGER NOT NULL,
  converged              INTEGER NOT NULL CHECK (converged IN (0, 1)),
  solver_summary         TEXT NOT NULL,
  options                TEXT NOT NULL CHECK (json_valid(options)),
  model_version          TEXT NOT NULL,
  tables_digest          TEXT NOT NULL,
  measured               BLOB NOT NULL,
  fitted                 BLOB NOT NULL,
  samples_ignored        INTEGER NOT NULL,
  created_at             INTEGER NOT NULL
);
CREATE INDEX fits_by_measurement ON fits (measurement_id);
)sql";

// Version 2: jobs (what was asked of the service, by whom, and how it ended), the job behind
// each measurement, and the indexes for listing sessions by site and state.
constexpr std::string_view kVersion2Sql = R"sql(
CREATE TABLE jobs (
  id              INTEGER PRIMARY KEY,
  kind            TEXT NOT NULL,
  request         TEXT NOT NULL CHECK (json_valid(request)),
  requested_by    TEXT NOT NULL,
  session_id      INTEGER REFERENCES sessions (id),
  idempotency_key TEXT UNIQUE,
  state           TEXT NOT NULL CHECK (state IN ('queued', 'running', 'succeeded', 'failed', 'cancelled')),
  error           TEXT NOT NULL,
  result          TEXT NOT NULL CHECK (json_valid(result)),
  created_at      INTEGER NOT NULL,
  started_at      INTEGER,
  finished_at     INTEGER
);
CREATE INDEX jobs_by_session ON jobs (session_id);
CREATE INDEX jobs_active ON jobs (state) WHERE state IN ('queued', 'running');

ALTER TABLE measurements ADD COLUMN job_id INTEGER REFERENCES jobs (id);

CREATE INDEX sessions_by_site ON sessions (site, id);
CREATE INDEX sessions_by_state ON sessions (state, id);
)sql";

// Version 3: readings the meter returned with a bad quality code, with their raw reply bytes,
// kept apart from measurements so that nothing averages or fits them by mistake.
constexpr std::string_view kVersion3Sql = R"sql(
CREATE TABLE rejected_readings (
  id            INTEGER PRIMARY KEY,
  session_id    INTEGER NOT NULL REFERENCES sessions (id),
  job_id        INTEGER REFERENCES jobs (id),
  instrument_id INTEGER REFERENCES instruments (id),
  attempt       INTEGER NOT NULL CHECK (attempt >= 1),
  quality_code  INTEGER NOT NULL,
  quality       TEXT NOT NULL,
  reason        TEXT NOT NULL,
  raw_reply     BLOB NOT NULL,
  measured_at   INTEGER NOT NULL,
  created_at    INTEGER NOT NULL
);
CREATE INDEX rejected_readings_by_session ON rejected_readings (session_id);
)sql";

// Version 4: a job's error as the JSON object {"code", "message"}, NULL when there is none
// (it was free text), and jobs that produced a measurement but were left failed by a writer
// that died between storing the measurement and the job's end marked succeeded with its ids.
constexpr std::string_view kVersion4Sql = R"sql(
ALTER TABLE jobs ADD COLUMN typed_error TEXT CHECK (typed_error IS NULL OR (json_valid(typed_error)
  AND json_type(typed_error, '$.code') = 'text' AND json_type(typed_error, '$.message') = 'text'));
)sql";

constexpr std::string_view kVersion4After = R"sql(
UPDATE jobs SET state = 'succeeded', typed_error = NULL,
  result = (SELECT json_set(jobs.result, '$.measurement_id', m.id,
                            '$.fit_id', (SELECT min(f.id) FROM fits f WHERE f.measurement_id = m.id),
                            '$.white_measurement_id', m.white_measurement_id, '$.readings', m.reading_count,
                            '$.warnings', json(m.warnings), '$.recovered', json('true'))
            FROM measurements m WHERE m.job_id = jobs.id ORDER BY m.id LIMIT 1),
  finished_at = coalesce(finished_at, (SELECT max(m.created_at) FROM measurements m WHERE m.job_id = jobs.id))
WHERE state <> 'succeeded' AND EXISTS (SELECT 1 FROM measurements m WHERE m.job_id = jobs.id);
ALTER TABLE jobs DROP COLUMN error;
ALTER TABLE jobs RENAME COLUMN typed_error TO error;
)sql";

// Version 5: fits of any skin model. A fit names its model and keeps that model's parameters
// as a JSON array [{"name", "value", "standard_error"}] (null where the fit could not bound
// one), what the spectrum determined as a JSON object, and the digest of the model's tuned
// constants; a session names the model its samples are fitted with. Earlier fits and sessions
// are the paper model's, whose five parameter columns become the array; their constants
// digest is unknown and left empty.
constexpr std::string_view kVersion5Sql = R"sql(
ALTER TABLE sessions ADD COLUMN model TEXT NOT NULL DEFAULT 'paper';

CREATE TABLE fits_v5 (
  id               INTEGER PRIMARY KEY,
  measurement_id   INTEGER NOT NULL REFERENCES measurements (id),
  site             TEXT NOT NULL,
  model            TEXT NOT NULL,
  parameters       TEXT NOT NULL CHECK (json_valid(parameters) AND json_type(parameters) = 'array'),
  assessment       TEXT NOT NULL CHECK (json_valid(assessment) AND json_type(assessment) = 'object'),
  rmse             REAL NOT NULL,
  max_abs_error    REAL NOT NULL,
  delta_e00_d65    REAL NOT NULL,
  iterations       INTEGER NOT NULL,
  converged        INTEGER NOT NULL CHECK (converged IN (0, 1)),
  solver_summary   TEXT NOT NULL,
  options          TEXT NOT NULL CHECK (json_valid(options)),
  model_version    TEXT NOT NULL,
  tables_digest    TEXT NOT NULL,
  constants_digest TEXT NOT NULL,
  measured         BLOB NOT NULL,
  fitted           BLOB NOT NULL,
  samples_ignored  INTEGER NOT NULL,
  created_at       INTEGER NOT NULL
);

INSERT INTO fits_v5
SELECT id, measurement_id, site, 'paper',
       json_array(
                  json_object('name', 'surface_reflectance', 'value', surface_reflectance, 'standard_error',
                              CASE WHEN abs(se_surface_reflectance) <= 1.7976931348623157e308 THEN se_surface_reflectance END),
                  json_object('name', 'melanin', 'value', melanin, 'standard_error',
                              CASE WHEN abs(se_melanin) <= 1.7976931348623157e308 THEN se_melanin END),
                  json_object('name', 'oxyhemoglobin', 'value', oxyhemoglobin, 'standard_error',
                              CASE WHEN abs(se_oxyhemoglobin) <= 1.7976931348623157e308 THEN se_oxyhemoglobin END),
                  json_object('name', 'deoxyhemoglobin', 'value', deoxyhemoglobin, 'standard_error',
                              CASE WHEN abs(se_deoxyhemoglobin) <= 1.7976931348623157e308 THEN se_deoxyhemoglobin END),
                  json_object('name', 'bilirubin', 'value', bilirubin, 'standard_error',
                              CASE WHEN abs(se_bilirubin) <= 1.7976931348623157e308 THEN se_bilirubin END)),
       '{}', rmse, max_abs_error, delta_e00_d65, iterations, converged, solver_summary, options, model_version,
       tables_digest, '', measured, fitted, samples_ignored, created_at
FROM fits;

DROP TABLE fits;
ALTER TABLE fits_v5 RENAME TO fits;
CREATE INDEX fits_by_measurement ON fits (measurement_id);
)sql";

// The free-text errors of versions 2 and 3 began with the kind of failure and a colon, under
// these names; the codes they became in version 4.
constexpr std::array<std::pair<std::string_view, std::string_view>, 13> kVersion3ErrorKinds = {{
    {"no_contact", "no_contact"},
    {"lost", "lost"},
    {"protocol", "protocol"},
    {"bad_reading", "bad_reading"},
    {"rejected", "rejected"},
    {"cancelled", "cancelled"},
    {"transport", "transport"},
    {"no_white_reference", "no_white"},
    {"white_mismatch", "white_mismatch"},
    {"white_reference_dark", "white_dark"},
    {"database", "store"},
    {"internal", "internal"},
    {"interrupted", "interrupted"},
}};

// {code, message} of a version-3 error text, as well as the text allows.
std::pair<std::string_view, std::string> version3_error(std::string_view state, std::string_view text) {
  if (text.empty()) return {state == "cancelled" ? "cancelled" : "internal", "no reason was recorded"};
  if (text.starts_with("cancelled")) return {"cancelled", std::string(text)};
  if (text == "the service stopped") return {"stopped", std::string(text)};
  if (const auto colon = text.find(':'); colon != std::string_view::npos) {
    const auto kind = text.substr(0, colon);
    auto rest = text.substr(colon + 1);
    rest.remove_prefix(std::min(rest.find_first_not_of(' '), rest.size()));
    for (const auto& [name, code] : kVersion3ErrorKinds)
      if (kind == name && !rest.empty()) return {code, std::string(rest)};
  }
  return {state == "cancelled" ? "cancelled" : "internal", std::string(text)};
}

void convert_version3_errors(detail::Connection& writer) {
  std::vector<std::tuple<std::int64_t, std::string, std::string>> jobs;
  {
    auto rows = writer.prepare("SELECT id, state, error FROM jobs WHERE state IN ('failed', 'cancelled')");
    while (rows.step()) jobs.emplace_back(rows.integer(0), rows.text(1), rows.text(2));
  }
  for (const auto& [id, state, text] : jobs) {
    const auto [code, message] = version3_error(state, text);
    writer.prepare("UPDATE jobs SET typed_error = json_object('code', ?2, 'message', ?3) WHERE id = ?1")
        .bind(id, code, message)
        .run();
  }
}

}  // namespace

constexpr detail::MigrationStep kVersion1{kVersion1Sql};
constexpr detail::MigrationStep kVersion2{kVersion2Sql};
constexpr detail::MigrationStep kVersion3{kVersion3Sql};
constexpr detail::MigrationStep kVersion4{kVersion4Sql, convert_version3_errors, kVersion4After};
constexpr detail::MigrationStep kVersion5{kVersion5Sql};
// Benches (docs/store.md, "Benches"): the bench each session was opened on and each job runs on
// ('' for rows from before), and the benches with their heartbeats.
constexpr std::string_view kVersion6Sql = R"sql(
ALTER TABLE sessions ADD COLUMN bench TEXT NOT NULL DEFAULT '';
ALTER TABLE jobs ADD COLUMN bench TEXT NOT NULL DEFAULT '';
CREATE INDEX jobs_active_by_bench ON jobs (bench, id) WHERE state IN ('queued', 'running');
CREATE TABLE benches (
  name         TEXT PRIMARY KEY,
  host         TEXT NOT NULL,
  pid          INTEGER NOT NULL,
  started_at   INTEGER NOT NULL,
  heartbeat_at INTEGER NOT NULL,
  lease_ms     INTEGER NOT NULL CHECK (lease_ms > 0),
  instrument   TEXT NOT NULL CHECK (json_valid(instrument) AND json_type(instrument) = 'object'),
  stopped_at   INTEGER
);
)sql";
constexpr detail::MigrationStep kVersion6{kVersion6Sql};

// Imports (docs/store.md, "Imports"): measurements of kind 'imported'. Only the CHECK of
// measurements.kind changes, and it only admits one more value, which every row already
// satisfies: so, as SQLite's manual describes for loosening a CHECK, its text is changed in
// sqlite_schema and the schema's cookie advanced, in the migration's transaction, instead of
// copying the table (which its fits and white readings reference).
void admit_imported_measurements(detail::Connection& writer) {
  const auto cookie = writer.query_integer("PRAGMA schema_version");
  writer.execute("PRAGMA writable_schema = ON");
  writer.execute(
      "UPDATE sqlite_schema SET sql = replace(sql, '(kind IN (''white'', ''sample'', ''dark''))', "
      "'(kind IN (''white'', ''sample'', ''dark'', ''imported''))') WHERE type = 'table' AND name = 'measurements' "
      "AND instr(sql, '(kind IN (''white'', ''sample'', ''dark''))') > 0");
  const auto changed = writer.query_integer("SELECT changes()");
  writer.execute(fmt::format("PRAGMA schema_version = {}", cookie + 1));
  writer.execute("PRAGMA writable_schema = OFF");
  if (changed != 1)
    detail::fail(StoreError::Kind::corrupt, "the measurements table is not as version 7 made it (its kind check)");
}

constexpr detail::MigrationStep kVersion8{"", admit_imported_measurements};

// Maps (docs/store.md, "Maps"): a map with the job that made it, its two parts of data (0 the
// answer cube, 1 the pixels' reflectance) deflated in pieces of 1 MiB of raw data (a cube's data runs to hundreds of
// MB, which no one statement should hold), and its pictures, whose ordinal keeps the order they were given in on every
// engine.
constexpr std::string_view kVersion9Sql = R"sql(
CREATE TABLE maps (
  id         INTEGER PRIMARY KEY,
  job_id     INTEGER NOT NULL UNIQUE REFERENCES jobs (id),
  session_id INTEGER REFERENCES sessions (id),
  name       TEXT NOT NULL,
  summary    TEXT NOT NULL CHECK (json_valid(summary) AND json_type(summary) = 'object'),
  header     TEXT NOT NULL,
  data_bytes INTEGER NOT NULL CHECK (data_bytes >= 0),
  reflectance_bytes INTEGER NOT NULL CHECK (reflectance_bytes >= 0),
  created_at INTEGER NOT NULL
);
CREATE INDEX maps_by_session ON maps (session_id);
CREATE TABLE map_data (
  map_id INTEGER NOT NULL REFERENCES maps (id),
  part   INTEGER NOT NULL CHECK (part IN (0, 1)),
  piece  INTEGER NOT NULL CHECK (piece >= 0),
  bytes  BLOB NOT NULL,
  PRIMARY KEY (map_id, part, piece)
);
CREATE TABLE map_pictures (
  map_id    INTEGER NOT NULL REFERENCES maps (id),
  ordinal   INTEGER NOT NULL CHECK (ordinal >= 0),
  parameter TEXT NOT NULL CHECK (parameter <> ''),
  png       BLOB NOT NULL,
  PRIMARY KEY (map_id, parameter),
  UNIQUE (map_id, ordinal)
);
)sql";
constexpr detail::MigrationStep kVersion9{kVersion9Sql};

// The audit trail (docs/store.md, "Audit trail"): who asked for each change, written in the
// change's own transaction. Rows are only ever added.
constexpr std::string_view kVersion10Sql = R"sql(
CREATE TABLE audit (
  id      INTEGER PRIMARY KEY,
  at      INTEGER NOT NULL,
  token   TEXT NOT NULL,
  address TEXT NOT NULL,
  request TEXT NOT NULL,
  change  TEXT NOT NULL
);
)sql";
constexpr detail::MigrationStep kVersion10{kVersion10Sql};

// Imports in batches (docs/store.md, "Imports"): a large file's measurements are committed a
// batch at a time, each naming its import, and stay unseen by every read until the import's row
// is published; an import never published (its writer died) is removed when the file is next
// opened. A published import's row is kept: its measurements still name it. `bench`: the bench
// whose writer stored it, whose next opening removes it on PostgreSQL.
constexpr std::string_view kVersion11Sql = R"sql(
CREATE TABLE imports (
  id           INTEGER PRIMARY KEY,
  job_id       INTEGER REFERENCES jobs (id),
  bench        TEXT NOT NULL,
  started_at   INTEGER NOT NULL,
  published_at INTEGER
);
CREATE INDEX imports_unpublished ON imports (id) WHERE published_at IS NULL;
ALTER TABLE measurements ADD COLUMN import_id INTEGER REFERENCES imports (id);
CREATE INDEX measurements_by_import ON measurements (import_id) WHERE import_id IS NOT NULL;
)sql";
constexpr detail::MigrationStep kVersion11{kVersion11Sql};

int schema_version(detail::Connection& writer) { return static_cast<int>(writer.query_integer("PRAGMA user_version")); }

void set_schema_version(detail::Connection& writer, int version) {
  // PRAGMA takes no parameters; the value is our own integer.
  writer.execute(fmt::format("PRAGMA user_version = {}", version));
}

}  // namespace skinspec::store::sqlite
