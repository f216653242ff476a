// One measurement job: readings from the meter, their average, reflectance against the
// session's latest white, the fit, and all of it stored in one transaction.

#include <cmath>

#include "skinspec/fit/spectrum.hpp"
#include "supervisor.hpp"
#include "supervisor_common.hpp"

namespace skinspec::daemon {

using nlohmann::json;

namespace {

// The reflectance of the white standard on `grid`: the stored standard's, or a flat 0.99.
std::vector<double> standard_on(const std::optional<store::WhiteStandard>& standard, const std::vector<double>& grid) {
  if (!standard || standard->reflectance.wavelength_nm.size() < 2) return std::vector<double>(grid.size(), 0.99);
  auto spectrum = Spectrum::create(standard->reflectance.wavelength_nm, standard->reflectance.values);
  if (!spectrum) return std::vector<double>(grid.size(), 0.99);
  const auto resampled = spectrum->resampled(grid);
  return {resampled.values().begin(), resampled.values().end()};
}

}  // namespace

Supervisor::Outcome Supervisor::execute(const store::Job& job, const api::MeasureRequest& request) {
  const store::Id session_id = job.session_id.value_or(0);
  auto session = db_.session(session_id);
  if (!session) return {store::JobState::failed, "database: " + session.error().message, json::object()};

  // A sample needs a white reference first: find it before using the meter.
  std::optional<store::Measurement> white;
  if (request.kind == store::MeasurementKind::sample) {
    auto detail = db_.session_detail(session_id);
    if (!detail) return {store::JobState::failed, "database: " + detail.error().message, json::object()};
    for (const auto& m : detail->measurements)
      if (m.kind == store::MeasurementKind::white) white = m;
    if (!white) return {store::JobState::failed, "no_white_reference: measure the white standard of session " + std::to_string(session_id) + " first", json::object()};
  }

  if (auto error = ensure_connected()) {
    note_instrument_error(*error);
    return {store::JobState::failed, describe(*error), json::object()};
  }
  std::shared_ptr<drivers::Pr650> meter;
  {
    std::lock_guard lock(mutex_);
    if (cancel_running_) return {store::JobState::cancelled, "cancelled by request", json::object()};
    meter = meter_;
    state_ = "measuring";
  }
  drivers::MeasureOptions options;
  options.integration_ms = request.integration_ms;
  std::vector<drivers::Reading> readings;
  report_progress("measuring", 0);
  for (int i = 0; i < request.count; ++i) {
    auto reading = meter->measure(options);
    if (!reading) {
      note_instrument_error(reading.error());
      return {store::JobState::failed, describe(reading.error()), json{{"readings", i}}};
    }
    readings.push_back(std::move(*reading));
    report_progress("measuring", i + 1);
    std::lock_guard lock(mutex_);
    if (cancel_running_) return {store::JobState::cancelled, "cancelled by request", json::object()};
  }
  set_state("connected");

  const auto& first = readings.front();
  const std::size_t n = first.radiance.size();
  store::Measurement m;
  m.session_id = session_id;
  m.kind = request.kind;
  m.label = request.label;
  m.instrument_id = instrument_id_;
  m.job_id = job.id;
  m.quality_code = first.quality_code;
  m.quality = first.quality;
  m.units = first.units;
  m.reading_count = static_cast<int>(readings.size());
  m.settings = json{{"integration_ms", request.integration_ms}, {"averages", options.averages}, {"count", request.count},
                    {"sync", first.sync}}
                   .dump();
  m.radiance.wavelength_nm = first.wavelength_nm;
  m.radiance.values.assign(n, 0.0);
  for (const auto& r : readings) {
    if (r.radiance.size() != n) return {store::JobState::failed, "protocol: readings of different lengths", json::object()};
    for (std::size_t i = 0; i < n; ++i) m.radiance.values[i] += r.radiance[i] / static_cast<double>(readings.size());
    m.raw_reply += r.raw_reply;
  }
  if (readings.size() > 1) {
    m.radiance_sd.wavelength_nm = first.wavelength_nm;
    m.radiance_sd.values.assign(n, 0.0);
    for (std::size_t i = 0; i < n; ++i) {
      double sum = 0;
      for (const auto& r : readings) sum += (r.radiance[i] - m.radiance.values[i]) * (r.radiance[i] - m.radiance.values[i]);
      m.radiance_sd.values[i] = std::sqrt(sum / static_cast<double>(readings.size() - 1));
    }
  }
  m.started_at = to_store_time(first.started);
  m.finished_at = to_store_time(readings.back().finished);

  std::optional<store::Fit> fit;
  if (request.kind == store::MeasurementKind::sample) {
    if (white->radiance.wavelength_nm != m.radiance.wavelength_nm)
      return {store::JobState::failed, "white_mismatch: the white reference was measured on another grid", json::object()};
    std::optional<store::WhiteStandard> standard;
    if (session->white_standard_id)
      if (auto s = db_.white_standard(*session->white_standard_id)) standard = *s;
    const auto calibrated = standard_on(standard, m.radiance.wavelength_nm);
    m.white_measurement_id = white->id;
    m.reflectance.wavelength_nm = m.radiance.wavelength_nm;
    for (std::size_t i = 0; i < n; ++i) {
      const double w = white->radiance.values[i];
      if (!(w > 0))
        return {store::JobState::failed, "white_reference_dark: the white reference has no signal at " + std::to_string(static_cast<int>(m.radiance.wavelength_nm[i])) + " nm", json::object()};
      m.reflectance.values.push_back(m.radiance.values[i] / w * calibrated[i]);
    }
    auto spectrum = Spectrum::create(m.reflectance.wavelength_nm, m.reflectance.values);
    FitOptions fit_options;
    fit_options.site = session->site;
    if (spectrum) {
      report_progress("fitting", request.count);
      auto result = fitter_.fit(*spectrum, fit_options);
      if (result)
        fit = api::stored_fit(*result, {{"site", fit_options.site}, {"lateral_diffusion", fit_options.lateral_diffusion}},
                              "skinspecd " + version_, fitter_.optics().tables_digest());
      else
        m.warnings.push_back("fit failed: " + result.error());
    } else {
      m.warnings.push_back("reflectance not fittable: " + spectrum.error());
    }
  }
  report_progress("storing", request.count);
  auto recorded = db_.record_measurement(m, fit);
  if (!recorded) return {store::JobState::failed, "database: " + recorded.error().message, json::object()};
  json result = {{"measurement_id", recorded->measurement_id},
                 {"fit_id", recorded->fit_id ? json(*recorded->fit_id) : json(nullptr)},
                 {"white_measurement_id", m.white_measurement_id ? json(*m.white_measurement_id) : json(nullptr)},
                 {"readings", readings.size()}};
  if (!m.warnings.empty()) result["warnings"] = m.warnings;
  return {store::JobState::succeeded, "", result};
}

}  // namespace skinspec::daemon
