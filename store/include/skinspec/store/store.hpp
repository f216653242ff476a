#pragma once
// The store of instruments, white standards, sessions, measurements, fits and jobs
// (docs/store.md), in a SQLite file or a PostgreSQL database. One writer connection and a pool
// of read connections: every method may be called from any thread; writes are serialised,
// reads run beside them on their own snapshot. Every write is one transaction, durable when
// the method returns (SQLite: WAL, synchronous=FULL; PostgreSQL: its commit).

#include <chrono>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "skinspec/store/audit.hpp"
#include "skinspec/store/types.hpp"

namespace skinspec::store {

// The database engines a Store can run on.
enum class Backend { sqlite, postgresql };

// The engine a target names: a libpq URI ("postgresql://..." or "postgres://...") is
// PostgreSQL; a path, or "sqlite:PATH", is a SQLite file.
Backend backend_of(const std::string& target);

// `target` as messages and logs show it: a PostgreSQL URI as postgresql://user@host:port/dbname
// (never a password, nor parameters that could hold one), a file as its path.
std::string display_target(const std::string& target);

// Which sessions count as running when a database is opened after its writer died.
enum class RecoveryPolicy {
  sessions_with_active_jobs,  // open sessions with a queued or running job
  all_open_sessions,          // every open session
};

// How a Store uses its file.
enum class OpenMode {
  // The one writer (skinspecd): creates a missing file, migrates, recovers, takes the writer lock.
  read_write,
  // Only reads (skinspec export), beside a live writer or none: never writes, creates, migrates
  // or checkpoints anything, not even a -wal or -shm file beside it (docs/store.md, "Opening").
  // The file must exist and be a skinspec database at the current schema version.
  read_only,
};

struct OpenOptions {
  OpenMode mode = OpenMode::read_write;
  // read_write: a missing SQLite file is created (skinspecd); false refuses it as not_found, for
  // commands that work on a database that must exist (skinspec refit).
  bool create_missing = true;
  RecoveryPolicy recovery = RecoveryPolicy::sessions_with_active_jobs;
  // Run PRAGMA quick_check before using an existing file (time proportional to its size).
  bool check_integrity = true;
  std::chrono::milliseconds busy_timeout{5000};
  // The bench this Store writes for (docs/store.md, "Benches"): stamped on the sessions and jobs
  // it creates. On PostgreSQL one Store writes for a bench at a time (the writer lock is the
  // bench's), and opening recovers only that bench's jobs; a SQLite file has one writer whatever
  // the bench, and recovers every job.
  std::string bench;
  int max_readers = 8;  // read connections; a reader beyond them waits for one
  // Caps the database at this many pages (PRAGMA max_page_count, 4 KiB each); 0 = no cap.
  // Writes beyond it fail as `full`, like a full disk.
  std::int64_t max_pages = 0;
  // How many measurements of a larger import (record_measurements and
  // record_measurements_as_ready) are committed at a time, unseen by every read until the
  // import is published (docs/store.md, "Imports"). The writer is held one batch at a time, and
  // on SQLite the write-ahead log and the writer's memory stay bounded by it, whatever the file's
  // size. At least 1.
  int import_batch = 1024;
  // Where the store takes "now" from; the system clock when empty.
  std::function<Time()> clock;
};

// What opening did to sessions and jobs left running by a writer that died.
struct RecoveryReport {
  std::vector<Id> interrupted_sessions;  // now `interrupted`
  std::vector<Id> failed_jobs;           // were queued or running, now `failed`
};

struct SessionFilter {
  std::optional<std::string> site{};
  std::optional<SessionState> state{};
  std::optional<Time> created_from{};    // created_at >= this
  std::optional<Time> created_before{};  // created_at < this
  std::optional<Id> cursor{};            // next_cursor of the previous page
  int limit = 50;                        // 1-1000
};

// What made a fit, as a refit names the fits it makes: a measurement holding a fit with all
// four is refitted already.
struct FitMaker {
  std::string model;
  std::string model_version;
  std::string tables_digest;
  std::string constants_digest;
};

// The measurements a refit has still to do: those with a reflectance (of one session, or of
// every one) holding no fit by `made_by`, in order of id after `after_id`, at most `limit`.
struct RefitQuery {
  FitMaker made_by;
  std::optional<Id> session_id{};
  Id after_id = 0;
  int limit = 256;  // 1-10000
};

// Newest first.
struct SessionPage {
  std::vector<Session> sessions;
  std::optional<Id> next_cursor{};  // empty on the last page
};

struct SessionDetail {
  Session session;
  std::vector<Measurement> measurements;           // in the order stored
  std::vector<Fit> fits;                           // of those measurements, in the order stored
  std::vector<RejectedReading> rejected_readings;  // in the order stored
};

struct SessionUpdate {
  std::optional<std::string> notes{};
  // open <-> interrupted; open or interrupted -> complete or aborted, which are final.
  std::optional<SessionState> state{};
};

struct RecordedMeasurement {
  Id measurement_id = 0;
  std::optional<Id> fit_id{};
};

struct JobUpdate {
  // queued -> running, failed or cancelled; running -> succeeded, failed or cancelled.
  JobState state = JobState::running;
  // Required for failed and cancelled, refused for the other states.
  std::optional<JobError> error{};
  std::optional<std::string> result{};  // a JSON object
  // When set, the update applies only to a job in this state (conflict otherwise): a program
  // cancelling another bench's queued job must not end it once that bench has started it.
  std::optional<JobState> only_from{};
};

struct CreatedJob {
  Job job;
  bool created = true;  // false: an earlier job had the same idempotency key, returned as is
};

struct CopyReport;    // copy.hpp
struct BackupReport;  // backup.hpp

// A message between the programs writing one database (docs/store.md, "Benches").
struct Notification {
  std::string channel;
  std::string payload;
};

// Notifications on some channels: PostgreSQL's LISTEN, or for a SQLite file, which one program
// writes, those its own Store sends. Delivery is at most once: a connection lost and made again
// misses what was sent meanwhile, so listeners also look at the records now and then.
class Subscription {
 public:
  virtual ~Subscription() = default;
  // What arrived, waiting up to `timeout` for the first; empty after the timeout. Fails as
  // `unreachable` while the database server cannot be reached.
  virtual Result<std::vector<Notification>> wait(std::chrono::milliseconds timeout) = 0;
};

// The end of a job stored with what it made: the job `succeeded` with `result` (a JSON object).
struct JobCompletion {
  Id job_id = 0;
  std::string result = "{}";
};

struct CompletedJob {
  Job job;  // succeeded, its result holding the ids below
  RecordedMeasurement ids;
};

class Store {
 public:
  // Opens the database `target` names (backend_of). Read-write: creates the schema when missing,
  // migrates it forward and recovers from a writer that died (recovery()). Refuses, leaving the
  // database as it was: a newer schema, a file or database that is not a skinspec one or is
  // damaged, a read-only file or role (read-write), a database another program holds for
  // writing (busy, read-write), a missing, empty or older one (read-only); and for PostgreSQL a
  // server that cannot be reached (unreachable) or refuses the role (access_denied). A
  // PostgreSQL password comes from PGPASSFILE or ~/.pgpass, never from the URI.
  static Result<Store> open(const std::string& target, const OpenOptions& options = {});

