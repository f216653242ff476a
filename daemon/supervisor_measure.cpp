// One measurement job: readings from the meter (readings it rejects for their quality code are
// stored with their raw reply and retried, up to the policy's limit), their average,
// reflectance against the session's latest white, the fit, and all of it stored in one
// transaction; warnings for a white that is old or that saw the lamp change.

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <utility>

#include "skinspec/fit/spectrum.hpp"
#include "supervisor.hpp"
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

double ms_since(Clock::time_point start) { return std::chrono::duration<double, std::milli>(Clock::now() - start).count(); }

std::int64_t wall_micros(std::chrono::system_clock::time_point t) {
  return std::chrono::duration_cast<std::chrono::microseconds>(t.time_since_epoch()).count();
}

json optional_id(const std::optional<store::Id>& id) { return id ? json(*id) : json(nullptr); }

}  // namespace

std::expected<store::Id, Supervisor::Outcome> Supervisor::keep_rejected(const store::Job& job, int attempt,
                                                                       const drivers::InstrumentError& error) {
  store::RejectedReading r;
  r.session_id = job.session_id.value_or(0);
  r.job_id = job.id;
  r.instrument_id = instrument_id_;
  r.attempt = attempt;
  r.quality_code = error.quality_code;
  r.quality = drivers::pr650::quality_message(error.quality_code);
  r.reason = describe(error);
  r.raw_reply = error.raw_reply;
  r.measured_at = to_store_time(std::chrono::system_clock::now());
  auto id = db_.record_rejected_reading(r);
  if (!id) return std::unexpected(Outcome{store::JobState::failed, "database: " + id.error().message, json::object()});
  return *id;
}

std::expected<Supervisor::Readings, Supervisor::Outcome> Supervisor::take_readings(const store::Job& job,
                                                                                 const api::MeasureRequest& request,
                                                                                 drivers::Pr650& meter) {
  drivers::MeasureOptions options;
  options.integration_ms = request.integration_ms;
  Readings out;
  report_progress("measuring", 0);
  const auto failed = [&out](std::string error) {
    return std::unexpected(Outcome{store::JobState::failed, std::move(error),
                                   json{{"readings", out.good.size()}, {"rejected_reading_ids", out.rejected_ids}}});
  };
  for (int attempt = 1; std::cmp_less(out.good.size(), request.count); ++attempt) {
    auto reading = meter.measure(options);
    const auto received = std::chrono::system_clock::now();
    if (reading) {
      out.good.push_back(std::move(*reading));
      out.last_reply_at = received;
      report_progress("measuring", static_cast<int>(out.good.size()));
    } else if (const auto& error = reading.error(); error.kind != drivers::InstrumentError::Kind::bad_reading) {
      note_instrument_error(error);
      return failed(describe(error));
    } else {
      // Raw data is kept even when the job fails later: it is the record of what the meter said.
      auto id = keep_rejected(job, attempt, error);
      if (!id) return std::unexpected(id.error());
      out.rejected_ids.push_back(*id);
      out.warnings.push_back(rejection_warning(attempt, error, *id));
      spdlog::warn("event=reading_rejected job={} attempt={} quality={} rejected_reading={}", job.id, attempt, error.quality_code, *id);
      if (std::cmp_greater(out.rejected_ids.size(), policy_.max_rejected_readings)) {
        note_instrument_error(error);
        return failed(fmt::format("{} ({} readings rejected, at most {} allowed per job)", describe(error),
                                  out.rejected_ids.size(), policy_.max_rejected_readings));
      }
    }
    std::lock_guard lock(mutex_);
    if (cancel_running_) return std::unexpected(Outcome{store::JobState::cancelled, "cancelled by request", json::object()});
  }
  return out;
}

