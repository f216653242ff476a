#include "supervisor.hpp"

#include <algorithm>

#include <spdlog/spdlog.h>

#include "supervisor_common.hpp"

namespace skinspec::daemon {

using nlohmann::json;

Supervisor::Supervisor(std::string device, store::Store& db, const Fitter& fitter)
    : device_(std::move(device)), db_(db), fitter_(fitter) {}

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
  std::lock_guard lock(mutex_);
  for (const auto& [id, request] : left) {
    (void)db_.update_job(id, {store::JobState::cancelled, std::string("the service stopped"), std::nullopt});
    live_.erase(id);
  }
  if (!left.empty()) job_changed();
}

std::expected<store::CreatedJob, api::ApiError> Supervisor::submit(store::Id session_id, const api::MeasureRequest& request,
                                                                   const std::string& idempotency_key) {
  if (!idempotency_key.empty()) {
    auto earlier = db_.job_by_idempotency_key(idempotency_key);
    if (!earlier) return std::unexpected(api::from_store_error(earlier.error()));
    if (*earlier) return store::CreatedJob{**earlier, false};
  }
  auto session = db_.session(session_id);
  if (!session) return std::unexpected(api::from_store_error(session.error()));
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
  if (!created) return std::unexpected(api::from_store_error(created.error()));
  if (created->created) {
    queue_.emplace_back(created->job.id, request);
    live_[created->job.id].readings_total = request.count;
    job_changed();
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
      live_.erase(job_id);
      job_changed();  // the jobs behind it moved up
      if (!job) return std::unexpected(api::from_store_error(job.error()));
      return *job;
    }
    if (running_ == job_id) {
      was_running = true;
      cancel_running_ = true;
      if (meter_) meter_->cancel();
    }
  }
  auto job = db_.job(job_id);
  if (!job) return std::unexpected(api::from_store_error(job.error()));
  if (job->state != store::JobState::queued && job->state != store::JobState::running && !was_running)
    return std::unexpected(api::ApiError{api::ErrorKind::conflict, "conflict",
                                         "job " + std::to_string(job_id) + " has already " + std::string(store::to_string(job->state))});
  return *job;
}

void Supervisor::run() {
  for (;;) {
    std::pair<store::Id, api::MeasureRequest> next;
    std::expected<store::Job, store::StoreError> job;
    {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
      if (stopping_) return;
      next = queue_.front();
      queue_.pop_front();
      running_ = next.first;
      cancel_running_ = false;
      // Under the lock, so that followers never see the job running in one place and queued
      // in the other.
      job = db_.update_job(next.first, {store::JobState::running, std::nullopt, std::nullopt});
      live_[next.first].phase = "connecting";
      job_changed();
    }
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
      (void)db_.update_job(next.first, {outcome.state, outcome.error.empty() ? std::nullopt : std::optional<std::string>(outcome.error),
                                        outcome.result.dump()});
      live_.erase(next.first);
      job_changed();
    }
    spdlog::info("event=job_finished job={} state={} error=\"{}\"", next.first, store::to_string(outcome.state), outcome.error);
  }
}

void Supervisor::report_progress(const char* phase, int readings_done) {
  std::lock_guard lock(mutex_);
  if (!running_) return;
  auto& live = live_[*running_];
  live.phase = phase;
  live.readings_done = readings_done;
  job_changed();
}

void Supervisor::job_changed() {
  ++changes_;
  changed_.notify_all();
}

std::optional<api::JobProgress> Supervisor::progress(store::Id job_id) const {
  std::lock_guard lock(mutex_);
  const auto it = live_.find(job_id);
  if (it == live_.end()) return std::nullopt;
  api::JobProgress out{0, it->second.phase, it->second.readings_done, it->second.readings_total};
  if (running_ != job_id) {
    const auto queued = std::find_if(queue_.begin(), queue_.end(), [job_id](const auto& entry) { return entry.first == job_id; });
    out.position = static_cast<int>(queued - queue_.begin()) + 1;
  }
  return out;
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