  // A moved-from Store may only be destroyed or assigned to.
  Store(Store&&) noexcept;
  Store& operator=(Store&&) noexcept;
  ~Store();

  // The file's path, or the PostgreSQL URI as given.
  const std::string& path() const;
  Backend backend() const;
  int schema_version() const;
  const RecoveryReport& recovery() const;

  // Instruments are known by model and serial number: a second call for the same one updates
  // its configuration, connection and last_seen_at and returns the same id.
  Result<Id> ensure_instrument(const Instrument& instrument);
  Result<Instrument> instrument(Id id) const;
  Result<std::vector<Instrument>> instruments() const;

  Result<Id> add_white_standard(const WhiteStandard& standard);
  Result<WhiteStandard> white_standard(Id id) const;
  Result<std::vector<WhiteStandard>> white_standards() const;

  Result<Id> create_session(const Session& session);
  Result<Session> update_session(Id id, const SessionUpdate& update);
  Result<Session> session(Id id) const;
  Result<SessionDetail> session_detail(Id id) const;
  Result<SessionPage> sessions(const SessionFilter& filter) const;

  // Stores a measurement of an open session and, when given, its fit (whose measurement_id is
  // ignored), in one transaction: both or neither. A measurement a job made (job_id set) is
  // refused here: it is stored with the job's end, by complete_measurement_job.
  Result<RecordedMeasurement> record_measurement(const Measurement& measurement, const std::optional<Fit>& fit);
  // Several measurements, each with its fit when given: all of them or none (an imported file).
  // Their ids in the order given. With `job`, the running job that made them ends `succeeded`
  // with them and each measurement names it (job_id), so an import the service acknowledged is
  // stored whole with its job's end, or not at all. In one transaction when they fit in
  // OpenOptions::import_batch, and otherwise a batch at a time, unseen by every read until one
  // last small transaction publishes them with the job's end (docs/store.md, "Imports"): an
  // import that fails, or whose writer dies, leaves nothing seen, and its batches are removed (by
  // this call, or when this bench's writer next opens the database).
  Result<std::vector<RecordedMeasurement>> record_measurements(
      const std::vector<std::pair<Measurement, std::optional<Fit>>>& measurements,
      const std::optional<JobCompletion>& job = std::nullopt);
  // The same, the measurements handed over one at a time as they become ready (an import's, as
  // they are fitted): `next` gives the next one (valid until it is called again), or null when
  // there are no more. All or none, as above. `next` may end it by throwing; the exception
  // leaves this call and nothing is stored. A batch is taken from `next` before the writer is,
  // and the writer is held only while the batch is written: other writes (`next`'s too) go on
  // while the spectra are fitted.
  using NextMeasurement = std::function<const std::pair<Measurement, std::optional<Fit>>*()>;
  Result<std::vector<RecordedMeasurement>> record_measurements_as_ready(
      const NextMeasurement& next, const std::optional<JobCompletion>& job = std::nullopt);
  // The end of a running job that measured: the measurement (its job_id set to `job_id`), its
  // fit when given, and the job `succeeded` with `result` (a JSON object, to which the store
  // adds "measurement_id" and "fit_id"), in one transaction: all of it or nothing. So a
  // stored measurement's job has always succeeded and names it, whenever the writer dies.
  Result<CompletedJob> complete_measurement_job(Id job_id, const Measurement& measurement,
                                                const std::optional<Fit>& fit, const std::string& result);
  Result<Measurement> measurement(Id id) const;
  // The session's most recently stored measurement of `kind`, if any (the session must exist).
  Result<std::optional<Measurement>> latest_measurement(Id session_id, MeasurementKind kind) const;
  // Another fit of a stored measurement (a refit), in any session state.
  Result<Id> add_fit(const Fit& fit);
  // Several fits of stored measurements in one transaction: all of them or none. Their ids in
  // the order given.
  Result<std::vector<Id>> add_fits(const std::vector<Fit>& fits);
  Result<std::vector<Measurement>> measurements_to_refit(const RefitQuery& query) const;
  // How many measurements the query (after_id and limit aside) would yield in all.
  Result<std::int64_t> count_measurements_to_refit(const RefitQuery& query) const;
  Result<Fit> fit(Id id) const;
  Result<std::vector<Fit>> fits_of_measurement(Id measurement_id) const;

