#include "supervisor.hpp"

#include <algorithm>
#include <utility>

#include <spdlog/spdlog.h>

#include "measure_request.hpp"
#include "supervisor_common.hpp"

namespace skinspec::daemon {

using nlohmann::json;

namespace {

// What a follower is shown for a job whose end the store refused.
store::JobError unrecorded(const store::JobError& end, const store::StoreError& refused) {
  return {store::JobErrorCode::store, "the job ended (" + std::string(store::to_string(end.code)) + ": " + end.message +
                                          ") but the database refused to store it: " + refused.message};
}

void log_unrecorded(store::Id id, const store::JobError& end, const store::StoreError& refused) {
  spdlog::error("event=job_end_not_stored job={} code={} kind={} error=\"{}\"", id, store::to_string(end.code),
                store::to_string(refused.kind), refused.message);
}

}  // namespace

Supervisor::Supervisor(std::string device, store::Store& db, const Fitter& fitter, drivers::ModelChoice model)
    : device_(std::move(device)), model_(model), db_(db), fitter_(fitter) {}

Supervisor::~Supervisor() { stop(); }

void Supervisor::start() {
  std::lock_guard lock(mutex_);
  if (!worker_.joinable()) worker_ = std::thread([this] { run(); });
}

void Supervisor::stop() {
  std::deque<QueuedJob> left;
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    cancel_running_ = store::JobErrorCode::stopped;
    if (meter_) meter_->cancel();
    left.swap(queue_);
  }
  wake_.notify_all();
  if (worker_.joinable()) worker_.join();
  release_meter();
  const auto stopped = cancellation(store::JobErrorCode::stopped);
  for (const auto& queued : left) {
    // A record left queued is failed as interrupted when the database is next opened.
    if (auto refused = record_end(queued.id, stopped, std::nullopt)) log_unrecorded(queued.id, stopped, *refused);
    std::lock_guard lock(mutex_);
    forget_live(queued.id);
    job_changed();
  }
}

// The newer meters stay in remote mode, their keys locked, until they are sent Q: the meter is
// disconnected here, once nothing else can use it, rather than whenever its last owner lets go.
void Supervisor::release_meter() {
  if (connector_.joinable()) connector_.join();  // it ends at stopping_; a connection under way was cancelled
  std::shared_ptr<drivers::Instrument> meter;
  {
    std::lock_guard lock(mutex_);
    meter = std::exchange(meter_, nullptr);
  }
  if (!meter) return;
  std::lock_guard wire(wire_mutex_);
  meter->disconnect();
  spdlog::info("event=instrument_disconnected device=\"{}\"", device_);
}

// What the identified meter takes, or before a meter was reached what the forced model takes
// (any model with auto): a job asking for anything else is refused when it is posted, naming
// what is taken, rather than failed later.
MeterSettings Supervisor::meter_settings() const {
  std::lock_guard lock(mutex_);
  return known_settings();
}

MeterSettings Supervisor::known_settings() const {
  std::optional<drivers::Model> known = model_.forced;
  if (identity_ && identity_->model) known = identity_->model;
  return {drivers::setting_limits(known), apertures_};
}

std::expected<store::CreatedJob, api::ApiError> Supervisor::submit(store::Id session_id,
                                                                   const api::MeasureRequest& request,
                                                                   const std::string& idempotency_key) {
  if (!idempotency_key.empty()) {
    auto earlier = db_.job_by_idempotency_key(idempotency_key);
    if (!earlier) return std::unexpected(api::from_store_error(earlier.error()));
    if (*earlier) return store::CreatedJob{**earlier, false};
  }
  auto session = db_.session(session_id);
  if (!session) return std::unexpected(api::from_store_error(session.error()));
  if (session->state != store::SessionState::open)
    return std::unexpected(api::ApiError{
        api::ErrorKind::conflict, "conflict",
        "session " + std::to_string(session_id) + " is " + std::string(store::to_string(session->state))});
  store::Job job;
  job.kind = std::string(api::to_string(api::JobKind::measure));
  job.session_id = session_id;
  job.idempotency_key = idempotency_key;
  job.request = measure_request_json(request);
  if (owned_elsewhere(*session)) return submit_elsewhere(*session, std::move(job));
  if (auto refused = check_settings(meter_settings(), request)) return std::unexpected(*refused);
  job.bench = bench_;
  std::lock_guard lock(mutex_);  // queue order is the order of the jobs' ids
  if (stopping_)
    return std::unexpected(api::ApiError{api::ErrorKind::unavailable, "unavailable", "the service is stopping"});
  auto created = db_.create_job(job);
  if (!created) return std::unexpected(api::from_store_error(created.error()));
  if (created->created) {
    queue_.push_back({created->job.id, request});
    live_[created->job.id] =
        api::JobProgress{static_cast<int>(queue_.size()), api::JobPhase::queued, 0, request.count, std::nullopt};
    job_changed();
    wake_.notify_all();
  }
  return *created;
}

