#include "supervisor.hpp"

#include <cmath>

#include <spdlog/spdlog.h>

#include "skinspec/drivers/transport.hpp"
#include "skinspec/fit/spectrum.hpp"

namespace skinspec::daemon {

using nlohmann::json;

namespace {

store::Time to_store_time(std::chrono::system_clock::time_point t) {
  return std::chrono::floor<std::chrono::microseconds>(t);
}

api::ApiError store_failure(const store::StoreError& e) {
  using K = store::StoreError::Kind;
  switch (e.kind) {
    case K::not_found: return {api::ErrorKind::not_found, "not_found", e.message};
    case K::conflict: return {api::ErrorKind::conflict, "conflict", e.message};
    case K::busy: return {api::ErrorKind::unavailable, "database_busy", e.message};
    case K::full: return {api::ErrorKind::unavailable, "database_full", e.message};
    case K::read_only: return {api::ErrorKind::unavailable, "database_read_only", e.message};
    default: return {api::ErrorKind::internal, "database_error", e.message};
  }
}

std::string describe(const drivers::InstrumentError& e) {
  return std::string(drivers::to_string(e.kind)) + ": " + e.message;
}

// The reflectance of the white standard on `grid`: the stored standard's, or a flat 0.99.
std::vector<double> standard_on(const std::optional<store::WhiteStandard>& standard, const std::vector<double>& grid) {
  if (!standard || standard->reflectance.wavelength_nm.size() < 2) return std::vector<double>(grid.size(), 0.99);
  auto spectrum = Spectrum::create(standard->reflectance.wavelength_nm, standard->reflectance.values);
  if (!spectrum) return std::vector<double>(grid.size(), 0.99);
  const auto resampled = spectrum->resampled(grid);
  return {resampled.values().begin(), resampled.values().end()};
}

}  // namespace

Supervisor::Supervisor(std::string device, store::Store& db, const Fitter& fitter, std::string version)
    : device_(std::move(device)), db_(db), fitter_(fitter), version_(std::move(version)) {}

Supervisor::~Supervisor() { stop(); }

void Supervisor::start() {
  std::lock_guard lock(mutex_);
  if (!worker_.joinable()) worker_ = std::thread([this] { run(); });
}

void Supervisor::stop() {
  std::deque<std::pair<store::Id, api::MeasureRequest>> left;
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    cancel_running_ = true;
    if (meter_) meter_->cancel();
    left.swap(queue_);
  }
  wake_.notify_all();
  if (worker_.joinable()) worker_.join();
  for (const auto& [id, request] : left)
    (void)db_.update_job(id, {store::JobState::cancelled, std::string("the service stopped"), std::nullopt});
}

json Supervisor::instrument_status() const {
  std::lock_guard lock(mutex_);
  return {{"device", device_},
          {"state", state_},
          {"last_error", last_error_.empty() ? json(nullptr) : json(last_error_)},
          {"serial_number", serial_number_.empty() ? json(nullptr) : json(serial_number_)},
          {"running_job", running_ ? json(*running_) : json(nullptr)},
          {"queued", queue_.size()}};
}

std::expected<store::CreatedJob, api::ApiError> Supervisor::submit(store::Id session_id, const api::MeasureRequest& request,
                                                                   const std::string& idempotency_key) {
  if (!idempotency_key.empty()) {
    auto earlier = db_.job_by_idempotency_key(idempotency_key);
    if (!earlier) return std::unexpected(store_failure(earlier.error()));
    if (*earlier) return store::CreatedJob{**earlier, false};
  }
  auto session = db_.session(session_id);
  if (!session) return std::unexpected(store_failure(session.error()));
  if (session->state != store::SessionState::open)
    return std::unexpected(api::ApiError{api::ErrorKind::conflict, "conflict",
                                         "session " + std::to_string(session_id) + " is " + std::string(store::to_string(session->state))});
  store::Job job;
  job.kind = "measure";
  job.session_id = session_id;
  job.idempotency_key = idempotency_key;
  job.request = json{{"kind", std::string(store::to_string(request.kind))}, {"count", request.count},
                     {"label", request.label}, {"integration_ms", request.integration_ms}}
                    .dump();
  std::lock_guard lock(mutex_);  // queue order is the order of the jobs' ids
  if (stopping_) return std::unexpected(api::ApiError{api::ErrorKind::unavailable, "unavailable", "the service is stopping"});
  auto created = db_.create_job(job);
  if (!created) return std::unexpected(store_failure(created.error()));
  if (created->created) {
    queue_.emplace_back(created->job.id, request);
    wake_.notify_all();
  }
  return *created;
}

