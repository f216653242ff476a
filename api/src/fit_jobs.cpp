#include "fit_jobs.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <nlohmann/json.hpp>

#include "skinspec/records/import_file.hpp"

namespace skinspec::api {

using nlohmann::json;
using Clock = std::chrono::steady_clock;

namespace {

std::string compact(const json& value) { return value.dump(-1, ' ', false, json::error_handler_t::replace); }

store::JobError job_error(store::JobErrorCode code, std::string message) { return {code, std::move(message)}; }

store::JobUpdate ended(store::JobState state, std::optional<store::JobError> error,
                       std::optional<std::string> result = std::nullopt) {
  return {state, std::move(error), std::move(result), std::nullopt};
}

// The end of a job told to stop: cancelled by request, or by the service stopping.
store::JobUpdate stopped_update(bool by_request, std::optional<std::string> result = std::nullopt) {
  return ended(store::JobState::cancelled,
               by_request ? job_error(store::JobErrorCode::cancelled, "cancelled by request")
                          : job_error(store::JobErrorCode::stopped, "the service stopped"),
               std::move(result));
}

// What a refit did, as its job's result.
std::string refit_result(const records::RefitReport& report) {
  return compact({{"refitted", report.progress.done},
                  {"failed", report.progress.failed},
                  {"total", report.progress.total},
                  {"failures", report.failures}});
}

// The seconds left when `done` of `total` took `elapsed` seconds; none before any is done.
std::optional<double> remaining(double elapsed, std::int64_t done, std::int64_t total) {
  if (done <= 0) return std::nullopt;
  return elapsed * static_cast<double>(total - done) / static_cast<double>(done);
}

}  // namespace

FitJobs::FitJobs(store::Store& store, const Fitter& fitter)
    : store_(store), fitter_(fitter), worker_([this] { work(); }) {}

FitJobs::~FitJobs() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    wake_.notify_all();
  }
  worker_.join();
}

std::expected<store::CreatedJob, ApiError> FitJobs::submit_import(ImportUpload upload,
                                                                  const std::string& idempotency_key) {
  auto session = store_.session(upload.session_id);
  if (!session) return std::unexpected(from_store_error(session.error()));
  if (session->state != store::SessionState::open)
    return std::unexpected(
        ApiError{ErrorKind::conflict, "conflict",
                 fmt::format("session {} is {}, not open", upload.session_id, store::to_string(session->state))});
  store::Job job;
  job.kind = std::string(to_string(JobKind::import));
  job.session_id = upload.session_id;
  job.idempotency_key = idempotency_key;
  job.request = compact({{"source", upload.source},
                         {"format", records::to_string(upload.format)},
                         {"scale", to_string(upload.scale)},
                         {"bytes", upload.bytes.size()}});
  return enqueue(std::move(job), std::move(upload));
}

std::expected<store::CreatedJob, ApiError> FitJobs::submit_refit(const records::RefitRequest& request,
                                                                 const std::string& idempotency_key) {
  if (request.session_id) {
    if (auto session = store_.session(*request.session_id); !session)
      return std::unexpected(from_store_error(session.error()));
  }
  store::Job job;
  job.kind = std::string(to_string(JobKind::refit));
  // Not the job's session: a refit reads what is stored and is not part of any session's
  // acquisition, so the session's state neither limits it nor is changed by its fate.
  job.idempotency_key = idempotency_key;
  job.request = compact({{"model", std::string(to_string(request.model))},
                         {"session_id", request.session_id ? json(*request.session_id) : json(nullptr)}});
  return enqueue(std::move(job), request);
}