  // Stores a reading rejected for its quality code, in its own transaction, in any session
  // state (the raw data of an interrupted session is kept too).
  Result<Id> record_rejected_reading(const RejectedReading& reading);
  Result<RejectedReading> rejected_reading(Id id) const;

  Result<CreatedJob> create_job(const Job& job);
  Result<Job> update_job(Id id, const JobUpdate& update);
  Result<Job> job(Id id) const;
  Result<std::optional<Job>> job_by_idempotency_key(const std::string& key) const;
  // Newest first; of one session when given.
  Result<std::vector<Job>> jobs(std::optional<Id> session_id = std::nullopt, int limit = 100) const;

  // ---- Maps (docs/store.md, "Maps") ----

  // The end of a running job that mapped a cube: the map (its id, job_id and created_at set
  // here), its data, its pictures and the job `succeeded` with `result` (a JSON object, to which
  // the store adds "map_id"), in one transaction: all of it or nothing. The data is stored
  // deflated in pieces, so neither this call nor a reader holds all of it at once. `map.pictures`
  // is ignored: the pictures are those given. Refused: a job that is not running (conflict), a
  // session that does not exist (not_found; it need not be open), an empty name, a summary or
  // result that is not a JSON object, a negative size, a picture without a parameter or two of
  // one parameter (invalid_argument). `data.read` may end it by throwing, as
  // record_measurements_as_ready's `next` may: the exception leaves this call as thrown, nothing
  // is stored and the job stays running. A write tried again (a connection found lost before the
  // commit) reads the data again from the start.
  // `reflectance` is the pixels' reflectance as fitted (size 0: none kept).
  Result<Job> complete_map_job(Id job_id, const Map& map, const MapData& answers, const MapData& reflectance,
                               const std::vector<MapPicture>& pictures, const std::string& result);
  // One map, without its data or pictures' bytes (Map::pictures names them).
  Result<Map> map(Id id) const;
  // Newest first, at most `limit` (1-1000); of one session when given.
  Result<std::vector<Map>> maps(std::optional<Id> session_id = std::nullopt, int limit = 100) const;
  // A map's picture of `parameter` (not_found when the map or the picture does not exist).
  Result<std::string> map_picture(Id id, std::string_view parameter) const;
  // A map's data, inflated, handed to `sink` piece by piece in order (each view valid during the
  // call); the read stops early when `sink` returns false. One snapshot from first to last piece.
  Result<void> read_map_data(Id id, const std::function<bool(std::string_view piece)>& sink,
                             MapPart part = MapPart::answers) const;
  // `length` bytes of a map's data from `offset`, inflating only the pieces that hold them (one
  // pixel's spectrum of a large map): fewer at the end of the data, none past it.
  Result<std::string> read_map_bytes(Id id, MapPart part, std::int64_t offset, std::int64_t length) const;

