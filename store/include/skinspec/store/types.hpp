#pragma once
// The records skinspec keeps: plain values with no database, driver or fit types in them, so that
// the store depends on nothing of ours and the programs convert at their edge.
//
// Ids are assigned by the store; on insert, `id` and the `*_at` fields the store stamps are
// ignored. Times are UTC, kept to the microsecond.

#include <array>
#include <chrono>
#include <cstdint>
#include <expected>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace skinspec::store {

using Id = std::int64_t;
using Time = std::chrono::sys_time<std::chrono::microseconds>;

// What went wrong, in kinds a caller can act on (an HTTP status, an exit status, a retry).
struct StoreError {
  enum class Kind {
    invalid_argument,  // the caller's values cannot be stored (unequal lengths, NaN, unknown state)
    not_found,         // no such record, or no database file where one must exist
    conflict,          // not allowed in the record's current state (a measurement in a closed session)
    newer_schema,      // written by a newer skinspec: left untouched
    older_schema,      // opened read-only but needs migrating first
    corrupt,           // not a SQLite file, not a skinspec database, or damaged
    read_only,         // the file (or this Store) cannot be written
    full,              // the disk, or the configured size limit, is full
    busy,              // another program holds the database for writing (or wrote one opened read-only)
    io,                // the operating system failed a read or write
    internal,          // anything else the database reports
    unreachable,       // the database server cannot be reached, or the connection to it was lost
    access_denied,     // the database server refused the role (its password, or no password for it)
  };
  Kind kind = Kind::internal;
  std::string message;
  int sqlite_code = 0;      // SQLite's extended result code when it came from SQLite, else 0
  std::string sql_state{};  // PostgreSQL's SQLSTATE ("53100") when it came from PostgreSQL, else empty
};

std::string_view to_string(StoreError::Kind kind);

// Whether a failure to open or use a database says the database named is wrong for the job
// (another program's, a newer schema, a role or file that may not write, a server that cannot
// be reached or refuses the role, records in the way): the programs' exit status 2. Otherwise
// (io, full, internal) the machine failed: status 1.
bool is_bad_target(StoreError::Kind kind);

template <typename T>
using Result = std::expected<T, StoreError>;

// A sampled spectrum and its grid, equal lengths, wavelengths strictly increasing. Stored
// bit for bit (docs/store.md). An empty one stands for "none".
struct SpectralSamples {
  std::vector<double> wavelength_nm;
  std::vector<double> values;

  bool empty() const { return wavelength_nm.empty(); }
  bool operator==(const SpectralSamples&) const = default;
};

struct Instrument {
  Id id = 0;
  std::string model;  // "PR-650"
  std::string serial_number;
  std::string spectral_configuration;  // free text or JSON: grid, bandwidth, firmware
  std::string connection;              // the URI it was last reached by
  Time created_at{}, last_seen_at{};
};

struct WhiteStandard {
  Id id = 0;
  std::string name;
  std::string certificate;      // certificate number, issuer, date: free text
  SpectralSamples reflectance;  // calibrated reflectance, 0..1
  Time created_at{};
};

enum class SessionState { open, complete, interrupted, aborted };
std::string_view to_string(SessionState state);
// Every state with its name, for documents that list them (OpenAPI).
std::span<const std::pair<SessionState, std::string_view>> session_state_names();
std::optional<SessionState> parse_session_state(std::string_view text);

struct Session {
  Id id = 0;
  std::string subject;  // a pseudonym; no real names are needed
  std::string site;     // body site, as the model names them ("forearm")
  std::string operator_name;
  std::string notes;
  std::string model;  // the skin model its samples are fitted with ("paper", "extended"); required
  std::optional<Id> white_standard_id{};
  // The bench it was opened on (the store's OpenOptions::bench); empty for sessions from before
  // benches (schema 6), which belong to the first bench that measures in them.
  std::string bench;
  SessionState state = SessionState::open;  // new sessions are always open
  Time created_at{}, updated_at{};
  std::optional<Time> ended_at{};  // when it left the open state
};