std::expected<store::CreatedJob, ApiError> FitJobs::enqueue(store::Job job,
                                                            std::variant<ImportUpload, records::RefitRequest> work) {
  if (!job.idempotency_key.empty()) {
    auto earlier = store_.job_by_idempotency_key(job.idempotency_key);
    if (!earlier) return std::unexpected(from_store_error(earlier.error()));
    if (*earlier && (*earlier)->kind != job.kind)
      return std::unexpected(
          ApiError{ErrorKind::conflict, "conflict",
                   fmt::format("the Idempotency-Key names job {}, a {} job", (*earlier)->id, (*earlier)->kind)});
    if (*earlier) return store::CreatedJob{**earlier, false};
  }
  const std::size_t bytes = held_bytes(work);
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return std::unexpected(ApiError{ErrorKind::unavailable, "unavailable", "the service is stopping"});
    // Files wait in memory until their turn: more than this, and the next is refused for now.
    if (held_bytes_ + bytes > kMaxHeldBytes)
      return std::unexpected(
          ApiError{ErrorKind::unavailable, "busy",
                   fmt::format("{} MB of files wait to be imported already; send this one when they are done",
                               held_bytes_ / 1000000)});
    held_bytes_ += bytes;
  }
  // The record is made without the lock: its write may wait for an import being stored, and
  // followers of the other jobs must not wait with it.
  auto created = store_.create_job(job);
  std::lock_guard lock(mutex_);
  if (!created || !created->created || stopping_) {
    held_bytes_ -= bytes;
    if (!created) return std::unexpected(from_store_error(created.error()));
    if (created->created)  // made as the service stopped: never started
      return std::unexpected(ApiError{ErrorKind::unavailable, "unavailable", "the service is stopping"});
    return *created;
  }
  // In the order of the jobs' ids, which is the order they were posted in.
  const auto at = std::ranges::upper_bound(queue_, created->job.id, {}, &Queued::id);
  queue_.insert(at, {created->job.id, std::move(work)});
  live_[created->job.id] = JobProgress{};
  changed();
  wake_.notify_all();
  return *created;
}

std::expected<store::Job, ApiError> FitJobs::cancel(store::Id job_id) {
  {
    std::unique_lock lock(mutex_);
    const auto queued = std::ranges::find(queue_, job_id, &Queued::id);
    if (queued != queue_.end()) {
      held_bytes_ -= held_bytes(queued->work);
      queue_.erase(queued);
      lock.unlock();
      end(job_id, stopped_update(true));
    } else if (running_ == job_id) {
      cancel_running_ = true;  // the job ends at its next step
    }
  }
  // Progress first, then the record (as current_job_json): a job that ends between the two
  // reads is then seen ended, not taken for another program's.
  const bool runs_here = progress(job_id).has_value();
  auto job = store_.job(job_id);
  if (!job) return std::unexpected(from_store_error(job.error()));
  if (job->state == store::JobState::queued || job->state == store::JobState::running) {
    if (!runs_here)
      return std::unexpected(ApiError{
          ErrorKind::conflict, "conflict",
          fmt::format("job {} is run by the skinspecd of bench '{}': cancel it through that one", job_id, job->bench)});
    return *job;
  }
  if (job->error && job->error->code == store::JobErrorCode::cancelled) return *job;
  return std::unexpected(ApiError{ErrorKind::conflict, "conflict",
                                  fmt::format("job {} has already {}", job_id, store::to_string(job->state))});
}

std::optional<JobProgress> FitJobs::progress(store::Id job_id) const {
  std::lock_guard lock(mutex_);
  const auto it = live_.find(job_id);
  if (it == live_.end()) return std::nullopt;
  JobProgress out = it->second;
  if (out.phase == JobPhase::queued) {
    // Taken from the queue but not yet started, it is next: the end of the queue would be wrong.
    const auto at = std::ranges::find(queue_, job_id, &Queued::id);
    out.position = at == queue_.end() ? 1 : static_cast<int>(at - queue_.begin()) + 1;
  }
  return out;
}

std::uint64_t FitJobs::changes() const {
  std::lock_guard lock(mutex_);
  return changes_;
}

std::uint64_t FitJobs::wait_for_change(std::uint64_t seen, std::chrono::milliseconds timeout,
                                       const std::atomic<bool>& abandoned) const {
  std::unique_lock lock(mutex_);
  change_.wait_for(lock, timeout, [&] { return changes_ > seen || abandoned; });
  return changes_;
}

void FitJobs::wake_waiters() const {
  std::lock_guard lock(mutex_);
  change_.notify_all();
}

void FitJobs::changed() {
  ++changes_;
  change_.notify_all();
}

void FitJobs::work() {
  for (;;) {
    Queued job;
    {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
      if (stopping_) break;
      job = std::move(queue_.front());
      queue_.pop_front();
      running_ = job.id;
      cancel_running_ = false;
      changed();  // the others' places moved
    }
    run(job);
    std::lock_guard lock(mutex_);
    held_bytes_ -= held_bytes(job.work);
    running_ = 0;
  }
  // What is still queued never starts. Its record would otherwise be failed as interrupted
  // when the database is next opened; stopped is the truth.
  std::deque<Queued> left;
  {
    std::lock_guard lock(mutex_);
    left.swap(queue_);
  }
  for (const auto& job : left) end(job.id, stopped_update(false));
}