std::expected<store::Job, api::ApiError> Supervisor::cancel(store::Id job_id) {
  bool was_running = false;
  {
    std::lock_guard lock(mutex_);
    for (auto it = queue_.begin(); it != queue_.end(); ++it) {
      if (it->first != job_id) continue;
      queue_.erase(it);
      auto job = db_.update_job(job_id, {store::JobState::cancelled, std::string("cancelled by request"), std::nullopt});
      if (!job) return std::unexpected(store_failure(job.error()));
      return *job;
    }
    if (running_ == job_id) {
      was_running = true;
      cancel_running_ = true;
      if (meter_) meter_->cancel();
    }
  }
  auto job = db_.job(job_id);
  if (!job) return std::unexpected(store_failure(job.error()));
  if (job->state != store::JobState::queued && job->state != store::JobState::running && !was_running)
    return std::unexpected(api::ApiError{api::ErrorKind::conflict, "conflict",
                                         "job " + std::to_string(job_id) + " has already " + std::string(store::to_string(job->state))});
  return *job;
}

void Supervisor::set_state(std::string state) {
  std::lock_guard lock(mutex_);
  state_ = std::move(state);
}

void Supervisor::note_instrument_error(const drivers::InstrumentError& e) {
  using K = drivers::InstrumentError::Kind;
  std::lock_guard lock(mutex_);
  last_error_ = describe(e);
  if (e.kind == K::lost || e.kind == K::no_contact || e.kind == K::transport || e.kind == K::protocol) {
    // Start again from first contact on the next job.
    state_ = "lost";
    meter_.reset();
  } else {
    state_ = meter_ ? "connected" : "disconnected";
  }
}

std::optional<drivers::InstrumentError> Supervisor::ensure_connected() {
  using K = drivers::InstrumentError::Kind;
  {
    std::lock_guard lock(mutex_);
    if (meter_ && meter_->connected()) return std::nullopt;
  }
  auto uri = drivers::parse_connection_uri(device_);
  if (!uri) return drivers::InstrumentError{K::transport, "--device '" + device_ + "': " + uri.error(), -1, {}};
  auto transport = drivers::make_transport(*uri);
  if (!transport) return drivers::InstrumentError{K::transport, transport.error(), -1, {}};
  drivers::DriverOptions options;
  options.style.terminator = uri->terminator;
  auto meter = std::make_shared<drivers::Pr650>(std::move(*transport), options);
  {
    std::lock_guard lock(mutex_);
    meter_ = meter;  // visible to cancel() while connecting
  }
  if (auto ok = meter->connect(); !ok) return ok.error();
  auto identity = meter->identify();
  if (!identity) return identity.error();
  store::Instrument instrument;
  instrument.model = "PR-650";
  instrument.serial_number = identity->serial_number;
  instrument.spectral_configuration = json{{"grid_nm", "380-780/4"}}.dump();
  instrument.connection = device_;
  auto id = db_.ensure_instrument(instrument);
  std::lock_guard lock(mutex_);
  serial_number_ = identity->serial_number;
  if (id) instrument_id_ = *id;
  state_ = "connected";
  spdlog::info("event=instrument_connected device=\"{}\" serial={}", device_, serial_number_);
  return std::nullopt;
}

void Supervisor::run() {
  for (;;) {
    std::pair<store::Id, api::MeasureRequest> next;
    {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
      if (stopping_) return;
      next = queue_.front();
      queue_.pop_front();
      running_ = next.first;
      cancel_running_ = false;
    }
    auto job = db_.update_job(next.first, {store::JobState::running, std::nullopt, std::nullopt});
    Outcome outcome;
    if (!job) {
      outcome = {store::JobState::failed, "database: " + job.error().message, json::object()};
    } else {
      try {
        outcome = execute(*job, next.second);
      } catch (const std::exception& e) {
        outcome = {store::JobState::failed, std::string("internal: ") + e.what(), json::object()};
      }
    }
    {
      std::lock_guard lock(mutex_);
      if (cancel_running_ && outcome.state != store::JobState::succeeded) {
        outcome.state = store::JobState::cancelled;
        if (outcome.error.empty() || outcome.error.rfind("cancelled", 0) == 0) outcome.error = "cancelled by request";
      }
      running_.reset();
      if (state_ == "measuring") state_ = meter_ ? "connected" : "disconnected";
    }
    (void)db_.update_job(next.first, {outcome.state, outcome.error.empty() ? std::nullopt : std::optional<std::string>(outcome.error),
                                      outcome.result.dump()});
    spdlog::info("event=job_finished job={} state={} error=\"{}\"", next.first, store::to_string(outcome.state), outcome.error);
  }
}

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
  for (int i = 0; i < request.count; ++i) {
    auto reading = meter->measure(options);
    if (!reading) {
      note_instrument_error(reading.error());
      return {store::JobState::failed, describe(reading.error()), json{{"readings", i}}};
    }
    readings.push_back(std::move(*reading));
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