std::expected<store::Job, api::ApiError> Supervisor::cancel(store::Id job_id) {
  bool was_running = false;
  {
    std::lock_guard lock(mutex_);
    const auto queued = std::ranges::find(queue_, job_id, &QueuedJob::id);
    if (queued != queue_.end()) {
      queue_.erase(queued);
      const auto cancelled = cancellation(store::JobErrorCode::cancelled);
      auto job = db_.update_job(job_id, {store::JobState::cancelled, cancelled, std::nullopt});
      if (job) {
        forget_live(job_id);
      } else {
        // Still queued in the store, where it is failed as interrupted at the next start.
        log_unrecorded(job_id, cancelled, job.error());
        auto& live = live_[job_id];
        live.phase = api::JobPhase::done;
        live.unrecorded_failure = unrecorded(cancelled, job.error());
      }
      job_changed();  // the jobs behind it moved up
      if (!job) return std::unexpected(api::from_store_error(job.error()));
      return *job;
    }
    if (running_ == job_id) {
      was_running = true;
      if (!cancel_running_) cancel_running_ = store::JobErrorCode::cancelled;
      if (meter_) meter_->cancel();
    }
  }
  auto job = db_.job(job_id);
  if (!job) return std::unexpected(api::from_store_error(job.error()));
  // Not in this program's queue: queued for another bench, or for this one and not taken in yet.
  if (!was_running && (job->state == store::JobState::queued || (routes_ && job->bench != bench_)))
    return cancel_elsewhere(*job);
  if (job->state != store::JobState::queued && job->state != store::JobState::running && !was_running)
    return std::unexpected(
        api::ApiError{api::ErrorKind::conflict, "conflict",
                      "job " + std::to_string(job_id) + " has already " + std::string(store::to_string(job->state))});
  return *job;
}

std::optional<std::pair<Supervisor::QueuedJob, Supervisor::Step<store::Job>>> Supervisor::take_next() {
  std::unique_lock lock(mutex_);
  for (;;) {
    wake_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
    if (stopping_) return std::nullopt;
    QueuedJob next = queue_.front();
    queue_.pop_front();
    // Under the lock, so that followers never see the job running in one place and queued in
    // the other.
    auto job = db_.update_job(next.id, {store::JobState::running, std::nullopt, std::nullopt, store::JobState::queued});
    if (!job && job.error().kind == store::StoreError::Kind::conflict) {
      // Cancelled through another bench's program before it started here: nothing to run.
      forget_live(next.id);
      job_changed();
      continue;
    }
    running_ = next.id;
    cancel_running_.reset();
    live_[next.id].phase = api::JobPhase::connecting;
    job_changed();
    return started(next, std::move(job));
  }
}

std::pair<Supervisor::QueuedJob, Supervisor::Step<store::Job>> Supervisor::started(const QueuedJob& next,
                                                                                   store::Result<store::Job> job) {
  if (!job) {
    const store::JobError failure{store::JobErrorCode::store, "the job could not start: " + job.error().message};
    return std::pair{next, Step<store::Job>(std::unexpected(failure))};
  }
  return std::pair{next, Step<store::Job>(std::move(*job))};
}

void Supervisor::run() {
  while (auto next = take_next()) {
    const auto& [queued, job] = *next;
    json partial = json::object();
    const auto outcome = [&]() -> Step<store::CompletedJob> {
      if (!job) return std::unexpected(job.error());
      try {
        return execute(*job, queued.request, partial);
      } catch (const std::exception& e) {
        return std::unexpected(store::JobError{store::JobErrorCode::internal, e.what()});
      }
    }();
    finish(queued.id, outcome, partial);
  }
}