void FitJobs::run(const Queued& job) {
  auto started =
      store_.update_job(job.id, {store::JobState::running, std::nullopt, std::nullopt, store::JobState::queued});
  if (!started) {
    // Cancelled by another program meanwhile (a conflict): not run. Otherwise the record could
    // not be written and stays queued; shown failed while this program runs, and failed as
    // interrupted when the database is next opened.
    if (started.error().kind == store::StoreError::Kind::conflict) return release(job.id);
    return release(job.id, job_error(store::JobErrorCode::store, started.error().message));
  }
  // Nothing thrown may leave this thread, which would end the whole service with it.
  try {
    if (const auto* upload = std::get_if<ImportUpload>(&job.work)) run_import(job.id, *upload);
    else run_refit(job.id, std::get<records::RefitRequest>(job.work));
  } catch (const std::exception& e) {
    end(job.id, ended(store::JobState::failed, job_error(store::JobErrorCode::internal, e.what())));
  }
}

std::size_t FitJobs::held_bytes(const std::variant<ImportUpload, records::RefitRequest>& work) {
  const auto* upload = std::get_if<ImportUpload>(&work);
  return upload ? upload->bytes.size() : 0;
}

FitJobs::Verdict FitJobs::report(store::Id id, const JobProgress& progress) {
  std::lock_guard lock(mutex_);
  live_[id] = progress;
  changed();
  if (stopping_) return Verdict::stopped;
  return cancel_running_ ? Verdict::cancelled : Verdict::go_on;
}

void FitJobs::run_import(store::Id id, const ImportUpload& upload) {
  if (const auto first = report(id, {0, JobPhase::reading}); first != Verdict::go_on)
    return end(id, stopped_update(first == Verdict::cancelled));
  const auto began = Clock::now();
  auto verdict = Verdict::go_on;
  const auto observer = [&](std::size_t fitted, std::size_t total) {
    const double elapsed = std::chrono::duration<double>(Clock::now() - began).count();
    JobProgress p{0, fitted == total ? JobPhase::storing : JobPhase::fitting};
    p.spectra_done = static_cast<std::int64_t>(fitted);
    p.spectra_total = static_cast<std::int64_t>(total);
    p.remaining_s = remaining(elapsed, p.spectra_done, p.spectra_total);
    verdict = report(id, p);
    return verdict == Verdict::go_on;
  };
  const auto imported = records::import_file(store_, fitter_, upload.session_id, upload.bytes, upload.source,
                                             upload.format, observer, id, upload.scale);
  if (!imported) {
    const auto code = imported.error().bad_file() ? store::JobErrorCode::bad_file : store::JobErrorCode::store;
    return end(id, ended(store::JobState::failed, job_error(code, imported.error().message())));
  }
  if (imported->stopped) return end(id, stopped_update(verdict == Verdict::cancelled));
  release(id);  // import_file stored the job's end with the spectra
}

void FitJobs::run_refit(store::Id id, const records::RefitRequest& request) {
  auto verdict = report(id, {0, JobPhase::fitting});
  if (verdict != Verdict::go_on) return end(id, stopped_update(verdict == Verdict::cancelled));
  const auto observer = [&](const records::RefitProgress& at) {
    JobProgress p{0, JobPhase::fitting};
    p.spectra_done = at.done + at.failed;
    p.spectra_total = at.total;
    p.remaining_s = at.remaining_s;
    verdict = report(id, p);
    return verdict == Verdict::go_on;
  };
  const auto report = records::refit(store_, fitter_, request, observer);
  if (!report)
    return end(id, ended(store::JobState::failed, job_error(store::JobErrorCode::store, report.error().message)));
  if (report->stopped) return end(id, stopped_update(verdict == Verdict::cancelled, refit_result(*report)));
  end(id, ended(store::JobState::succeeded, std::nullopt, refit_result(*report)));
}

// The job's record ended as `update` says, then its live progress dropped, so that a follower
// never sees the progress gone before the record has ended.
void FitJobs::end(store::Id id, const store::JobUpdate& update) {
  auto recorded = store_.update_job(id, update);
  release(id, recorded ? std::nullopt : std::optional(job_error(store::JobErrorCode::store, recorded.error().message)));
}

void FitJobs::release(store::Id id, std::optional<store::JobError> unrecorded) {
  std::lock_guard lock(mutex_);
  if (unrecorded) live_[id].unrecorded_failure = std::move(unrecorded);
  else live_.erase(id);
  changed();
}

}  // namespace skinspec::api
