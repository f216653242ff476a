// The measurement jobs' queue on the board: their records made, started and ended, and the
// worker that runs them one at a time (the measuring itself: measurement_job.cpp).

#include "measurement_executor.hpp"

#include <spdlog/spdlog.h>

#include <utility>

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

MeasurementExecutor::MeasurementExecutor(store::Store& db, const Fitter& fitter, api::JobBoard& board,
                                         ConnectionKeeper& keeper)
    : db_(db), fitter_(fitter), board_(board), keeper_(keeper) {}

MeasurementExecutor::~MeasurementExecutor() { join(); }

void MeasurementExecutor::start() {
  if (!worker_.joinable()) worker_ = std::thread([this] { run(); });
}

void MeasurementExecutor::join() {
  if (worker_.joinable()) worker_.join();
}

void MeasurementExecutor::end_stopped(const std::vector<store::Id>& never_ran) {
  const auto stopped = cancellation(store::JobErrorCode::stopped);
  for (const auto id : never_ran) {
    // A record left queued is failed as interrupted when the database is next opened.
    if (auto refused = record_end(id, stopped, std::nullopt)) log_unrecorded(id, stopped, *refused);
    board_.end(id);
  }
}

std::expected<store::CreatedJob, api::ApiError> MeasurementExecutor::submit(const store::Job& job, int count) {
  std::lock_guard lock(submit_mutex_);
  if (board_.closed(kLane)) return std::unexpected(api::service_stopping());
  auto created = db_.create_job(job);
  if (!created) return std::unexpected(api::from_store_error(created.error()));
  if (created->created && !board_.enqueue(kLane, created->job.id, {1, api::JobPhase::queued, 0, count, std::nullopt}))
    return std::unexpected(api::service_stopping());  // made as the service stopped: never started
  return *created;
}

std::optional<std::expected<store::Job, api::ApiError>> MeasurementExecutor::withdraw(store::Id id) {
  if (!board_.withdraw(id)) return std::nullopt;
  const auto cancelled = cancellation(store::JobErrorCode::cancelled);
  auto job = db_.update_job(id, {store::JobState::cancelled, cancelled, std::nullopt});
  if (job) {
    board_.end(id);
    return *job;
  }
  // Still queued in the store, where it is failed as interrupted at the next start.
  log_unrecorded(id, cancelled, job.error());
  board_.end(id, unrecorded(cancelled, job.error()));
  return std::unexpected(api::from_store_error(job.error()));
}

bool MeasurementExecutor::ask_to_stop(store::Id id) {
  if (!board_.ask_to_stop(id, store::JobErrorCode::cancelled)) return false;
  keeper_.interrupt();
  return true;
}

std::optional<store::JobError> MeasurementExecutor::stop_requested(store::Id id) const {
  const auto why = board_.stop_asked(id);
  if (!why) return std::nullopt;
  return cancellation(*why);
}

std::optional<MeasurementExecutor::Step<store::Job>> MeasurementExecutor::begin(store::Id id) {
  auto job = db_.update_job(id, {store::JobState::running, std::nullopt, std::nullopt, store::JobState::queued});
  if (!job && job.error().kind == store::StoreError::Kind::conflict) {
    // Cancelled through another bench's program before it started here: nothing to run.
    board_.end(id);
    return std::nullopt;
  }
  // Its record written first, as a follower reads the progress before the record.
  board_.report_phase(id, api::JobPhase::connecting, 0);
  if (!job)
    return Step<store::Job>(std::unexpected(
        store::JobError{store::JobErrorCode::store, "the job could not start: " + job.error().message}));
  return Step<store::Job>(std::move(*job));
}

void MeasurementExecutor::run() {
  while (const auto id = board_.take_next(kLane)) {
    const auto job = begin(*id);
    if (!job) continue;
    json partial = json::object();
    const auto outcome = [&]() -> Step<store::CompletedJob> {
      if (!*job) return std::unexpected(job->error());
      try {
        return execute(**job, partial);
      } catch (const std::exception& e) {
        return std::unexpected(store::JobError{store::JobErrorCode::internal, e.what()});
      }
    }();
    finish(*id, outcome, partial);
  }
}

MeasurementExecutor::Step<store::CompletedJob> MeasurementExecutor::execute(const store::Job& job, json& partial) {
  // The request as its record keeps it, whichever program took the job.
  const auto request = parse_measure_request(job.request);
  if (!request)
    return std::unexpected(store::JobError{store::JobErrorCode::internal, "its request is not a measurement's"});
  return measure(job, *request, partial);
}

void MeasurementExecutor::finish(store::Id id, const Step<store::CompletedJob>& outcome, const json& partial) {
  std::optional<store::JobError> failure;
  if (!outcome) {
    failure = stop_requested(id).value_or(outcome.error());
    if (failure->code != outcome.error().code)
      spdlog::info("event=job_cancelled job={} while=\"{}: {}\"", id, store::to_string(outcome.error().code),
                   outcome.error().message);
  }
  std::optional<store::StoreError> refused;
  if (failure) refused = record_end(id, *failure, partial.dump());
  keeper_.end_measuring();
  // With a refusal the record stays running (failed as interrupted at the next start); this
  // process shows the job failed meanwhile.
  board_.end(id, refused ? std::optional(unrecorded(*failure, *refused)) : std::nullopt);
  if (outcome) {
    spdlog::info("event=job_finished job={} state=succeeded measurement={} fit={}", id, outcome->ids.measurement_id,
                 outcome->ids.fit_id ? std::to_string(*outcome->ids.fit_id) : "none");
  } else if (refused) {
    log_unrecorded(id, *failure, *refused);
  } else {
    // The service's own failures stand out from the meter's and the operator's.
    const bool ours = failure->code == store::JobErrorCode::store ||
                      failure->code == store::JobErrorCode::storage_full ||
                      failure->code == store::JobErrorCode::internal;
    spdlog::log(ours ? spdlog::level::err : spdlog::level::info,
                "event=job_finished job={} state={} code={} error=\"{}\"", id, store::to_string(ended_state(*failure)),
                store::to_string(failure->code), failure->message);
  }
}

std::optional<store::StoreError> MeasurementExecutor::record_end(store::Id id, const store::JobError& error,
                                                                 std::optional<std::string> result) {
  const auto written = outlasting_outages(
      "job_end", id, [&] { return db_.update_job(id, {ended_state(error), error, result}); },
      [this] { return board_.closed(kLane); });
  if (written) return std::nullopt;
  return written.error();
}

}  // namespace skinspec::daemon
