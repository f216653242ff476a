// One measurement job, as the executor runs it: readings from the meter (readings it rejects for their quality code are
// stored with their raw reply and retried, up to the policy's limit), their average,
// reflectance against the session's latest white, the fit, and all of it stored in one
// transaction with the job's end; warnings for a white that is old or that saw the lamp change.

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <utility>

#include "measurement_executor.hpp"
#include "skinspec/records/fit_record.hpp"
#include "skinspec/spectral/spectrum.hpp"
#include "store_records.hpp"
#include "supervisor_common.hpp"

namespace skinspec::daemon {

using nlohmann::json;

namespace {

using Clock = std::chrono::steady_clock;

// The reflectance of the white standard on `grid`: the stored standard's, or a flat 0.99.
std::vector<double> standard_on(const std::optional<store::WhiteStandard>& standard, const std::vector<double>& grid) {
  if (!standard || standard->reflectance.wavelength_nm.size() < 2) return std::vector<double>(grid.size(), 0.99);
  auto spectrum = Spectrum::create(standard->reflectance.wavelength_nm, standard->reflectance.values);
  if (!spectrum) return std::vector<double>(grid.size(), 0.99);
  const auto resampled = spectrum->resampled(grid);
  return {resampled.values().begin(), resampled.values().end()};
}

double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

std::int64_t wall_micros(std::chrono::system_clock::time_point t) {
  return std::chrono::duration_cast<std::chrono::microseconds>(t.time_since_epoch()).count();
}

json optional_id(const std::optional<store::Id>& id) { return id ? json(*id) : json(nullptr); }

// A first command that finds the link in this state is worth one fresh connection.
bool finds_link_dead(drivers::InstrumentError::Kind kind) {
  using enum drivers::InstrumentError::Kind;
  return kind == lost || kind == no_contact || kind == transport;
}

std::unexpected<store::JobError> store_error(const std::string& doing, const store::StoreError& e) {
  return std::unexpected(store::JobError{store::job_error_code_of(e.kind), doing + ": " + e.message});
}

// Why a sample cannot be measured: the session has no white. When its last white job failed
// or was cancelled, that job is named, since every sample after it fails for want of it.
std::string no_white_reference(const store::Store& db, store::Id session_id) {
  if (auto jobs = db.jobs(session_id, 1000)) {
    for (const auto& job : *jobs) {
      const auto request = json::parse(job.request, nullptr, false);
      if (!request.is_object() || request.value("kind", "") != "white") continue;
      if (job.state == store::JobState::failed || job.state == store::JobState::cancelled)
        return fmt::format(
            "session {} has no white reference, its white measurement (job {}) {}; "
            "measure the white standard again",
            session_id, job.id, store::to_string(job.state));
      break;
    }
  }
  return fmt::format("measure the white standard of session {} first", session_id);
}

}  // namespace

MeasurementExecutor::Step<store::Id> MeasurementExecutor::keep_rejected(const store::Job& job, int attempt,
                                                                        const drivers::InstrumentError& error) {
  const auto meter = keeper_.meter_of_record();
  store::RejectedReading r =
      rejected_reading_record(error, meter.family, attempt, to_store_time(std::chrono::system_clock::now()));
  r.session_id = job.session_id.value_or(0);
  r.job_id = job.id;
  r.instrument_id = meter.instrument_id;
  auto id = with_retries("rejected_reading", job.id, [&] { return db_.record_rejected_reading(r); });
  if (!id) return store_error("a rejected reading could not be stored", id.error());
  return *id;
}

MeasurementExecutor::Step<void> MeasurementExecutor::take_readings(const store::Job& job,
                                                                   const api::MeasureRequest& request,
                                                                   std::shared_ptr<drivers::Instrument>& meter,
                                                                   Readings& out) {
  const drivers::MeasureOptions options = measure_options(request);
  board_.report_phase(job.id, api::JobPhase::measuring, 0);
  for (int attempt = 1; std::cmp_less(out.good.size(), request.count); ++attempt) {
    const auto reading_time = meter->reading_time(options);
    const int after = std::max(request.count - static_cast<int>(out.good.size()) - 1, 0);
    board_.start_countdown(job.id, {std::chrono::steady_clock::now() + reading_time, reading_time, after});
    auto reading = measure_reading(job.id, meter, options, attempt == 1);
    keeper_.note_firmware_warnings(meter->firmware_warnings());
    const auto received = std::chrono::system_clock::now();
    if (reading) {
      out.warnings.insert(out.warnings.end(), reading->warnings.begin(), reading->warnings.end());
      out.good.push_back(std::move(*reading));
      out.last_reply_at = received;
      board_.report_phase(job.id, api::JobPhase::measuring, static_cast<int>(out.good.size()));
    } else if (const auto& error = reading.error(); error.kind != drivers::InstrumentError::Kind::bad_reading) {
      keeper_.note_instrument_error(error);
      return std::unexpected(job_error(error));
    } else {
      // Raw data is kept even when the job fails later: it is the record of what the meter said.
      auto id = keep_rejected(job, attempt, error);
      if (!id) return std::unexpected(id.error());
      out.rejected_ids.push_back(*id);
      out.warnings.push_back(rejection_warning(attempt, error, *id));
      spdlog::warn("event=reading_rejected job={} attempt={} quality={} rejected_reading={}", job.id, attempt,
                   error.quality_code, *id);
      if (std::cmp_greater(out.rejected_ids.size(), policy_.max_rejected_readings)) {
        keeper_.note_instrument_error(error);
        auto failure = job_error(error);
        failure.message += fmt::format(" ({} readings rejected, at most {} allowed per job)", out.rejected_ids.size(),
                                       policy_.max_rejected_readings);
        return std::unexpected(failure);
      }
    }
    if (auto stop = stop_requested(job.id)) return std::unexpected(*stop);
  }
  return {};
}

// Reflectance against `white` into `m`, and its fit (none when the spectrum cannot be fitted,
// with a warning saying why).
MeasurementExecutor::Step<std::optional<store::Fit>> MeasurementExecutor::derive_sample(const store::Session& session,
                                                                                        const store::Measurement& white,
                                                                                        store::Measurement& m,
                                                                                        json& timing) const {
  if (white.radiance.wavelength_nm != m.radiance.wavelength_nm)
    return std::unexpected(
        store::JobError{store::JobErrorCode::white_mismatch, "the white reference was measured on another grid"});
  if (auto stale = white_age_warning(white, m.started_at, policy_)) m.warnings.push_back(*stale);
  if (auto lamp = inherited_lamp_warning(white)) m.warnings.push_back(*lamp);
  std::optional<store::WhiteStandard> standard;
  if (session.white_standard_id) {
    auto s = db_.white_standard(*session.white_standard_id);
    if (!s) return store_error("the session's white standard could not be read", s.error());
    standard = *s;
  }
  const auto calibrated = standard_on(standard, m.radiance.wavelength_nm);
  m.white_measurement_id = white.id;
  m.reflectance.wavelength_nm = m.radiance.wavelength_nm;
  for (std::size_t i = 0; i < m.radiance.values.size(); ++i) {
    const double w = white.radiance.values[i];
    if (!(w > 0))
      return std::unexpected(
          store::JobError{store::JobErrorCode::white_dark,
                          fmt::format("the white reference has no signal at {:.0f} nm", m.radiance.wavelength_nm[i])});
    m.reflectance.values.push_back(m.radiance.values[i] / w * calibrated[i]);
  }
  const auto fit_started = Clock::now();
  std::optional<store::Fit> fit;
  auto spectrum = Spectrum::create(m.reflectance.wavelength_nm, m.reflectance.values);
  FitOptions fit_options;
  fit_options.site = session.site;
  const auto model = parse_model_kind(session.model);
  if (!model) {
    m.warnings.push_back("fit_failed: the session's model '" + session.model + "' is not one this version knows");
  } else if (spectrum) {
    fit_options.model = *model;
    auto result = fitter_.fit(*spectrum, fit_options);
    if (result) fit = records::to_store_fit(*result, fit_options, fitter_.optics(*model));
    else m.warnings.push_back("fit_failed: " + result.error());
  } else {
    m.warnings.push_back("not_fittable: " + spectrum.error());
  }
  timing["fit_ms"] = ms_since(fit_started);
  return fit;
}

MeasurementExecutor::Step<store::CompletedJob> MeasurementExecutor::measure(const store::Job& job,
                                                                            const api::MeasureRequest& request,
                                                                            json& partial) {
  const store::Id session_id = job.session_id.value_or(0);
  auto session = db_.session(session_id);
  if (!session) return store_error("the job's session could not be read", session.error());

  // A sample needs a white reference first: find it before using the meter. A white is
  // compared with the one before it.
  auto white = db_.latest_measurement(session_id, store::MeasurementKind::white);
  if (!white) return store_error("the session's white reference could not be read", white.error());
  if (request.kind == store::MeasurementKind::sample && !*white)
    return std::unexpected(store::JobError{store::JobErrorCode::no_white, no_white_reference(db_, session_id)});

  if (auto error = keeper_.ensure_connected()) {
    keeper_.note_instrument_error(*error);
    return std::unexpected(job_error(*error));
  }
  if (auto stop = stop_requested(job.id)) return std::unexpected(*stop);
  // The adapter can be unplugged between connecting and here; the hot-plug handler has then
  // already dropped the meter and marked it lost.
  auto meter = keeper_.begin_measuring();
  if (!meter)
    return std::unexpected(store::JobError{store::JobErrorCode::lost, "the instrument went away before measuring"});
  Readings readings;
  auto taken = take_readings(job, request, meter, readings);
  partial = {{"readings", readings.good.size()}, {"rejected_reading_ids", readings.rejected_ids}};
  if (!taken) return std::unexpected(taken.error());
  keeper_.end_measuring();
  const auto derive_started = Clock::now();

  auto averaged_reading = averaged(readings.good);
  if (!averaged_reading)
    return std::unexpected(store::JobError{store::JobErrorCode::protocol, averaged_reading.error()});
  store::Measurement m = std::move(*averaged_reading);
  m.session_id = session_id;
  m.kind = request.kind;
  m.label = request.label;
  m.instrument_id = keeper_.meter_of_record().instrument_id;
  m.job_id = job.id;
  m.settings =
      measurement_settings(readings.good, measure_options(request), request.count, readings.rejected_ids.size());
  m.warnings = readings.warnings;

  json timing = {{"reply_received_at_us", wall_micros(readings.last_reply_at)}};
  std::optional<store::Fit> fit;
  if (request.kind == store::MeasurementKind::sample) {
    board_.report_phase(job.id, api::JobPhase::fitting, request.count);
    auto derived = derive_sample(*session, **white, m, timing);
    if (!derived) return std::unexpected(derived.error());
    fit = std::move(*derived);
  } else if (*white) {
    if (auto lamp = lamp_change_warning(m, **white, policy_)) m.warnings.push_back(*lamp);
  }
  board_.report_phase(job.id, api::JobPhase::storing, request.count);
  timing["derive_ms"] = ms_since(derive_started);
  // The store adds measurement_id and fit_id, in the transaction that stores them.
  const json result = {{"white_measurement_id", optional_id(m.white_measurement_id)},
                       {"readings", readings.good.size()},
                       {"rejected_reading_ids", readings.rejected_ids},
                       {"warnings", m.warnings},
                       {"timing", timing}};
  return store_measurement(job, m, fit, result);
}

MeasurementExecutor::Step<store::CompletedJob> MeasurementExecutor::store_measurement(
    const store::Job& job, const store::Measurement& m, const std::optional<store::Fit>& fit, const json& result) {
  const auto started = Clock::now();
  const auto text = result.dump();
  auto completed = outlasting_outages(
      "job_success", job.id, [&] { return db_.complete_measurement_job(job.id, m, fit, text); },
      [this] { return board_.closed(kLane); });
  if (!completed && completed.error().kind == store::StoreError::Kind::conflict) {
    if (auto stored = stored_before_the_connection_was_lost(job.id)) return std::move(*stored);
  }
  if (!completed) return store_error("the measurement could not be stored", completed.error());
  spdlog::debug("event=job_stored job={} store_ms={:.3f}", job.id, ms_since(started));
  return std::move(*completed);
}

// A connection lost while committing leaves unknown whether the commit was made: when it was, the
// attempt after it finds the job no longer running, and the job's record names what it stored.
std::optional<store::CompletedJob> MeasurementExecutor::stored_before_the_connection_was_lost(store::Id id) const {
  auto job = db_.job(id);
  if (!job || job->state != store::JobState::succeeded) return std::nullopt;
  const auto result = json::parse(job->result, nullptr, false);
  if (!result.is_object() || !result.contains("measurement_id") || !result["measurement_id"].is_number_integer())
    return std::nullopt;
  store::CompletedJob stored{*job, {result["measurement_id"].get<store::Id>(), std::nullopt}};
  if (result.contains("fit_id") && result["fit_id"].is_number_integer())
    stored.ids.fit_id = result["fit_id"].get<store::Id>();
  spdlog::info("event=job_stored_before_connection_lost job={} measurement={}", id, stored.ids.measurement_id);
  return stored;
}

// One reading for a job. A job whose first command finds the link dead (the meter was switched
// off and on, or its serial server went away, since anyone last looked) connects once more, by
// the connector's path, and measures on the new connection; a failure after the meter has
// answered in this job, or after connecting again, is the job's.
std::expected<drivers::Reading, drivers::InstrumentError> MeasurementExecutor::measure_reading(
    store::Id job_id, std::shared_ptr<drivers::Instrument>& meter, const drivers::MeasureOptions& options,
    bool first_of_job) {
  const std::uint64_t replies_before = meter->replies_received();
  auto reading = meter->measure(options);
  const bool never_answered = meter->replies_received() == replies_before;
  if (reading || !first_of_job || !never_answered || !finds_link_dead(reading.error().kind)) return reading;
  const drivers::InstrumentError dead = reading.error();
  spdlog::warn("event=instrument_reconnect_for_job device=\"{}\" error=\"{}\"", keeper_.device(), describe(dead));
  keeper_.note_instrument_error(dead);
  meter->disconnect();  // a meter serves one connection at a time
  if (auto error = keeper_.ensure_connected()) {
    error->message = fmt::format("{}; connecting again failed: {}", dead.message, error->message);
    return std::unexpected(*error);
  }
  if (board_.stop_asked(job_id))
    return std::unexpected(drivers::InstrumentError{drivers::InstrumentError::Kind::cancelled, "cancelled", -1, {}});
  meter = keeper_.begin_measuring();
  if (!meter)
    return std::unexpected(
        drivers::InstrumentError{drivers::InstrumentError::Kind::lost, "the instrument went away again", -1, {}});
  return meter->measure(options);
}

}  // namespace skinspec::daemon