// Reflectance against `white` and the fit; an outcome when the job cannot go on.
std::optional<Supervisor::Outcome> Supervisor::derive_sample(const store::Session& session, const store::Measurement& white,
                                                             store::Measurement& m, std::optional<store::Fit>& fit,
                                                             json& timing) const {
  if (white.radiance.wavelength_nm != m.radiance.wavelength_nm)
    return Outcome{store::JobState::failed, "white_mismatch: the white reference was measured on another grid", json::object()};
  if (auto stale = white_age_warning(white, m.started_at, policy_)) m.warnings.push_back(*stale);
  if (auto lamp = inherited_lamp_warning(white)) m.warnings.push_back(*lamp);
  std::optional<store::WhiteStandard> standard;
  if (session.white_standard_id)
    if (auto s = db_.white_standard(*session.white_standard_id)) standard = *s;
  const auto calibrated = standard_on(standard, m.radiance.wavelength_nm);
  m.white_measurement_id = white.id;
  m.reflectance.wavelength_nm = m.radiance.wavelength_nm;
  for (std::size_t i = 0; i < m.radiance.values.size(); ++i) {
    const double w = white.radiance.values[i];
    if (!(w > 0))
      return Outcome{store::JobState::failed,
                     fmt::format("white_reference_dark: the white reference has no signal at {:.0f} nm", m.radiance.wavelength_nm[i]),
                     json::object()};
    m.reflectance.values.push_back(m.radiance.values[i] / w * calibrated[i]);
  }
  const auto fit_started = Clock::now();
  auto spectrum = Spectrum::create(m.reflectance.wavelength_nm, m.reflectance.values);
  FitOptions fit_options;
  fit_options.model = api::kServiceModel;
  fit_options.site = session.site;
  if (spectrum) {
    auto result = fitter_.fit(*spectrum, fit_options);
    if (result)
      fit = api::stored_fit(*result, {{"site", fit_options.site}, {"lateral_diffusion", fit_options.lateral_diffusion}},
                            "skinspecd " + version_, fitter_.optics(api::kServiceModel).tables_digest());
    else
      m.warnings.push_back("fit_failed: " + result.error());
  } else {
    m.warnings.push_back("not_fittable: " + spectrum.error());
  }
  timing["fit_ms"] = ms_since(fit_started);
  return std::nullopt;
}

Supervisor::Outcome Supervisor::execute(const store::Job& job, const api::MeasureRequest& request) {
  const auto failure = [](std::string error) { return Outcome{store::JobState::failed, std::move(error), json::object()}; };
  const store::Id session_id = job.session_id.value_or(0);
  auto session = db_.session(session_id);
  if (!session) return failure("database: " + session.error().message);

  // A sample needs a white reference first: find it before using the meter. A white is
  // compared with the one before it.
  auto white = db_.latest_measurement(session_id, store::MeasurementKind::white);
  if (!white) return failure("database: " + white.error().message);
  if (request.kind == store::MeasurementKind::sample && !*white)
    return failure("no_white_reference: measure the white standard of session " + std::to_string(session_id) + " first");

  if (auto error = ensure_connected()) {
    note_instrument_error(*error);
    return failure(describe(*error));
  }
  std::shared_ptr<drivers::Pr650> meter;
  {
    std::lock_guard lock(mutex_);
    if (cancel_running_) return {store::JobState::cancelled, "cancelled by request", json::object()};
    meter = meter_;
    // The adapter can be unplugged between connecting and here; the hot-plug handler has
    // then already dropped the meter and marked it lost.
    if (!meter) return failure("lost: the instrument went away before measuring");
    state_ = "measuring";
  }
  auto readings = take_readings(job, request, *meter);
  if (!readings) return readings.error();
  {
    std::lock_guard lock(mutex_);
    if (state_ == "measuring") state_ = "connected";  // not over a "lost" set meanwhile
  }
  const auto derive_started = Clock::now();

  auto averaged_reading = averaged(readings->good);
  if (!averaged_reading) return failure("protocol: " + averaged_reading.error());
  store::Measurement m = std::move(*averaged_reading);
  m.session_id = session_id;
  m.kind = request.kind;
  m.label = request.label;
  m.instrument_id = instrument_id_;
  m.job_id = job.id;
  m.settings = json{{"integration_ms", request.integration_ms}, {"averages", readings->good.front().averages}, {"count", request.count},
                    {"sync", readings->good.front().sync}, {"rejected_readings", readings->rejected_ids.size()}}
                   .dump();
  m.warnings = readings->warnings;

  json timing = {{"reply_received_at_us", wall_micros(readings->last_reply_at)}};
  std::optional<store::Fit> fit;
  if (request.kind == store::MeasurementKind::sample) {
    report_progress("fitting", request.count);
    if (auto stop = derive_sample(*session, **white, m, fit, timing)) return *stop;
  } else if (*white) {
    if (auto lamp = lamp_change_warning(m, **white, policy_)) m.warnings.push_back(*lamp);
  }
  report_progress("storing", request.count);
  const auto store_started = Clock::now();
  auto recorded = db_.record_measurement(m, fit);
  if (!recorded) return failure("database: " + recorded.error().message);
  timing["store_ms"] = ms_since(store_started);
  timing["derive_and_store_ms"] = ms_since(derive_started);
  json result = {{"measurement_id", recorded->measurement_id},
                 {"fit_id", optional_id(recorded->fit_id)},
                 {"white_measurement_id", optional_id(m.white_measurement_id)},
                 {"readings", readings->good.size()},
                 {"rejected_reading_ids", readings->rejected_ids},
                 {"warnings", m.warnings},
                 {"timing", timing}};
  return {store::JobState::succeeded, "", result};
}

}  // namespace skinspec::daemon
