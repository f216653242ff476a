// Jobs as the API shows them: the store's record with the acquisition's live position and
// progress, and the Server-Sent Events that follow one job until it ends.

#include "jobs.hpp"

#include "json_io.hpp"
#include "text.hpp"

namespace skinspec::api {

using nlohmann::json;

namespace {

bool finished(store::JobState state) {
  return state == store::JobState::succeeded || state == store::JobState::failed || state == store::JobState::cancelled;
}

json progress_json(const std::string& phase, int done, int total, double fraction) {
  return {{"phase", phase}, {"readings_done", done}, {"readings_total", total}, {"fraction", fraction}};
}

// Measuring takes most of a job's time: it covers 0 to 0.9, reading by reading; fitting and
// storing the rest.
double measuring_fraction(int done, int total) { return total > 0 ? 0.9 * done / total : 0.0; }

json live_progress(const JobProgress& p) {
  double fraction = measuring_fraction(p.readings_done, p.readings_total);
  if (p.phase == "fitting") fraction = 0.9;
  if (p.phase == "storing") fraction = 0.95;
  return progress_json(p.phase, p.readings_done, p.readings_total, fraction);
}

// A job nobody here runs any more (or not yet): what its record says.
json stored_progress(const store::Job& job, const json& request, const json& result) {
  const auto integer = [](const json& object, const char* key, int fallback) {
    const auto it = object.is_object() ? object.find(key) : object.end();
    return it != object.end() && it->is_number_integer() ? it->get<int>() : fallback;
  };
  const int total = integer(request, "count", 1);
  switch (job.state) {
    case store::JobState::succeeded: return progress_json("done", total, total, 1.0);
    case store::JobState::queued: return progress_json("queued", 0, total, 0.0);
    case store::JobState::running: return progress_json("measuring", 0, total, 0.0);
    default: {
      const int done = integer(result, "readings", 0);
      return progress_json("done", done, total, measuring_fraction(done, total));
    }
  }
}

std::string sse_event(std::uint64_t id, const json& job) {
  return "id: " + std::to_string(id) + "\nevent: job\ndata: " + detail::dump(job) + "\n\n";
}

}  // namespace

json job_json(const store::Job& job, const std::optional<JobProgress>& live) {
  json result = json::parse(job.result, nullptr, false);
  json request = json::parse(job.request, nullptr, false);
  if (result.is_discarded()) result = json::object();
  if (request.is_discarded()) request = json::object();
  // A finished job's record wins over live progress that has not been cleared yet.
  const bool use_live = live && !finished(job.state);
  return {{"id", job.id},
          {"job_id", job.id},
          {"kind", job.kind},
          {"session_id", job.session_id ? json(*job.session_id) : json(nullptr)},
          {"state", std::string(store::to_string(job.state))},
          {"position", use_live ? json(live->position) : json(nullptr)},
          {"progress", use_live ? live_progress(*live) : stored_progress(job, request, result)},
          {"error", job.error.empty() ? json(nullptr) : json(job.error)},
          {"request", request},
          {"result", result},
          {"idempotency_key", job.idempotency_key.empty() ? json(nullptr) : json(job.idempotency_key)},
          {"created_at", detail::format_time(job.created_at)},
          {"started_at", job.started_at ? json(detail::format_time(*job.started_at)) : json(nullptr)},
          {"finished_at", job.finished_at ? json(detail::format_time(*job.finished_at)) : json(nullptr)}};
}

JobEvents::JobEvents(const store::Store& db, const Acquisition* acquisition, store::Id job_id)
    : db_(db), acquisition_(acquisition), job_id_(job_id) {}

std::optional<std::string> JobEvents::next(std::chrono::milliseconds keep_alive) {
  using clock = std::chrono::steady_clock;
  const auto deadline = clock::now() + keep_alive;
  while (!ended_ && !closed_) {
    // The count is read before the job, so that a change after the read wakes the wait below.
    const std::uint64_t seen = acquisition_ ? acquisition_->changes() : 0;
    auto job = db_.job(job_id_);
    if (!job) break;
    const json view = job_json(*job, acquisition_ ? acquisition_->progress(job_id_) : std::nullopt);
    // Without an acquisition nothing will change the job any more.
    const bool last = finished(job->state) || acquisition_ == nullptr;
    if (view != sent_) {
      sent_ = view;
      ended_ = last;
      return sse_event(++sequence_, view);
    }
    if (last) break;
    const auto now = clock::now();
    if (now >= deadline) return std::string(": keep-alive\n\n");
    acquisition_->wait_for_change(seen, std::chrono::ceil<std::chrono::milliseconds>(deadline - now), closed_);
  }
  ended_ = true;
  return std::nullopt;
}

void JobEvents::close() {
  closed_ = true;
  if (acquisition_) acquisition_->wake_waiters();
}

}  // namespace skinspec::api
