#include "bench_routes.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>

#include "bench_channels.hpp"
#include "measure_policy.hpp"
#include "measure_request.hpp"
#include "supervisor_common.hpp"

namespace skinspec::daemon {

using nlohmann::json;

void BenchRoutes::set_bench(std::string name, bool routes) {
  bench_ = std::move(name);
  routes_ = routes;
  // Told to the other programs as they end, even those never published live.
  if (routes_) board_.track_ends(api::JobLane::instrument);
}

bool BenchRoutes::owned_elsewhere(const store::Session& session) const {
  return routes_ && !session.bench.empty() && session.bench != bench_;
}

bool BenchRoutes::runs_elsewhere(const store::Job& job) const {
  return job.state == store::JobState::queued || (routes_ && job.bench != bench_);
}

std::expected<store::CreatedJob, api::ApiError> BenchRoutes::submit_elsewhere(const store::Session& session,
                                                                              store::Job job) {
  auto benches = db_.benches();
  if (!benches) return std::unexpected(api::from_store_error(benches.error()));
  const auto now = db_.database_time();
  if (!now) return std::unexpected(api::from_store_error(now.error()));
  const auto owner = std::ranges::find(*benches, session.bench, &store::Bench::name);
  if (owner == benches->end() || !store::bench_running(*owner, *now))
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

std::expected<store::Job, api::ApiError> BenchRoutes::cancel_elsewhere(const store::Job& job) {
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

void BenchRoutes::adopt(const store::Job& job) {
  if (api::parse_job_kind(job.kind) != api::JobKind::measure) return;  // not the instrument's work
  if (job.state != store::JobState::queued || board_.knows(job.id)) return;
  const auto request = parse_measure_request(job.request);
  if (!request) {
    spdlog::error("event=job_not_adopted job={} error=\"its request is not a measurement's\"", job.id);
    return;
  }
  if (!board_.enqueue(api::JobLane::instrument, job.id, {1, api::JobPhase::queued, 0, request->count, std::nullopt}))
    return;  // stopping, or taken in meanwhile
  spdlog::info("event=job_adopted job={} session={}", job.id, job.session_id.value_or(0));
}

}  // namespace skinspec::daemon
