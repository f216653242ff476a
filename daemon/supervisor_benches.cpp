// The supervisor among the benches of one database (docs/store.md, "Benches"): jobs for another
// bench's sessions are queued for that bench, jobs queued here by others are taken in, and
// other benches' progress is shown to this program's followers.

#include <algorithm>

#include <spdlog/spdlog.h>

#include "bench_channels.hpp"
#include "measure_request.hpp"
#include "supervisor.hpp"
#include "supervisor_common.hpp"

namespace skinspec::daemon {

using nlohmann::json;

void Supervisor::set_bench(std::string name, bool routes) {
  std::lock_guard lock(mutex_);
  bench_ = std::move(name);
  routes_ = routes;
}

bool Supervisor::owned_elsewhere(const store::Session& session) const {
  return routes_ && !session.bench.empty() && session.bench != bench_;
}

// Queued for the owner while it runs, so that it measures with its own meter; refused while it
// does not, so that a job never waits for a bench that may not come back.
std::expected<store::CreatedJob, api::ApiError> Supervisor::submit_elsewhere(const store::Session& session,
                                                                             store::Job job) {
  auto benches = db_.benches();
  if (!benches) return std::unexpected(api::from_store_error(benches.error()));
  const auto owner = std::ranges::find(*benches, session.bench, &store::Bench::name);
  if (owner == benches->end() || !store::bench_running(*owner, to_store_time(std::chrono::system_clock::now())))
    return std::unexpected(api::ApiError{
        api::ErrorKind::conflict, "bench_not_running",
        fmt::format("session {} belongs to bench {}, whose skinspecd is not running", session.id, session.bench)});
  job.bench = session.bench;
  auto created = db_.create_job(job);
  if (!created) return std::unexpected(api::from_store_error(created.error()));
  if (created->created) {
    // The owner also looks for its queued jobs at every heartbeat: a lost notice only delays.
    if (auto sent = db_.notify(std::string(kJobsChannel), session.bench); !sent)
      spdlog::warn("event=notify_failed job={} error=\"{}\"", created->job.id, sent.error().message);
    spdlog::info("event=job_queued_elsewhere job={} bench={}", created->job.id, session.bench);
  }
  return *created;
}

std::expected<store::Job, api::ApiError> Supervisor::cancel_elsewhere(const store::Job& job) {
  if (job.state == store::JobState::queued) {
    auto cancelled = db_.update_job(job.id, {store::JobState::cancelled, cancellation(store::JobErrorCode::cancelled),
                                             std::nullopt, store::JobState::queued});
    if (cancelled) return *cancelled;
    if (cancelled.error().kind != store::StoreError::Kind::conflict)
      return std::unexpected(api::from_store_error(cancelled.error()));
  }
  auto now = db_.job(job.id);
  if (!now) return std::unexpected(api::from_store_error(now.error()));
  if (now->state != store::JobState::running)
    return std::unexpected(
        api::ApiError{api::ErrorKind::conflict, "conflict",
                      "job " + std::to_string(job.id) + " has already " + std::string(store::to_string(now->state))});
  if (auto sent = db_.notify(std::string(kJobsChannel), cancel_notice(job.id)); !sent)
    return std::unexpected(api::from_store_error(sent.error()));
  return *now;
}

bool Supervisor::known_here(store::Id job_id) const {
  return running_ == job_id || live_.contains(job_id) ||
         std::ranges::find(queue_, job_id, &QueuedJob::id) != queue_.end();
}

void Supervisor::adopt(const store::Job& job) {
  if (api::parse_job_kind(job.kind) != api::JobKind::measure) return;  // not the instrument's work
  const auto request = parse_measure_request(job.request);
  std::lock_guard lock(mutex_);
  if (stopping_ || job.state != store::JobState::queued || known_here(job.id)) return;
  if (!request) {
    spdlog::error("event=job_not_adopted job={} error=\"its request is not a measurement's\"", job.id);
    return;
  }
  const auto at = std::ranges::upper_bound(queue_, job.id, {}, &QueuedJob::id);
  const auto position = static_cast<int>(at - queue_.begin()) + 1;
  queue_.insert(at, {job.id, *request});
  live_[job.id] = api::JobProgress{position, api::JobPhase::queued, 0, request->count, std::nullopt};
  spdlog::info("event=job_adopted job={} session={}", job.id, job.session_id.value_or(0));
  job_changed();
  wake_.notify_all();
}

void Supervisor::note_remote(store::Id job_id, std::optional<api::JobProgress> progress) {
  std::lock_guard lock(mutex_);
  if (progress) {
    remote_[job_id] = *progress;
  } else {
    remote_.erase(job_id);
  }
  job_changed();
}

Supervisor::LocalJobs Supervisor::local_jobs() {
  LocalJobs out;
  std::lock_guard lock(mutex_);
  for (const auto& [id, live] : live_) {
    if (!live.unrecorded_failure) out.live.emplace(id, with_position(id, live));
  }
  out.ended.swap(ended_);
  return out;
}

std::vector<store::Id> Supervisor::remote_jobs() const {
  std::lock_guard lock(mutex_);
  std::vector<store::Id> out;
  for (const auto& [id, progress] : remote_) out.push_back(id);
  return out;
}

void Supervisor::cancel_here(store::Id job_id) {
  {
    std::lock_guard lock(mutex_);
    if (!known_here(job_id)) return;
  }
  if (auto cancelled = cancel(job_id); !cancelled)
    spdlog::warn("event=cancel_failed job={} error=\"{}\"", job_id, cancelled.error().message);
}

}  // namespace skinspec::daemon
