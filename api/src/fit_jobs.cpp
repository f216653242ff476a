#include "fit_jobs.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <nlohmann/json.hpp>

#include "job_updates.hpp"
#include "skinspec/records/import_file.hpp"

namespace skinspec::api {

using nlohmann::json;
using Clock = std::chrono::steady_clock;

namespace {

std::string compact(const json& value) { return value.dump(-1, ' ', false, json::error_handler_t::replace); }

using detail::ended;
using detail::failed;
using detail::stopped_update;

store::JobError job_error(store::JobErrorCode code, std::string message) { return {code, std::move(message)}; }

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

FitJobs::FitJobs(store::Store& store, const Fitter& fitter, JobBoard& board)
    : store_(store), fitter_(fitter), board_(board), worker_([this] { work(); }) {}

FitJobs::~FitJobs() {
  const auto left = board_.close(JobLane::fitting);
  worker_.join();
  // What is still queued never starts. Its record would otherwise be failed as interrupted
  // when the database is next opened; stopped is the truth.
  for (const auto id : left) {
    (void)take_work(id);
    end(id, stopped_update(store::JobErrorCode::stopped));
  }
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
  job.session_id = upload.session_id;
  job.idempotency_key = idempotency_key;
  job.request = compact({{"source", upload.source},
                         {"format", records::to_string(upload.format)},
                         {"scale", to_string(upload.scale)},
                         {"bytes", upload.bytes.size()}});
  return enqueue(JobKind::import, std::move(job), std::move(upload));
}

std::expected<store::CreatedJob, ApiError> FitJobs::submit_refit(const records::RefitRequest& request,
                                                                 const std::string& idempotency_key) {
  if (request.session_id) {
    if (auto session = store_.session(*request.session_id); !session)
      return std::unexpected(from_store_error(session.error()));
  }
  store::Job job;
  // Not the job's session: a refit reads what is stored and is not part of any session's
  // acquisition, so the session's state neither limits it nor is changed by its fate.
  job.idempotency_key = idempotency_key;
  job.request = compact({{"model", std::string(to_string(request.model))},
                         {"session_id", request.session_id ? json(*request.session_id) : json(nullptr)}});
  return enqueue(JobKind::refit, std::move(job), request);
}

std::expected<store::CreatedJob, ApiError> FitJobs::enqueue(JobKind kind, store::Job job, Work work) {
  job.kind = std::string(to_string(kind));
  auto earlier = JobBoard::earlier_job(store_, kind, job.idempotency_key);
  if (!earlier) return std::unexpected(earlier.error());
  if (*earlier) return **earlier;
  const std::size_t bytes = held_bytes(work);
  if (auto refused = hold(bytes)) return std::unexpected(*refused);
  const auto unhold = [&] {
    std::lock_guard lock(mutex_);
    held_bytes_ -= bytes;
  };
  // The record is made without a lock: its write may wait for an import being stored, and
  // followers of the other jobs must not wait with it.
  auto created = store_.create_job(job);
  if (!created || !created->created || board_.closed(JobLane::fitting)) {
    unhold();
    if (!created) return std::unexpected(from_store_error(created.error()));
    if (created->created)  // made as the service stopped: never started
      return std::unexpected(service_stopping());
    return *created;
  }
  const store::Id id = created->job.id;
  {
    std::lock_guard lock(mutex_);
    work_.emplace(id, std::move(work));  // before the worker can take the job
  }
  if (!board_.enqueue(JobLane::fitting, id)) {
    (void)take_work(id);
    return std::unexpected(service_stopping());
  }
  return *created;
}

std::optional<ApiError> FitJobs::hold(std::size_t bytes) {
  if (board_.closed(JobLane::fitting)) return service_stopping();
  std::lock_guard lock(mutex_);
  // Files wait in memory until their turn: more than this, and the next is refused for now.
  if (held_bytes_ + bytes > kMaxHeldBytes)
    return ApiError{ErrorKind::unavailable, "busy",
                    fmt::format("{} MB of files wait to be imported already; send this one when they are done",
                                held_bytes_ / 1000000)};
  held_bytes_ += bytes;
  return std::nullopt;
}

std::optional<FitJobs::Work> FitJobs::take_work(store::Id id) {
  std::lock_guard lock(mutex_);
  auto node = work_.extract(id);
  if (node.empty()) return std::nullopt;
  held_bytes_ -= held_bytes(node.mapped());
  return std::move(node.mapped());
}

std::expected<store::Job, ApiError> FitJobs::cancel(store::Id job_id) {
  if (board_.withdraw(job_id)) {
    (void)take_work(job_id);
    end(job_id, stopped_update(store::JobErrorCode::cancelled));
  } else {
    board_.ask_to_stop(job_id, store::JobErrorCode::cancelled);  // the job ends at its next step
  }
  // Progress first, then the record (as current_job_json): a job that ends between the two
  // reads is then seen ended, not taken for another program's.
  const bool runs_here = board_.progress(job_id).has_value();
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

void FitJobs::work() {
  while (const auto id = board_.take_next(JobLane::fitting)) {
    std::optional<Work> work;
    {
      std::lock_guard lock(mutex_);
      if (auto node = work_.extract(*id); !node.empty()) work = std::move(node.mapped());
    }
    if (!work) {
      release(*id);
      continue;
    }
    run(*id, *work);
    // Its file counted against the limit until it had been imported.
    std::lock_guard lock(mutex_);
    held_bytes_ -= held_bytes(*work);
  }
}

void FitJobs::run(store::Id id, Work& work) {
  auto started = store_.update_job(id, {store::JobState::running, std::nullopt, std::nullopt, store::JobState::queued});
  if (!started) {
    // Cancelled by another program meanwhile (a conflict): not run. Otherwise the record could
    // not be written and stays queued; shown failed while this program runs, and failed as
    // interrupted when the database is next opened.
    if (started.error().kind == store::StoreError::Kind::conflict) return release(id);
    return release(id, job_error(store::JobErrorCode::store, started.error().message));
  }
  // Nothing thrown may leave this thread, which would end the whole service with it.
  try {
    if (const auto* upload = std::get_if<ImportUpload>(&work)) run_import(id, *upload);
    else if (auto* map = std::get_if<MapRequest>(&work)) run_map(id, *map);
    else run_refit(id, std::get<records::RefitRequest>(work));
  } catch (const std::exception& e) {
    end(id, failed(store::JobErrorCode::internal, e.what()));
  }
}

std::size_t FitJobs::held_bytes(const Work& work) {
  if (const auto* upload = std::get_if<ImportUpload>(&work)) return upload->bytes.size();
  if (const auto* map = std::get_if<MapRequest>(&work)) return map->upload_bytes;
  return 0;
}

void FitJobs::run_import(store::Id id, const ImportUpload& upload) {
  if (const auto why = board_.report(id, {0, JobPhase::reading})) return end(id, stopped_update(*why));
  const auto began = Clock::now();
  std::optional<store::JobErrorCode> why;  // the job was asked to stop
  const auto observer = [&](std::size_t fitted, std::size_t total) {
    const double elapsed = std::chrono::duration<double>(Clock::now() - began).count();
    JobProgress p{0, fitted == total ? JobPhase::storing : JobPhase::fitting};
    p.spectra_done = static_cast<std::int64_t>(fitted);
    p.spectra_total = static_cast<std::int64_t>(total);
    p.remaining_s = remaining(elapsed, p.spectra_done, p.spectra_total);
    why = board_.report(id, p);
    return !why;
  };
  const auto imported = records::import_file(store_, fitter_, upload.session_id, upload.bytes, upload.source,
                                             upload.format, observer, id, upload.scale);
  if (!imported) {
    const auto& cause = imported.error().cause;
    const auto code = imported.error().bad_file() ? store::JobErrorCode::bad_file
                                                  : store::job_error_code_of(std::get<store::StoreError>(cause).kind);
    return end(id, failed(code, imported.error().message()));
  }
  if (imported->stopped) return end(id, stopped_update(why.value_or(store::JobErrorCode::stopped)));
  release(id);  // import_file stored the job's end with the spectra
}

void FitJobs::run_refit(store::Id id, const records::RefitRequest& request) {
  auto why = board_.report(id, {0, JobPhase::fitting});
  if (why) return end(id, stopped_update(*why));
  const auto observer = [&](const records::RefitProgress& at) {
    JobProgress p{0, JobPhase::fitting};
    p.spectra_done = at.done + at.failed;
    p.spectra_total = at.total;
    p.remaining_s = at.remaining_s;
    why = board_.report(id, p);
    return !why;
  };
  const auto report = records::refit(store_, fitter_, request, observer);
  if (!report) return end(id, failed(store::job_error_code_of(report.error().kind), report.error().message));
  if (report->stopped)
    return end(id, stopped_update(why.value_or(store::JobErrorCode::stopped), refit_result(*report)));
  end(id, ended(store::JobState::succeeded, std::nullopt, refit_result(*report)));
}

// The job's record ended as `update` says, then its live progress dropped, so that a follower
// never sees the progress gone before the record has ended.
void FitJobs::end(store::Id id, const store::JobUpdate& update) {
  auto recorded = store_.update_job(id, update);
  release(id, recorded ? std::nullopt : std::optional(job_error(store::JobErrorCode::store, recorded.error().message)));
}

void FitJobs::release(store::Id id, std::optional<store::JobError> unrecorded) {
  if (unrecorded)
    spdlog::error("event=job_end_not_stored job={} code={} error=\"{}\"", id, store::to_string(unrecorded->code),
                  unrecorded->message);
  board_.end(id, std::move(unrecorded));
}

}  // namespace skinspec::api
