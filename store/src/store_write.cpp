// The store's writes: each checks its input first, then runs as one write transaction.

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <set>
#include <span>

#include "codec.hpp"
#include "map_pieces.hpp"
#include "postgresql/statements.hpp"
#include "rows.hpp"
#include "staged_imports.hpp"
#include "store_impl.hpp"

namespace skinspec::store {

using detail::Blob;
using detail::Connection;
using detail::fail;
using Kind = StoreError::Kind;

namespace {

[[noreturn]] void invalid(std::string message) { fail(Kind::invalid_argument, std::move(message)); }

void check_measurement(const Measurement& m) {
  if (m.session_id <= 0) invalid("a measurement needs its session's id");
  // An imported reflectance comes without the radiance it was taken from; a measured one has it.
  const bool imported = m.kind == MeasurementKind::imported;
  detail::check_spectrum(m.radiance, "radiance", imported);
  if (imported && m.reflectance.empty()) invalid("an imported measurement needs its reflectance");
  detail::check_spectrum(m.radiance_sd, "radiance_sd", true);
  if (!m.radiance_sd.empty() && m.radiance_sd.wavelength_nm != m.radiance.wavelength_nm)
    invalid("radiance_sd: not on the radiance's grid");
  detail::check_spectrum(m.reflectance, "reflectance", true);
  detail::check_json_object(m.settings, "settings");
  if (m.reading_count < 1) invalid(fmt::format("reading_count {} is below 1", m.reading_count));
}

void check_fit(const Fit& f) {
  detail::check_not_empty(f.site, "the fit's site");
  detail::check_not_empty(f.model_version, "model_version");
  detail::check_not_empty(f.tables_digest, "tables_digest");
  detail::check_not_empty(f.model, "the fit's model");
  if (f.params.empty()) invalid("the fit has no parameters");
  for (const auto& p : f.params) {
    detail::check_not_empty(p.name, "a fit parameter's name");
    if (!std::isfinite(p.value)) invalid(fmt::format("parameter {} is not finite", p.name));
  }
  for (const auto& [value, name] : {std::pair{f.rmse, "rmse"}, std::pair{f.max_abs_error, "max_abs_error"},
                                    std::pair{f.delta_e00_d65, "delta_e00_d65"}}) {
    if (!std::isfinite(value)) invalid(fmt::format("the fit's {} is not finite", name));
  }
  detail::check_json_object(f.assessment, "fit assessment");
  if (f.measured.size() != f.wavelength_nm.size() || f.fitted.size() != f.wavelength_nm.size()) {
    invalid(fmt::format("fit: {} wavelengths, {} measured, {} fitted values", f.wavelength_nm.size(), f.measured.size(),
                        f.fitted.size()));
  }
  detail::check_spectrum({f.wavelength_nm, f.measured}, "fit", true);
  detail::check_json_object(f.options, "fit options");
}

// The id an INSERT ... RETURNING id gave.
Id returned_id(detail::Statement& insert) {
  if (!insert.step()) fail(Kind::internal, "an insert returned no id");
  const Id id = insert.integer(0);
  insert.run();
  return id;
}

std::string session_state_of(Connection& c, Id session_id) {
  auto stmt = c.prepare("SELECT state FROM sessions WHERE id = ?1", detail::RowLock::update);
  stmt.bind(session_id);
  if (!stmt.step()) fail(Kind::not_found, fmt::format("session {} does not exist", session_id));
  return stmt.text(0);
}

// A measurement that reads may see (not one of an unpublished import) by its id, ?1.
const std::string kPublishedMeasurement =
    fmt::format("SELECT 1 FROM measurements WHERE id = ?1 AND {}", detail::kPublished);

void require_row(Connection& c, std::string_view sql, Id id, std::string_view what) {
  auto stmt = c.prepare(sql);
  stmt.bind(id);
  if (!stmt.step()) fail(Kind::not_found, fmt::format("{} {} does not exist", what, id));
}

// A measurement's columns and a fit's but its measurement_id, as bind_measurement and
// bind_fit bind them; each engine's INSERTs name them in this order.
constexpr std::string_view kMeasurementColumns =
    "session_id, kind, label, instrument_id, white_measurement_id, job_id, simulated, quality_code, quality, units, "
    "settings, reading_count, radiance, radiance_sd, reflectance, warnings, raw_reply, started_at, finished_at, "
    "created_at, import_id";
constexpr int kMeasurementColumnCount = 21;
constexpr std::string_view kFitColumns =
    "site, model, parameters, assessment, rmse, max_abs_error, delta_e00_d65, iterations, converged, solver_summary, "
    "options, model_version, tables_digest, constants_digest, measured, fitted, samples_ignored, created_at";
constexpr int kFitColumnCount = 18;

std::optional<Blob> optional_blob(const SpectralSamples& spectrum, const std::string& bytes) {
  if (spectrum.empty()) return std::nullopt;
  return Blob{bytes};
}

// `import_id`: the unpublished import it is staged in (staged_imports.hpp), if any.
void bind_measurement(detail::Statement& insert, int first, const Measurement& m, Time now,
                      std::optional<Id> import_id) {
  const auto radiance = detail::encode_spectrum(m.radiance);
  const auto radiance_sd = detail::encode_spectrum(m.radiance_sd);
  const auto reflectance = detail::encode_spectrum(m.reflectance);
  insert.bind_from(first, m.session_id, to_string(m.kind), m.label, m.instrument_id, m.white_measurement_id, m.job_id,
                   m.simulated, m.quality_code, m.quality, m.units, m.settings, m.reading_count, Blob{radiance},
                   optional_blob(m.radiance_sd, radiance_sd), optional_blob(m.reflectance, reflectance),
                   detail::encode_text_list(m.warnings), Blob{m.raw_reply}, m.started_at, m.finished_at, now,
                   import_id);
}

void bind_fit(detail::Statement& insert, int first, const Fit& f, Time now) {
  const auto measured = detail::encode_spectrum({f.wavelength_nm, f.measured});
  const auto fitted = detail::encode_spectrum({f.wavelength_nm, f.fitted});
  insert.bind_from(first, f.site, f.model, detail::encode_fit_params(f.params), f.assessment, f.rmse, f.max_abs_error,
                   f.delta_e00_d65, f.iterations, f.converged, f.solver_summary, f.options, f.model_version,
                   f.tables_digest, f.constants_digest, Blob{measured}, Blob{fitted}, f.samples_ignored, now);
}

Id insert_fit(Connection& c, const Fit& f, Id measurement_id, Time now) {
  static const std::string sql = fmt::format("INSERT INTO fits (measurement_id, {}) VALUES (?1, {}) RETURNING id",
                                             kFitColumns, detail::placeholders(2, kFitColumnCount));
  auto insert = c.prepare(sql);
  insert.bind(measurement_id);
  bind_fit(insert, 2, f, now);
  return returned_id(insert);
}

// PostgreSQL's one statement that records a measurement (with its fit when `fit`, and the end of
// its job when `ends_job`), postgresql/statements.hpp.
const std::string& recording_statement(bool fit, bool ends_job) {
  static const auto make = [](bool with_fit, bool with_job) {
    return postgresql::recording_statement({.measurement_columns = kMeasurementColumns,
                                            .measurement_count = kMeasurementColumnCount,
                                            .fit_columns = with_fit ? kFitColumns : "",
                                            .fit_count = with_fit ? kFitColumnCount : 0,
                                            .job_columns = with_job ? detail::kJobColumns : ""});
  };
  static const std::array<std::string, 4> statements{make(false, false), make(true, false), make(false, true),
                                                     make(true, true)};
  return statements[(fit ? 1 : 0) + (ends_job ? 2 : 0)];
}

bool session_transition_allowed(SessionState from, SessionState to) {
  if (from == to) return true;
  switch (from) {
    case SessionState::open:
      return true;
    case SessionState::interrupted:
      return true;
    case SessionState::complete:
    case SessionState::aborted:
      return false;
  }
  return false;
}

bool job_transition_allowed(JobState from, JobState to) {
  switch (from) {
    case JobState::queued:
      return to == JobState::running || to == JobState::failed || to == JobState::cancelled;
    case JobState::running:
      return to == JobState::succeeded || to == JobState::failed || to == JobState::cancelled;
    default:
      return false;
  }
}

void check_job_update(const JobUpdate& update) {
  if (update.result) detail::check_json_object(*update.result, "the job's result");
  const bool ended_badly = update.state == JobState::failed || update.state == JobState::cancelled;
  if (ended_badly && !update.error)
    invalid(fmt::format("a job that becomes {} needs its error", to_string(update.state)));
  if (!ended_badly && update.error) invalid(fmt::format("a job that becomes {} has no error", to_string(update.state)));
  if (update.error) detail::check_not_empty(update.error->message, "the job error's message");
}

// That job `job_id`, found in state `state`, is running: only a running job ends with what it
// made.
void require_running(Id job_id, JobState state) {
  if (state != JobState::running)
    fail(Kind::conflict, fmt::format("job {} is {}, not running", job_id, to_string(state)));
}

// That the job a measurement ends, found in state `state`, is running and of the measurement's
// session.
void check_job_ended_by(Id job_id, JobState state, std::optional<Id> job_session, Id session_id) {
  require_running(job_id, state);
  if (job_session != session_id) invalid(fmt::format("job {} is not of session {}", job_id, session_id));
}

// That what the checks of measurement `m` read, from column `first` of `row` (the session's
// state, NULL when there is none; the white reading's kind, NULL when there is none or it does
// not exist; how many instruments have its instrument's id), allows storing it.
void check_context(const detail::Statement& row, int first, const Measurement& m) {
  if (row.is_null(first)) fail(Kind::not_found, fmt::format("session {} does not exist", m.session_id));
  const auto state = row.text(first);
  if (state != to_string(SessionState::open))
    fail(Kind::conflict, fmt::format("session {} is {}, not open", m.session_id, state));
  if (m.white_measurement_id) {
    if (row.is_null(first + 1))
      fail(Kind::not_found, fmt::format("measurement {} does not exist", *m.white_measurement_id));
    if (row.text(first + 1) != to_string(MeasurementKind::white))
      fail(Kind::conflict, fmt::format("measurement {} is not a white reading", *m.white_measurement_id));
  }
  if (m.instrument_id && row.integer(first + 2) == 0)
    fail(Kind::not_found, fmt::format("instrument {} does not exist", *m.instrument_id));
}

// Job `id`, its row locked until the transaction ends where the engine has row locks: the
// programs of two benches may change one job (a cancel beside the start).
Job job_in(Connection& c, Id id) {
  static const std::string by_id = fmt::format("SELECT {} FROM jobs WHERE id = ?1", detail::kJobColumns);
  auto row = c.prepare(by_id, detail::RowLock::update);
  row.bind(id);
  if (!row.step()) fail(Kind::not_found, fmt::format("job {} does not exist", id));
  return detail::read_job(row);
}

// Moves job `current` (its row read, and locked, in this transaction) to the update's state,
// which check_job_update passed; returns the job as it is then.
Job move_job(Connection& c, const Job& current, const JobUpdate& update, Time now) {
  const auto from = current.state;
  if (update.only_from && from != *update.only_from) {
    fail(Kind::conflict,
         fmt::format("job {} is {}, not {}", current.id, to_string(from), to_string(*update.only_from)));
  }
  if (update.state != from && !job_transition_allowed(from, update.state))
    fail(Kind::conflict, fmt::format("a job that is {} cannot become {}", to_string(from), to_string(update.state)));
  const bool finished = update.state != JobState::queued && update.state != JobState::running;
  const std::optional<std::string> error =
      update.error ? std::optional<std::string>(detail::encode_job_error(*update.error)) : std::nullopt;
  static const std::string sql = fmt::format(
      "UPDATE jobs SET state = ?2, error = ?3, result = coalesce(?4, result), "
      "started_at = CASE WHEN ?2 = 'running' AND started_at IS NULL THEN ?5 ELSE started_at END, "
      "finished_at = CASE WHEN ?6 AND finished_at IS NULL THEN ?5 ELSE finished_at END WHERE id = ?1 RETURNING {}",
      detail::kJobColumns);
  auto row = c.prepare(sql);
  row.bind(current.id, to_string(update.state), error, update.result, now, finished);
  if (!row.step()) fail(Kind::internal, fmt::format("job {} was not updated", current.id));
  auto moved = detail::read_job(row);
  row.run();
  return moved;
}

// Moves job `current` to the update's state, inside the caller's transaction.
Job change_job(Connection& c, const Job& current, const JobUpdate& update, Time now) {
  check_job_update(update);
  return move_job(c, current, update, now);
}

// Moves job `id` to the update's state, inside the caller's transaction.
Job change_job(Connection& c, Id id, const JobUpdate& update, Time now) {
  check_job_update(update);
  return move_job(c, job_in(c, id), update, now);
}

struct Recorded {
  RecordedMeasurement ids;
  std::optional<Job> job;  // the job it ended
};

// PostgreSQL: measurement `m` and its fit (and, given the job's `result_head`, the end of its job)
// by one statement, inside the caller's transaction; as its last statement when `last`, so that
// the COMMIT goes with it. The statement writes only what the checks below allow: they read what
// it found, and name what failed.
Recorded record_by_one_statement(Connection& c, const Measurement& m, const std::optional<Fit>& fit,
                                 const std::optional<std::string>& result_head, bool last, Time now,
                                 std::optional<Id> import_id = {}) {
  check_measurement(m);
  if (fit) check_fit(*fit);
  using enum postgresql::RecordingColumn;
  auto row = c.prepare(recording_statement(fit.has_value(), result_head.has_value()));
  bind_measurement(row, 1, m, now, import_id);
  if (fit) bind_fit(row, kMeasurementColumnCount + 1, *fit, now);
  if (result_head) row.bind_at(kMeasurementColumnCount + (fit ? kFitColumnCount : 0) + 1, *result_head);
  if (last) row.send_with_commit();
  if (!row.step()) fail(Kind::internal, "recording a measurement returned no row");
  if (result_head) {
    if (row.is_null(job_state)) fail(Kind::not_found, fmt::format("job {} does not exist", *m.job_id));
    const auto state = row.text(job_state);
    const auto parsed = parse_job_state(state);
    if (!parsed) fail(Kind::corrupt, fmt::format("job state '{}' is not one skinspec writes", state));
    check_job_ended_by(*m.job_id, *parsed, row.optional_integer(job_session_id), m.session_id);
  }
  check_context(row, session_state, m);
  if (row.is_null(new_measurement_id)) fail(Kind::internal, "a measurement that passed its checks was not stored");
  Recorded out;
  out.ids.measurement_id = row.integer(new_measurement_id);
  if (fit) out.ids.fit_id = row.integer(new_fit_id);
  if (result_head) out.job = detail::read_job_from(row, job_row);
  row.run();
  return out;
}

// A measurement and its fit, inside the caller's transaction, after the checks every
// measurement passes; `last`: the transaction's last statement.
// `import_id`: the unpublished import it is staged in (staged_imports.hpp).
RecordedMeasurement insert_measurement_and_fit(Connection& c, const Measurement& m, const std::optional<Fit>& fit,
                                               Time now, bool last = false, std::optional<Id> import_id = {}) {
  if (c.dialect() == detail::Dialect::postgresql)
    return record_by_one_statement(c, m, fit, std::nullopt, last, now, import_id).ids;
  check_measurement(m);
  if (fit) check_fit(*fit);
  // What the checks need, in one query: the session's state, the white reading's kind (NULL
  // when there is none or it does not exist) and whether the instrument exists.
  static const std::string context_sql = fmt::format(
      "SELECT s.state, (SELECT kind FROM measurements WHERE id = ?2 AND {}), (SELECT count(*) FROM instruments "
      "WHERE id = ?3) FROM sessions s WHERE s.id = ?1",
      detail::kPublished);
  auto context = c.prepare(context_sql);
  context.bind(m.session_id, m.white_measurement_id, m.instrument_id);
  if (!context.step()) fail(Kind::not_found, fmt::format("session {} does not exist", m.session_id));
  check_context(context, 0, m);
  static const std::string insert_sql =
      fmt::format("INSERT INTO measurements ({}) VALUES ({}) RETURNING id", kMeasurementColumns,
                  detail::placeholders(1, kMeasurementColumnCount));
  auto insert = c.prepare(insert_sql);
  bind_measurement(insert, 1, m, now, import_id);
  RecordedMeasurement ids;
  ids.measurement_id = returned_id(insert);
  if (fit) ids.fit_id = insert_fit(c, *fit, ids.measurement_id, now);
  return ids;
}

// A job's result without the ids of what it stored, as the text they complete: the caller's
// object (any of `ids` in it left out) without its closing brace, and a comma when it has members.
std::string result_head(const std::string& result, std::initializer_list<std::string_view> ids) {
  auto object = nlohmann::json::parse(result, nullptr, false);
  if (object.is_discarded() || !object.is_object()) invalid("the job's result: not a JSON object");
  for (const auto id : ids) object.erase(std::string(id));
  auto text = object.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  text.pop_back();
  if (!object.empty()) text += ',';
  return text;
}

// The job's result: its head and the ids, as PostgreSQL's recording statement writes it too.
std::string with_ids(const std::string& head, const RecordedMeasurement& ids) {
  return fmt::format(R"({}"measurement_id":{},"fit_id":{}}})", head, ids.measurement_id,
                     ids.fit_id ? std::to_string(*ids.fit_id) : std::string("null"));
}

}  // namespace

Result<Id> Store::ensure_instrument(const Instrument& in) {
  return impl_->write("storing an instrument", [&](Connection& c) {
    detail::check_not_empty(in.model, "the instrument's model");
    detail::check_not_empty(in.serial_number, "the instrument's serial number");
    const auto now = impl_->now();
    return returned_id(
        c.prepare("INSERT INTO instruments (model, serial_number, spectral_configuration, connection, created_at, "
                  "last_seen_at) VALUES (?1, ?2, ?3, ?4, ?5, ?5) "
                  "ON CONFLICT (model, serial_number) DO UPDATE SET spectral_configuration = "
                  "excluded.spectral_configuration, connection = excluded.connection, last_seen_at = "
                  "excluded.last_seen_at RETURNING id")
            .bind(in.model, in.serial_number, in.spectral_configuration, in.connection, now));
  });
}

Result<Id> Store::add_white_standard(const WhiteStandard& standard) {
  return impl_->write("storing a white standard", [&](Connection& c) {
    detail::check_not_empty(standard.name, "the white standard's name");
    detail::check_spectrum(standard.reflectance, "the white standard's reflectance", false);
    const auto reflectance = detail::encode_spectrum(standard.reflectance);
    return returned_id(c.prepare("INSERT INTO white_standards (name, certificate, reflectance, created_at) "
                                 "VALUES (?1, ?2, ?3, ?4) RETURNING id")
                           .bind(standard.name, standard.certificate, Blob{reflectance}, impl_->now()));
  });
}

Result<Id> Store::create_session(const Session& s) {
  return impl_->write("creating a session", [&](Connection& c) {
    detail::check_not_empty(s.subject, "the session's subject");
    detail::check_not_empty(s.site, "the session's site");
    detail::check_not_empty(s.model, "the session's model");
    if (s.white_standard_id)
      require_row(c, "SELECT 1 FROM white_standards WHERE id = ?1", *s.white_standard_id, "white standard");
    const auto now = impl_->now();
    return returned_id(
        c.prepare("INSERT INTO sessions (subject, site, operator_name, notes, model, white_standard_id, state, "
                  "created_at, updated_at, bench) VALUES (?1, ?2, ?3, ?4, ?5, ?6, 'open', ?7, ?7, ?8) RETURNING id")
            .bind(s.subject, s.site, s.operator_name, s.notes, s.model, s.white_standard_id, now,
                  impl_->options.bench));
  });
}

Result<Session> Store::update_session(Id id, const SessionUpdate& update) {
  return impl_->write(fmt::format("updating session {}", id), [&](Connection& c) {
    const auto current = *parse_session_state(session_state_of(c, id));
    const auto now = impl_->now();
    if (update.state && *update.state != current) {
      if (!session_transition_allowed(current, *update.state)) {
        fail(Kind::conflict,
             fmt::format("a session that is {} cannot become {}", to_string(current), to_string(*update.state)));
      }
      const std::optional<Time> ended = *update.state == SessionState::open ? std::nullopt : std::optional<Time>(now);
      c.prepare("UPDATE sessions SET state = ?2, updated_at = ?3, ended_at = ?4 WHERE id = ?1")
          .bind(id, to_string(*update.state), now, ended)
          .run();
    }
    if (update.notes) {
      c.prepare("UPDATE sessions SET notes = ?2, updated_at = ?3 WHERE id = ?1").bind(id, *update.notes, now).run();
    }
    static const std::string select = fmt::format("SELECT {} FROM sessions WHERE id = ?1", detail::kSessionColumns);
    auto row = c.prepare(select);
    row.bind(id);
    row.step();
    return detail::read_session(row);
  });
}

namespace {

// A measurement stored on its own (not a job's, which complete_measurement_job stores), with its
// fit, inside the caller's transaction.
RecordedMeasurement insert_measurement_without_job(Connection& c, const Measurement& m, const std::optional<Fit>& fit,
                                                   Time now, bool last = false, std::optional<Id> import_id = {}) {
  if (m.job_id) invalid(fmt::format("the measurement of job {} is stored with the job's end", *m.job_id));
  return insert_measurement_and_fit(c, m, fit, now, last, import_id);
}

}  // namespace

Result<RecordedMeasurement> Store::record_measurement(const Measurement& m, const std::optional<Fit>& fit) {
  return impl_->write("recording a measurement",
                      [&](Connection& c) { return insert_measurement_without_job(c, m, fit, impl_->now(), true); });
}

namespace {

// The measurements `next` gives, inside the caller's transaction: with the end of their job
// when there is one, or, staged in unpublished import `import_id`, without it (the import's
// publication ends it).
std::vector<RecordedMeasurement> insert_measurements(Connection& c, const Store::NextMeasurement& next,
                                                     const std::optional<JobCompletion>& job, Time now,
                                                     std::optional<Id> import_id = {}) {
  std::vector<RecordedMeasurement> out;
  if (!job) {
    while (const auto* row = next())
      out.push_back(insert_measurement_without_job(c, row->first, row->second, now, false, import_id));
    return out;
  }
  const auto running = job_in(c, job->job_id);
  require_running(job->job_id, running.state);
  while (const auto* row = next()) {
    const auto& [m, fit] = *row;
    if (m.job_id) invalid(fmt::format("the measurement of job {} is stored with the job's end", *m.job_id));
    check_job_ended_by(job->job_id, running.state, running.session_id, m.session_id);
    Measurement of_job = m;
    of_job.job_id = job->job_id;
    out.push_back(insert_measurement_and_fit(c, of_job, fit, now, false, import_id));
  }
  if (!import_id) change_job(c, running, {.state = JobState::succeeded, .result = job->result}, now);
  return out;
}

using MeasurementRow = std::pair<Measurement, std::optional<Fit>>;

// Rows of a batch handed over as `next` hands them, from the first again on each call: a write
// tried again stores the same ones.
std::vector<RecordedMeasurement> insert_batch(Connection& c, const std::vector<MeasurementRow>& batch,
                                              const std::optional<JobCompletion>& job, Time now,
                                              std::optional<Id> import_id = {}) {
  std::size_t given = 0;
  const Store::NextMeasurement next = [&]() { return given < batch.size() ? &batch[given++] : nullptr; };
  return insert_measurements(c, next, job, now, import_id);
}

// Import `import_id`'s batches removed, a batch to a transaction, after it failed. A failure here
// leaves the rest unseen, for its bench's next opening to remove.
void remove_staged(Store::Impl& impl, Id import_id) {
  for (;;) {
    const auto gone = impl.write("removing an unpublished import", [&](Connection& c) {
      return detail::remove_part_of_import(c, import_id, impl.options.import_batch);
    });
    if (!gone || *gone) return;
  }
}

// Unpublished imports of this bench whose job has ended: ones whose removal after their failure
// failed too (on a full disk it needs room of its own). Removed before another import is staged,
// so that the room they hold is there for it, with no restart. An import without a job may be in
// progress: left for the next opening.
void remove_abandoned_imports(Store::Impl& impl) {
  const auto abandoned = impl.read("finding abandoned imports", [&](Connection& c) {
    return detail::all(
        c,
        "SELECT i.id FROM imports i JOIN jobs j ON j.id = i.job_id WHERE i.published_at IS NULL AND "
        "i.bench = ?1 AND j.state <> 'running' ORDER BY i.id",
        [](const detail::Statement& row) { return row.integer(0); }, impl.options.bench);
  });
  if (!abandoned) return;  // the import's own first write meets the same fault, and says so
  for (const Id id : *abandoned) remove_staged(impl, id);
}

// Makes import `import_id` seen, with the end of its job when there is one, inside the caller's
// transaction: each measurement's session was open when it was stored, and still is.
void publish(Connection& c, Id import_id, const std::set<Id>& sessions, const std::optional<JobCompletion>& job,
             Time now) {
  for (const Id session : sessions) {
    const auto state = session_state_of(c, session);
    if (state != to_string(SessionState::open))
      fail(Kind::conflict, fmt::format("session {} is {}, not open", session, state));
  }
  detail::publish_import(c, import_id, now);
  if (!job) return;
  const auto running = job_in(c, job->job_id);
  require_running(job->job_id, running.state);
  change_job(c, running, {.state = JobState::succeeded, .result = job->result}, now);
}

// The measurements of a file (staged_imports.hpp), on every engine: in one transaction when they
// fit in a batch; otherwise each batch committed in an unpublished import as `next` gives it, the
// writer held only while it is written (never while `next` fits the next spectra), then
// published with the job's end. Whatever fails after the first batch (a store error, or `next`
// throwing) removes what was staged before it leaves.
Result<std::vector<RecordedMeasurement>> record_in_batches(Store::Impl& impl, const Store::NextMeasurement& next,
                                                           const std::optional<JobCompletion>& job) {
  const auto limit = static_cast<std::size_t>(impl.options.import_batch);
  std::vector<MeasurementRow> batch;
  // Whether the batch is full, so that `next` may give more.
  const auto take_batch = [&] {
    batch.clear();
    while (batch.size() < limit) {
      const auto* row = next();
      if (!row) return false;
      batch.push_back(*row);
    }
    return true;
  };
  const auto now = impl.now();
  bool more = take_batch();
  if (!more) {
    return impl.write(fmt::format("recording {} measurements", batch.size()),
                      [&](Connection& c) { return insert_batch(c, batch, job, now); });
  }
  remove_abandoned_imports(impl);
  std::optional<Id> import_id;
  const auto abandon = [&] {
    if (import_id) remove_staged(impl, *import_id);
  };
  try {
    std::vector<RecordedMeasurement> out;
    std::set<Id> sessions;
    while (!batch.empty()) {
      using Written = std::pair<Id, std::vector<RecordedMeasurement>>;
      auto written = impl.write(fmt::format("storing {} measurements of an import", batch.size()), [&](Connection& c) {
        const Id id = import_id ? *import_id
                                : detail::begin_import(c, job ? std::optional(job->job_id) : std::nullopt,
                                                       impl.options.bench, now);
        return Written{id, insert_batch(c, batch, job, now, id)};
      });
      if (!written) {
        abandon();
        return std::unexpected(written.error());
      }
      import_id = written->first;
      out.insert(out.end(), written->second.begin(), written->second.end());
      for (const auto& row : batch) sessions.insert(row.first.session_id);
      if (!more) break;
      more = take_batch();
    }
    auto published =
        impl.write("publishing an import", [&](Connection& c) { publish(c, *import_id, sessions, job, impl.now()); });
    if (!published) {
      abandon();
      return std::unexpected(published.error());
    }
    return out;
  } catch (...) {
    abandon();
    throw;
  }
}

}  // namespace

Result<std::vector<RecordedMeasurement>> Store::record_measurements(
    const std::vector<std::pair<Measurement, std::optional<Fit>>>& measurements,
    const std::optional<JobCompletion>& job) {
  std::size_t given = 0;
  return record_in_batches(
      *impl_, [&]() { return given < measurements.size() ? &measurements[given++] : nullptr; }, job);
}

Result<std::vector<RecordedMeasurement>> Store::record_measurements_as_ready(const NextMeasurement& next,
                                                                             const std::optional<JobCompletion>& job) {
  return record_in_batches(*impl_, next, job);
}

Result<CompletedJob> Store::complete_measurement_job(Id job_id, const Measurement& m, const std::optional<Fit>& fit,
                                                     const std::string& result) {
  return impl_->write(fmt::format("completing job {}", job_id), [&](Connection& c) {
    if (m.job_id && *m.job_id != job_id)
      invalid(fmt::format("the measurement is of job {}, not {}", *m.job_id, job_id));
    Measurement of_job = m;
    of_job.job_id = job_id;
    const auto now = impl_->now();
    const auto head = result_head(result, {"measurement_id", "fit_id"});
    if (c.dialect() == detail::Dialect::postgresql) {
      auto recorded = record_by_one_statement(c, of_job, fit, head, true, now);
      return CompletedJob{.job = std::move(*recorded.job), .ids = recorded.ids};
    }
    const auto job = job_in(c, job_id);
    check_job_ended_by(job_id, job.state, job.session_id, m.session_id);
    CompletedJob out;
    out.ids = insert_measurement_and_fit(c, of_job, fit, now);
    out.job = change_job(c, job, {.state = JobState::succeeded, .result = with_ids(head, out.ids)}, now);
    return out;
  });
}

namespace {

void check_map_data(const MapData& data) {
  if (data.size < 0) invalid(fmt::format("the map's data cannot be {} bytes", data.size));
  if (data.size > 0 && !data.read) invalid("the map's data has no reader");
}

void check_map(const Map& map, const MapData& answers, const MapData& reflectance,
               const std::vector<MapPicture>& pictures) {
  detail::check_not_empty(map.name, "the map's name");
  detail::check_json_object(map.summary, "the map's summary");
  check_map_data(answers);
  check_map_data(reflectance);
  std::set<std::string_view> parameters;
  for (const auto& picture : pictures) {
    detail::check_not_empty(picture.parameter, "a map picture's parameter");
    if (!parameters.insert(picture.parameter).second)
      invalid(fmt::format("the map has two pictures of '{}'", picture.parameter));
  }
}

// The map's data, read and deflated a piece at a time (never all of it at once), inside the
// caller's transaction.
void insert_map_data(Connection& c, Id map_id, MapPart part, const MapData& data) {
  static const std::string sql =
      fmt::format("INSERT INTO map_data ({}) VALUES (?1, ?2, ?3, ?4)", detail::kMapDataColumns);
  std::vector<char> raw(static_cast<std::size_t>(std::min(data.size, detail::kMapPieceBytes)));
  for (std::int64_t piece = 0; piece < detail::map_piece_count(data.size); ++piece) {
    const std::span<char> into(raw.data(), static_cast<std::size_t>(detail::map_piece_length(data.size, piece)));
    data.read(piece * detail::kMapPieceBytes, into);
    const auto deflated = detail::deflate_piece(into);
    c.prepare(sql).bind(map_id, static_cast<std::int64_t>(part), piece, Blob{deflated}).run();
  }
}

// The pictures in the order given, which their ordinals keep.
void insert_map_pictures(Connection& c, Id map_id, const std::vector<MapPicture>& pictures) {
  static const std::string sql =
      fmt::format("INSERT INTO map_pictures ({}) VALUES (?1, ?2, ?3, ?4)", detail::kMapPictureColumns);
  for (std::size_t i = 0; i < pictures.size(); ++i) {
    c.prepare(sql).bind(map_id, static_cast<std::int64_t>(i), pictures[i].parameter, Blob{pictures[i].png}).run();
  }
}

}  // namespace

Result<Job> Store::complete_map_job(Id job_id, const Map& map, const MapData& answers, const MapData& reflectance,
                                    const std::vector<MapPicture>& pictures, const std::string& result) {
  return impl_->write(fmt::format("completing map job {}", job_id), [&](Connection& c) {
    check_map(map, answers, reflectance, pictures);
    const auto head = result_head(result, {"map_id"});
    const auto now = impl_->now();
    const auto job = job_in(c, job_id);
    require_running(job_id, job.state);
    if (map.session_id) require_row(c, "SELECT 1 FROM sessions WHERE id = ?1", *map.session_id, "session");
    const Id map_id = returned_id(
        c.prepare("INSERT INTO maps (job_id, session_id, name, summary, header, data_bytes, reflectance_bytes, "
                  "created_at) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8) RETURNING id")
            .bind(job_id, map.session_id, map.name, map.summary, map.header, answers.size, reflectance.size, now));
    insert_map_data(c, map_id, MapPart::answers, answers);
    insert_map_data(c, map_id, MapPart::reflectance, reflectance);
    insert_map_pictures(c, map_id, pictures);
    const auto ended = fmt::format(R"({}"map_id":{}}})", head, map_id);
    return change_job(c, job, {.state = JobState::succeeded, .result = ended}, now);
  });
}

Result<Id> Store::add_fit(const Fit& fit) {
  return impl_->write(fmt::format("storing a fit of measurement {}", fit.measurement_id), [&](Connection& c) {
    check_fit(fit);
    require_row(c, kPublishedMeasurement, fit.measurement_id, "measurement");
    return insert_fit(c, fit, fit.measurement_id, impl_->now());
  });
}

Result<std::vector<Id>> Store::add_fits(const std::vector<Fit>& fits) {
  return impl_->write(fmt::format("storing {} fits", fits.size()), [&](Connection& c) {
    std::vector<Id> ids;
    const auto now = impl_->now();
    for (const auto& fit : fits) {
      check_fit(fit);
      require_row(c, kPublishedMeasurement, fit.measurement_id, "measurement");
      ids.push_back(insert_fit(c, fit, fit.measurement_id, now));
    }
    return ids;
  });
}

Result<Id> Store::record_rejected_reading(const RejectedReading& r) {
  return impl_->write("recording a rejected reading", [&](Connection& c) {
    if (r.attempt < 1) invalid(fmt::format("attempt {} is below 1", r.attempt));
    require_row(c, "SELECT 1 FROM sessions WHERE id = ?1", r.session_id, "session");
    if (r.job_id) require_row(c, "SELECT 1 FROM jobs WHERE id = ?1", *r.job_id, "job");
    if (r.instrument_id) require_row(c, "SELECT 1 FROM instruments WHERE id = ?1", *r.instrument_id, "instrument");
    return returned_id(
        c.prepare("INSERT INTO rejected_readings (session_id, job_id, instrument_id, attempt, quality_code, quality, "
                  "reason, "
                  "raw_reply, measured_at, created_at) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10) RETURNING id")
            .bind(r.session_id, r.job_id, r.instrument_id, r.attempt, r.quality_code, r.quality, r.reason,
                  Blob{r.raw_reply}, r.measured_at, impl_->now()));
  });
}

Result<CreatedJob> Store::create_job(const Job& job) {
  return impl_->write("creating a job", [&](Connection& c) {
    detail::check_not_empty(job.kind, "the job's kind");
    detail::check_json_object(job.request, "the job's request");
    detail::check_json_object(job.result, "the job's result");
    static const std::string by_key =
        fmt::format("SELECT {} FROM jobs WHERE idempotency_key = ?1", detail::kJobColumns);
    if (!job.idempotency_key.empty()) {
      auto existing = c.prepare(by_key);
      existing.bind(job.idempotency_key);
      if (existing.step()) return CreatedJob{detail::read_job(existing), false};
    }
    if (job.session_id) require_row(c, "SELECT 1 FROM sessions WHERE id = ?1", *job.session_id, "session");
    const std::string& bench = job.bench.empty() ? impl_->options.bench : job.bench;
    // A session from before benches belongs to the first bench that runs a job in it.
    if (job.session_id)
      c.prepare("UPDATE sessions SET bench = ?2 WHERE id = ?1 AND bench = ''").bind(*job.session_id, bench).run();
    const std::optional<std::string> key =
        job.idempotency_key.empty() ? std::nullopt : std::optional<std::string>(job.idempotency_key);
    // A job with the same key stored since the look-up above (by another writer) wins.
    static const std::string insert = fmt::format(
        "INSERT INTO jobs (kind, request, requested_by, session_id, idempotency_key, state, error, result, "
        "created_at, bench) VALUES (?1, ?2, ?3, ?4, ?5, 'queued', NULL, ?6, ?7, ?8) "
        "ON CONFLICT (idempotency_key) DO NOTHING "
        "RETURNING {}",
        detail::kJobColumns);
    {
      auto created = c.prepare(insert);
      created.bind(job.kind, job.request, job.requested_by, job.session_id, key, job.result, impl_->now(), bench);
      if (created.step()) {
        auto out = CreatedJob{detail::read_job(created), true};
        created.run();
        return out;
      }
    }
    auto existing = c.prepare(by_key);
    existing.bind(job.idempotency_key);
    if (!existing.step()) fail(Kind::internal, "a job that was not stored for its key has none stored either");
    return CreatedJob{detail::read_job(existing), false};
  });
}

Result<Job> Store::update_job(Id id, const JobUpdate& update) {
  return impl_->write(fmt::format("updating job {}", id),
                      [&](Connection& c) { return change_job(c, id, update, impl_->now()); });
}

}  // namespace skinspec::store
