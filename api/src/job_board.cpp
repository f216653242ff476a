#include "skinspec/api/job_board.hpp"

#include <fmt/format.h>

#include <algorithm>

namespace skinspec::api {

JobLane lane_of(JobKind kind) { return kind == JobKind::measure ? JobLane::instrument : JobLane::fitting; }

store::JobError stop_error(store::JobErrorCode why) {
  if (why == store::JobErrorCode::stopped) return {why, "the service stopped"};
  return {store::JobErrorCode::cancelled, "cancelled by request"};
}

ApiError service_stopping() { return {ErrorKind::unavailable, "unavailable", "the service is stopping"}; }

std::expected<std::optional<store::CreatedJob>, ApiError> JobBoard::earlier_job(const store::Store& db, JobKind kind,
                                                                                const std::string& key) {
  const std::optional<store::CreatedJob> none;
  if (key.empty()) return none;
  auto earlier = db.job_by_idempotency_key(key);
  if (!earlier) return std::unexpected(from_store_error(earlier.error()));
  if (!*earlier) return none;
  if ((*earlier)->kind != to_string(kind))
    return std::unexpected(
        ApiError{ErrorKind::conflict, "conflict",
                 fmt::format("the Idempotency-Key names job {}, a {} job", (*earlier)->id, (*earlier)->kind)});
  return store::CreatedJob{**earlier, false};
}

bool JobBoard::enqueue(JobLane which, store::Id id, const JobProgress& initial) {
  std::lock_guard lock(mutex_);
  Lane& queue = lane(which);
  if (queue.closed || live_.contains(id)) return false;
  // In the order of the jobs' ids, which is the order they were posted in, wherever posted.
  queue.queue.insert(std::ranges::upper_bound(queue.queue, id), id);
  live_[id] = Entry{which, initial, std::nullopt};
  live_[id].progress.phase = JobPhase::queued;
  changed();
  queued_.notify_all();
  return true;
}

bool JobBoard::closed(JobLane which) const {
  std::lock_guard lock(mutex_);
  return lane(which).closed;
}

std::optional<store::Id> JobBoard::take_next(JobLane which) {
  std::unique_lock lock(mutex_);
  Lane& queue = lane(which);
  queued_.wait(lock, [&] { return queue.closed || !queue.queue.empty(); });
  if (queue.closed) return std::nullopt;
  const store::Id id = queue.queue.front();
  queue.queue.pop_front();
  queue.running = id;
  queue.stop_asked.reset();
  changed();  // the others' places moved
  return id;
}

bool JobBoard::withdraw(store::Id id) {
  std::lock_guard lock(mutex_);
  for (Lane& queue : lanes_) {
    const auto at = std::ranges::find(queue.queue, id);
    if (at == queue.queue.end()) continue;
    queue.queue.erase(at);
    changed();  // the jobs behind it moved up
    return true;
  }
  return false;
}

bool JobBoard::ask_to_stop(store::Id id, store::JobErrorCode why) {
  std::lock_guard lock(mutex_);
  Lane* queue = running_lane(id);
  if (queue == nullptr) return false;
  if (!queue->stop_asked) queue->stop_asked = why;
  return true;
}

std::optional<store::JobErrorCode> JobBoard::stop_asked(store::Id id) const {
  std::lock_guard lock(mutex_);
  return why_stop(id);
}

std::vector<store::Id> JobBoard::close(JobLane which) {
  std::lock_guard lock(mutex_);
  Lane& queue = lane(which);
  queue.closed = true;
  if (queue.running) queue.stop_asked = store::JobErrorCode::stopped;
  queued_.notify_all();
  std::vector<store::Id> left(queue.queue.begin(), queue.queue.end());
  queue.queue.clear();
  return left;
}

JobBoard::LaneLoad JobBoard::load(JobLane which) const {
  std::lock_guard lock(mutex_);
  return {lane(which).running, lane(which).queue.size()};
}

bool JobBoard::knows(store::Id id) const {
  std::lock_guard lock(mutex_);
  return live_.contains(id);
}

std::optional<store::JobErrorCode> JobBoard::report(store::Id id, const JobProgress& progress) {
  std::lock_guard lock(mutex_);
  if (const auto it = live_.find(id); it != live_.end()) set_progress(it->second, progress);
  return why_stop(id);
}

std::optional<store::JobErrorCode> JobBoard::report_phase(store::Id id, JobPhase phase, int readings_done) {
  std::lock_guard lock(mutex_);
  if (const auto it = live_.find(id); it != live_.end()) {
    JobProgress progress = it->second.progress;
    progress.phase = phase;
    progress.readings_done = readings_done;
    set_progress(it->second, progress);
  }
  return why_stop(id);
}

void JobBoard::start_countdown(store::Id id, const Countdown& countdown) {
  std::lock_guard lock(mutex_);
  if (const auto it = live_.find(id); it != live_.end()) it->second.countdown = countdown;
}

void JobBoard::end(store::Id id, std::optional<store::JobError> unrecorded) {
  std::lock_guard lock(mutex_);
  const auto it = live_.find(id);
  if (Lane* queue = running_lane(id)) {
    queue->running.reset();
    queue->stop_asked.reset();
  }
  if (it != live_.end()) {
    if (unrecorded) {
      it->second.progress.phase = JobPhase::done;
      it->second.progress.unrecorded_failure = std::move(unrecorded);
      it->second.countdown.reset();
    } else {
      if (Lane& queue = lane(it->second.lane); queue.tracks_ends) queue.ended.push_back(id);
      live_.erase(it);
    }
  }
  changed();
}

std::vector<std::pair<store::Id, store::JobError>> JobBoard::unrecorded_ends() const {
  std::lock_guard lock(mutex_);
  std::vector<std::pair<store::Id, store::JobError>> out;
  for (const auto& [id, entry] : live_)
    if (entry.progress.unrecorded_failure) out.emplace_back(id, *entry.progress.unrecorded_failure);
  return out;
}

void JobBoard::note_remote(store::Id id, std::optional<JobProgress> progress) {
  std::lock_guard lock(mutex_);
  if (progress) remote_[id] = *progress;
  else remote_.erase(id);
  changed();
}

std::vector<store::Id> JobBoard::remote_jobs() const {
  std::lock_guard lock(mutex_);
  std::vector<store::Id> out;
  for (const auto& [id, progress] : remote_) out.push_back(id);
  return out;
}

void JobBoard::track_ends(JobLane which) {
  std::lock_guard lock(mutex_);
  lane(which).tracks_ends = true;
}

JobBoard::LaneJobs JobBoard::take_lane_jobs(JobLane which) {
  LaneJobs out;
  std::lock_guard lock(mutex_);
  for (const auto& [id, entry] : live_) {
    if (entry.lane == which && !entry.progress.unrecorded_failure) out.live.emplace(id, shown(id, entry));
  }
  out.ended.swap(lane(which).ended);
  return out;
}

std::optional<JobProgress> JobBoard::progress(store::Id job_id) const {
  std::lock_guard lock(mutex_);
  if (const auto it = live_.find(job_id); it != live_.end()) return shown(job_id, it->second);
  if (const auto remote = remote_.find(job_id); remote != remote_.end()) return remote->second;
  return std::nullopt;
}

std::uint64_t JobBoard::changes() const {
  std::lock_guard lock(mutex_);
  return changes_;
}

std::uint64_t JobBoard::wait_for_change(std::uint64_t seen, std::chrono::milliseconds timeout,
                                        const std::atomic<bool>& abandoned) const {
  std::unique_lock lock(mutex_);
  changed_.wait_for(lock, timeout, [&] { return changes_ > seen || abandoned.load(); });
  return changes_;
}

void JobBoard::wake_waiters() const {
  std::lock_guard lock(mutex_);  // so that a follower between its check and its wait still wakes
  changed_.notify_all();
}

JobBoard::Lane* JobBoard::running_lane(store::Id id) {
  for (Lane& queue : lanes_)
    if (queue.running == id) return &queue;
  return nullptr;
}

const JobBoard::Lane* JobBoard::running_lane(store::Id id) const {
  for (const Lane& queue : lanes_)
    if (queue.running == id) return &queue;
  return nullptr;
}

std::optional<store::JobErrorCode> JobBoard::why_stop(store::Id id) const {
  const Lane* queue = running_lane(id);
  return queue ? queue->stop_asked : std::nullopt;
}

JobProgress JobBoard::shown(store::Id id, const Entry& entry) const {
  JobProgress out = entry.progress;
  if (out.phase == JobPhase::queued) {
    // Taken from its queue but not yet started, it is next: the end of the queue would be wrong.
    const auto& queue = lane(entry.lane).queue;
    const auto at = std::ranges::find(queue, id);
    out.position = at == queue.end() ? 1 : static_cast<int>(at - queue.begin()) + 1;
    return out;
  }
  out.position = 0;
  if (entry.countdown) {
    const auto now = std::chrono::steady_clock::now();
    const auto current = std::max(std::chrono::steady_clock::duration::zero(), entry.countdown->step_ends - now);
    out.remaining_s =
        std::chrono::duration<double>(current + entry.countdown->steps_after * entry.countdown->per_step).count();
  }
  return out;
}

void JobBoard::set_progress(Entry& entry, const JobProgress& progress) {
  if (progress.phase != entry.progress.phase) entry.countdown.reset();
  entry.progress = progress;
  changed();
}

void JobBoard::changed() {
  ++changes_;
  changed_.notify_all();
}

}  // namespace skinspec::api
