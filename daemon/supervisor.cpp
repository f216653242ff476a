#include "supervisor.hpp"

#include <spdlog/spdlog.h>

#include <utility>

#include "measure_request.hpp"
#include "meter_settings.hpp"

namespace skinspec::daemon {

using nlohmann::json;

Supervisor::Supervisor(std::string device, store::Store& db, const Fitter& fitter, drivers::ModelChoice model,
                       std::shared_ptr<api::JobBoard> board)
    : db_(db),
      board_(board ? std::move(board) : std::make_shared<api::JobBoard>()),
      keeper_(std::move(device), model, db,
              [jobs = board_.get()] {
                const auto load = jobs->load(api::JobLane::instrument);
                return load.running || load.queued > 0;
              }),
      executor_(db, fitter, *board_, keeper_),
      routes_(db, *board_) {}

Supervisor::~Supervisor() { stop(); }

void Supervisor::stop() {
  const auto never_ran = board_->close(api::JobLane::instrument);  // the running job asked to stop
  keeper_.stop();                                                  // and its exchange with the meter cancelled
  executor_.join();
  keeper_.release_meter();
  executor_.end_stopped(never_ran);
}

json Supervisor::instrument_status() const {
  json status = keeper_.status();
  const auto load = board_->load(api::JobLane::instrument);
  status["running_job"] = load.running ? json(*load.running) : json(nullptr);
  status["queued"] = load.queued;
  return status;
}

json Supervisor::ports() const { return ports_json(drivers::list_ports()); }

std::expected<store::CreatedJob, api::ApiError> Supervisor::submit(store::Id session_id,
                                                                   const api::MeasureRequest& request,
                                                                   const std::string& idempotency_key) {
  auto earlier = api::JobBoard::earlier_job(db_, api::JobKind::measure, idempotency_key);
  if (!earlier) return std::unexpected(earlier.error());
  if (*earlier) return **earlier;
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
  if (routes_.owned_elsewhere(*session)) return routes_.submit_elsewhere(*session, std::move(job));
  if (auto refused = check_settings(keeper_.settings(), request)) return std::unexpected(*refused);
  job.bench = routes_.bench();
  return executor_.submit(job, request.count);
}

std::expected<store::Job, api::ApiError> Supervisor::cancel(store::Id job_id) {
  if (auto withdrawn = executor_.withdraw(job_id)) return std::move(*withdrawn);
  const bool was_running = executor_.ask_to_stop(job_id);
  auto job = db_.job(job_id);
  if (!job) return std::unexpected(api::from_store_error(job.error()));
  // Not in this program's queue: queued for another bench, or for this one and not taken in yet.
  if (!was_running && routes_.runs_elsewhere(*job)) return routes_.cancel_elsewhere(*job);
  if (job->state != store::JobState::queued && job->state != store::JobState::running && !was_running)
    return std::unexpected(
        api::ApiError{api::ErrorKind::conflict, "conflict",
                      "job " + std::to_string(job_id) + " has already " + std::string(store::to_string(job->state))});
  return *job;
}

// Interrupted rather than the end the job was shown: what made that end (readings, a cancel) is
// not kept past the refusal.
void Supervisor::record_unrecorded_ends() {
  using Kind = store::StoreError::Kind;
  for (const auto& [id, shown] : board_->unrecorded_ends()) {
    const store::JobError error{store::JobErrorCode::interrupted, "its end could not be stored then: " + shown.message};
    auto written = db_.update_job(id, {store::JobState::failed, error, std::nullopt});
    if (!written && written.error().kind != Kind::conflict && written.error().kind != Kind::not_found) continue;
    spdlog::info("event=job_end_stored_late job={} state={}", id,
                 written ? store::to_string(written->state) : std::string_view("ended elsewhere"));
    board_->end(id);
  }
}

void Supervisor::cancel_here(store::Id job_id) {
  if (!board_->knows(job_id)) return;
  if (auto cancelled = cancel(job_id); !cancelled)
    spdlog::warn("event=cancel_failed job={} error=\"{}\"", job_id, cancelled.error().message);
}

}  // namespace skinspec::daemon