// imported: a reflectance read from another program's file (docs/store.md, "Imports"), with no
// radiance of its own.
enum class MeasurementKind { white, sample, dark, imported };
std::string_view to_string(MeasurementKind kind);
std::optional<MeasurementKind> parse_measurement_kind(std::string_view text);
std::span<const std::pair<MeasurementKind, std::string_view>> measurement_kind_names();

struct Measurement {
  Id id = 0;
  Id session_id = 0;
  MeasurementKind kind = MeasurementKind::sample;
  std::string label;
  std::optional<Id> instrument_id{};
  std::optional<Id> white_measurement_id{};  // the white reading its reflectance was derived from
  std::optional<Id> job_id{};                // the job that produced it
  bool simulated = false;
  int quality_code = 0;
  std::string quality;          // the meter's text for the code
  std::string units;            // of the radiance, "W/(sr m2 nm)"
  std::string settings = "{}";  // a JSON object: integration, averages, sync, ...
  int reading_count = 1;        // readings averaged into `radiance`
  SpectralSamples radiance;     // on the instrument's native grid
  SpectralSamples radiance_sd;  // standard deviation over the readings; empty for one
  SpectralSamples reflectance;  // derived; empty for whites and darks
  std::vector<std::string> warnings;
  std::string raw_reply;             // the meter's reply bytes, as received
  Time started_at{}, finished_at{};  // of the reading(s), from the caller
  Time created_at{};                 // when it was stored
};

// A reading the meter returned with a quality code that made it unusable: kept with its raw
// reply, since raw data is never thrown away, but never averaged into a measurement (v3).
struct RejectedReading {
  Id id = 0;
  Id session_id = 0;
  std::optional<Id> job_id{};
  std::optional<Id> instrument_id{};
  int attempt = 1;  // the job's reading attempt it was (1-based)
  int quality_code = 0;
  std::string quality;    // the meter's text for the code
  std::string reason;     // why it was rejected, as the job reports it
  std::string raw_reply;  // the meter's reply bytes, as received
  Time measured_at{};     // from the caller
  Time created_at{};      // when it was stored
};

// One fitted parameter of a fit, named as its model names it.
struct FitParam {
  std::string name;
  double value = 0;           // finite
  double standard_error = 0;  // infinite where the fit could not bound it (stored as null)
  bool operator==(const FitParam&) const = default;
};

struct Fit {
  Id id = 0;
  Id measurement_id = 0;  // set by record_measurement when stored with its measurement
  std::string site;
  std::string model;              // the skin model fitted ("paper", "extended")
  std::vector<FitParam> params;   // in the model's order; at least one
  std::string assessment = "{}";  // a JSON object: what the spectrum determined (records/ writes and reads it)
  double rmse = 0, max_abs_error = 0, delta_e00_d65 = 0;
  int iterations = 0;
  bool converged = false;
  std::string solver_summary;
  std::string options = "{}";    // a JSON object: the fit options used
  std::string model_version;     // the program and version that fitted
  std::string tables_digest;     // digest of every table behind the model, its constants included
  std::string constants_digest;  // digest of the model's tuned constants alone (empty before schema 5)
  // The samples that were fitted, equal lengths.
  std::vector<double> wavelength_nm, measured, fitted;
  int samples_ignored = 0;
  Time created_at{};
};

enum class JobState { queued, running, succeeded, failed, cancelled };
std::string_view to_string(JobState state);
std::optional<JobState> parse_job_state(std::string_view text);
// Each state and its name, in declaration order (for listings such as the API's schema).
std::span<const std::pair<JobState, std::string_view>> job_state_names();