  // ---- Audit trail (docs/store.md, "Audit trail") ----

  // The changes recorded (AuditScope), newest first: `limit` (1-1000) of them with ids below
  // `before` when given.
  Result<std::vector<AuditEntry>> audit(std::optional<Id> before, int limit) const;

  // ---- Benches (docs/store.md, "Benches") ----

  // The bench this Store writes for (OpenOptions::bench).
  const std::string& bench() const;
  // This bench's heartbeat: `bench` (its name ignored: this Store's) with heartbeat_at the
  // database's time (database_time), running again if it had stopped.
  Result<void> beat(const Bench& bench);
  // This bench stopped cleanly: others see it is not running without waiting for its lease.
  Result<void> leave_bench();
  Result<std::vector<Bench>> benches() const;
  // The time benches' heartbeats are written in and judged by (bench_running): the PostgreSQL
  // server's clock, so that benches whose machines' clocks disagree judge each other by one
  // clock; this machine's for SQLite.
  Result<Time> database_time() const;
  // This bench's queued jobs, oldest first: those posted through another program too.
  Result<std::vector<Job>> queued_jobs() const;
  // Another bench's queued and running jobs marked failed (`interrupted`), with the open sessions
  // they belonged to, when that bench's program is gone: its lease ran out (or it stopped) and,
  // on PostgreSQL, nobody holds its writer lock. Empty when it is not gone, or had none.
  Result<RecoveryReport> recover_bench(const std::string& name);

  // Sends `payload` on `channel` to every subscriber (PostgreSQL: pg_notify, delivered when sent).
  Result<void> notify(const std::string& channel, const std::string& payload);
  Result<std::unique_ptr<Subscription>> subscribe(const std::vector<std::string>& channels) const;

  struct Impl;  // opaque: store/src/store_impl.hpp
  friend Result<CopyReport> copy_database(const Store& from, Store& to);
  friend Result<BackupReport> backup_database(const Store& from, const std::string& to);

 private:
  explicit Store(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// The schema version this program writes.
int current_schema_version();

// Creates a new database at `path` holding the schema of `version` (1..current) and nothing
// else: what an older skinspec would have made. For migration tests and tools.
Result<void> create_database_at_version(const std::string& path, int version);

}  // namespace skinspec::store