void Supervisor::finish(store::Id id, const Step<store::CompletedJob>& outcome, const json& partial) {
  std::optional<store::JobError> failure;
  if (!outcome) {
    std::lock_guard lock(mutex_);
    failure = cancel_requested() ? cancellation(*cancel_running_) : outcome.error();
    if (failure->code != outcome.error().code)
      spdlog::info("event=job_cancelled job={} while=\"{}: {}\"", id, store::to_string(outcome.error().code),
                   outcome.error().message);
  }
  std::optional<store::StoreError> refused;
  if (failure) refused = record_end(id, *failure, partial.dump());
  {
    std::lock_guard lock(mutex_);
    running_.reset();
    cancel_running_.reset();
    time_left_.reset();
    if (state_ == api::InstrumentState::measuring)
      state_ = meter_ ? api::InstrumentState::connected : api::InstrumentState::disconnected;
    if (refused) {
      // The record stays running (failed as interrupted at the next start); this process shows
      // the job failed meanwhile.
      auto& live = live_[id];
      live.phase = api::JobPhase::done;
      live.unrecorded_failure = unrecorded(*failure, *refused);
    } else {
      forget_live(id);
    }
    job_changed();
  }
  if (outcome) {
    spdlog::info("event=job_finished job={} state=succeeded measurement={} fit={}", id, outcome->ids.measurement_id,
                 outcome->ids.fit_id ? std::to_string(*outcome->ids.fit_id) : "none");
  } else if (refused) {
    log_unrecorded(id, *failure, *refused);
  } else {
    // The service's own failures stand out from the meter's and the operator's.
    const bool ours = failure->code == store::JobErrorCode::store || failure->code == store::JobErrorCode::internal;
    spdlog::log(ours ? spdlog::level::err : spdlog::level::info,
                "event=job_finished job={} state={} code={} error=\"{}\"", id, store::to_string(ended_state(*failure)),
                store::to_string(failure->code), failure->message);
  }
}

std::optional<store::StoreError> Supervisor::record_end(store::Id id, const store::JobError& error,
                                                        std::optional<std::string> result) {
  const auto written = with_retries("job_end", id, [&] {
    return db_.update_job(id, {ended_state(error), error, result});
  });
  if (written) return std::nullopt;
  return written.error();
}

void Supervisor::report_progress(api::JobPhase phase, int readings_done) {
  std::lock_guard lock(mutex_);
  if (!running_) return;
  if (phase != api::JobPhase::measuring) time_left_.reset();
  auto& live = live_[*running_];
  live.phase = phase;
  live.readings_done = readings_done;
  job_changed();
}

void Supervisor::start_reading_clock(std::chrono::milliseconds reading_time, int after) {
  std::lock_guard lock(mutex_);
  time_left_ = TimeLeft{std::chrono::steady_clock::now() + reading_time, reading_time, std::max(after, 0)};
}

void Supervisor::note_firmware_warnings(const std::vector<std::string>& warnings) {
  std::lock_guard lock(mutex_);
  if (!identity_) return;
  for (const auto& warning : warnings) {
    if (std::ranges::find(identity_->warnings, warning) != identity_->warnings.end()) continue;
    identity_->warnings.push_back(warning);
    spdlog::warn("event=instrument_firmware serial={} warning=\"{}\"", identity_->serial_number, warning);
  }
}

void Supervisor::forget_live(store::Id id) {
  live_.erase(id);
  if (routes_) ended_.push_back(id);
}

void Supervisor::job_changed() {
  ++changes_;
  changed_.notify_all();
}

std::optional<api::JobProgress> Supervisor::progress(store::Id job_id) const {
  std::lock_guard lock(mutex_);
  const auto it = live_.find(job_id);
  if (it == live_.end()) {
    const auto remote = remote_.find(job_id);
    if (remote == remote_.end()) return std::nullopt;
    return remote->second;
  }
  return with_position(job_id, it->second);
}

api::JobProgress Supervisor::with_position(store::Id job_id, api::JobProgress live) const {
  live.position = 0;
  // Counted down at every look, not only when a reading ends: at most this long, each command
  // being waited for no longer than its deadline.
  if (running_ == job_id && time_left_ && live.phase == api::JobPhase::measuring) {
    const auto now = std::chrono::steady_clock::now();
    const auto current = std::max(std::chrono::steady_clock::duration::zero(), time_left_->reading_ends - now);
    live.remaining_s =
        std::chrono::duration<double>(current + time_left_->readings_after * time_left_->per_reading).count();
  }
  if (live.phase == api::JobPhase::queued)
    live.position = static_cast<int>(std::ranges::find(queue_, job_id, &QueuedJob::id) - queue_.begin()) + 1;
  return live;
}

std::uint64_t Supervisor::changes() const {
  std::lock_guard lock(mutex_);
  return changes_;
}

std::uint64_t Supervisor::wait_for_change(std::uint64_t seen, std::chrono::milliseconds timeout,
                                          const std::atomic<bool>& abandoned) const {
  std::unique_lock lock(mutex_);
  changed_.wait_for(lock, timeout, [&] { return changes_ > seen || abandoned.load(); });
  return changes_;
}

void Supervisor::wake_waiters() const {
  std::lock_guard lock(mutex_);  // so that a follower between its check and its wait still wakes
  changed_.notify_all();
}

}  // namespace skinspec::daemon