// Why a job failed or was cancelled, in kinds a program can act on (v4; docs/store.md).
enum class JobErrorCode {
  cancelled,       // cancelled by request
  stopped,         // the service stopped before the job ended
  interrupted,     // the program running it died; found when the database was next opened
  no_contact,      // the instrument never answered
  lost,            // the instrument answered before, then went silent or away
  protocol,        // the instrument's replies made no sense, even when asked again
  bad_reading,     // too many readings with a quality code that makes them unusable
  rejected,        // the instrument refused a setting
  transport,       // the port or host could not be opened
  identification,  // another meter than --model names answered, or one skinspec does not know
  no_white,        // a sample asked for before the session's first white reference
  white_mismatch,  // the white reference was measured on another grid
  white_dark,      // the white reference has no signal at some wavelength
  store,           // the database failed a read or a write
  storage_full,    // the database's disk (or its size limit) is full: free space, and post it again
  bad_file,        // a file to import has a defect (its file, line and column in the message)
  internal,        // anything else
};
std::string_view to_string(JobErrorCode code);
std::optional<JobErrorCode> parse_job_error_code(std::string_view text);
std::span<const std::pair<JobErrorCode, std::string_view>> job_error_code_names();
// The code of a job that failed because the store did: storage_full for a full disk, else store.
JobErrorCode job_error_code_of(StoreError::Kind kind);

struct JobError {
  JobErrorCode code = JobErrorCode::internal;
  std::string message;  // for people; never parsed
  bool operator==(const JobError&) const = default;
};

struct Job {
  Id id = 0;
  std::string kind;            // "measure", "refit", ...
  std::string request = "{}";  // a JSON object: what was asked
  std::string requested_by;    // who asked (a token name, a user)
  std::optional<Id> session_id{};
  std::string bench;            // the bench that runs it; empty for jobs from before benches (schema 6)
  std::string idempotency_key;  // empty = none; otherwise unique among jobs
  JobState state = JobState::queued;
  std::optional<JobError> error{};  // why it failed or was cancelled; none in any other state
  std::string result = "{}";        // a JSON object: the ids it produced
  Time created_at{};
  std::optional<Time> started_at{}, finished_at{};
};

// A skin map of a spectral image (docs/maps.md), as the service stores it (v9): the answer
// cube's ENVI header and data, its summary, and a PNG picture of each parameter. Made by one
// job, which it names; stored whole with that job's end, or not at all.
struct MapPicture {
  std::string parameter;  // the band it pictures ("melanin")
  std::string png;        // the picture's bytes
  bool operator==(const MapPicture&) const = default;
};

struct Map {
  Id id = 0;
  Id job_id = 0;  // the job that made it
  std::optional<Id> session_id{};
  std::string name;             // the cube's name: its file's stem, or the upload's name
  std::string summary = "{}";   // a JSON object: the map's summary.json, as written
  std::string header;           // the answer cube's ENVI header (NAME.map.hdr), as written
  std::int64_t data_bytes = 0;  // the size of the answer cube's data (NAME.map.img)
  // The size of the reflectance of every pixel as it was fitted (float32, the cube's bands,
  // pixel by pixel); 0 when the map keeps none.
  std::int64_t reflectance_bytes = 0;
  std::vector<std::string> pictures;  // the parameters it has a picture of, in the order stored
  Time created_at{};
};

// A map's two runs of data: the answer cube's, and the reflectance it fitted.
enum class MapPart { answers, reflectance };

// A map's data as the store reads it to store it: `size` bytes, read piece by piece
// in order from offset 0 by `read(offset, into)`, which fills `into` whole or throws. Read again
// from the start when a write is tried again.
struct MapData {
  std::int64_t size = 0;
  std::function<void(std::int64_t offset, std::span<char> into)> read;
};

// A skinspecd writing the database for one bench (a PC with its meter), as its last heartbeat
// left it (docs/store.md, "Benches").
struct Bench {
  std::string name;
  std::string host;  // the machine it runs on
  std::int64_t pid = 0;
  Time started_at{}, heartbeat_at{};
  std::chrono::milliseconds lease{15000};  // silent longer than this after heartbeat_at: gone
  std::string instrument = "{}";           // a JSON object: its instrument's state at the heartbeat
  std::optional<Time> stopped_at{};        // set when it stopped cleanly; empty while it runs
};

// Whether a bench's daemon counts as running at `now`: not stopped, and heard within its lease.
bool bench_running(const Bench& bench, Time now);

// A bench as GET /api/v1/benches shows it: running, stopped cleanly, or not heard within its
// lease (silent).
enum class BenchState { running, stopped, silent };
BenchState bench_state(const Bench& bench, Time now);
std::string_view to_string(BenchState state);
std::span<const std::pair<BenchState, std::string_view>> bench_state_names();

}  // namespace skinspec::store
