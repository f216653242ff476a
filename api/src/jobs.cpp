// Jobs as the API shows them: the store's record with the live position and progress of what
// runs them, and the Server-Sent Events that follow one job until it ends.

#include "jobs.hpp"

#include <algorithm>

#include "json_io.hpp"
#include "text.hpp"

namespace skinspec::api {

using nlohmann::json;

namespace {

bool finished(store::JobState state) {
  return state == store::JobState::succeeded || state == store::JobState::failed || state == store::JobState::cancelled;
}

json progress_json(JobPhase phase, int done, int total, double fraction) {
  return {{"phase", std::string(to_string(phase))},
          {"readings_done", done},
          {"readings_total", total},
          {"fraction", fraction}};
}

// An import's or a refit's progress: spectra rather than readings, and the time left.
json spectra_progress_json(JobPhase phase, std::int64_t done, std::int64_t total, std::optional<double> remaining_s) {
  // A refit also takes measurements stored after it began, so `done` may pass `total`.
  const double fraction = phase == JobPhase::done ? 1.0
                          : total > 0             ? std::min(1.0, static_cast<double>(done) / total)
                                                  : 0.0;
  return {{"phase", std::string(to_string(phase))},
          {"spectra_done", done},
          {"spectra_total", total},
          {"fraction", fraction},
          {"remaining_s", remaining_s ? json(*remaining_s) : json(nullptr)}};
}

bool counts_spectra(const store::Job& job) {
  const auto kind = parse_job_kind(job.kind);
  return kind == JobKind::import || kind == JobKind::refit || kind == JobKind::map;
}

// Measuring takes most of a job's time: it covers 0 to 0.9, reading by reading; fitting and
// storing the rest.
double measuring_fraction(int done, int total) { return total > 0 ? 0.9 * done / total : 0.0; }

// A measurement that measures also says how long it may still take (remaining_s: at most, each
// of the meter's commands waited for no longer than its deadline).
json live_progress(const JobProgress& p) {
  double fraction = measuring_fraction(p.readings_done, p.readings_total);
  if (p.phase == JobPhase::fitting) fraction = 0.9;
  if (p.phase == JobPhase::storing) fraction = 0.95;
  json out = progress_json(p.phase, p.readings_done, p.readings_total, fraction);
  if (p.remaining_s) out["remaining_s"] = *p.remaining_s;
  return out;
}

std::int64_t integer_in(const json& object, const char* key, std::int64_t fallback) {
  const auto it = object.is_object() ? object.find(key) : object.end();
  return it != object.end() && it->is_number_integer() ? it->get<std::int64_t>() : fallback;
}

// An import, refit or map nobody here runs any more (or not yet): what its record says. Its
// result counts what it stored (records::import_job_result, FitJobs' refit and map results).
json stored_spectra_progress(const store::Job& job, const json& result) {
  const std::int64_t done =
      integer_in(result, "imported", integer_in(result, "refitted", integer_in(result, "pixels_mapped", 0)));
  const std::int64_t total = integer_in(result, "total", done);
  switch (job.state) {
    case store::JobState::queued:
      return spectra_progress_json(JobPhase::queued, 0, 0, std::nullopt);
    case store::JobState::running:
      return spectra_progress_json(JobPhase::fitting, done, total, std::nullopt);
    default:
      return spectra_progress_json(JobPhase::done, done, total, std::nullopt);
  }
}

// A job nobody here runs any more (or not yet): what its record says.
json stored_progress(const store::Job& job, const json& request, const json& result) {
  if (counts_spectra(job)) return stored_spectra_progress(job, result);
  const auto integer = [](const json& object, const char* key, int fallback) {
    return static_cast<int>(integer_in(object, key, fallback));
  };
  const int total = integer(request, "count", 1);
  switch (job.state) {
    case store::JobState::succeeded:
      return progress_json(JobPhase::done, total, total, 1.0);
    case store::JobState::queued:
      return progress_json(JobPhase::queued, 0, total, 0.0);
    case store::JobState::running:
      return progress_json(JobPhase::measuring, 0, total, 0.0);
    default: {
      const int done = integer(result, "readings", 0);
      return progress_json(JobPhase::done, done, total, measuring_fraction(done, total));
    }
  }
}

json error_json(const std::optional<store::JobError>& error) {
  if (!error) return nullptr;
  return {{"code", std::string(store::to_string(error->code))}, {"message", error->message}};
}

// The state, position and progress of a job this process runs, from its live progress: a
// record read a moment earlier may still say queued.
void show_live(json& view, const JobProgress& live, bool spectra) {
  if (live.unrecorded_failure) {
    view["state"] = std::string(store::to_string(store::JobState::failed));
    view["position"] = nullptr;
    view["error"] = error_json(live.unrecorded_failure);
    view["progress"] = spectra
                           ? spectra_progress_json(JobPhase::done, live.spectra_done, live.spectra_total, std::nullopt)
                           : progress_json(JobPhase::done, live.readings_done, live.readings_total,
                                           measuring_fraction(live.readings_done, live.readings_total));
    return;
  }
  const bool queued = live.phase == JobPhase::queued;
  view["state"] = std::string(store::to_string(queued ? store::JobState::queued : store::JobState::running));
  view["position"] = queued ? std::max(1, live.position) : 0;
  view["progress"] = spectra
                         ? spectra_progress_json(live.phase, live.spectra_done, live.spectra_total, live.remaining_s)
                         : live_progress(live);
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
  json view = {{"id", job.id},
               {"job_id", job.id},
               {"kind", job.kind},
               {"session_id", job.session_id ? json(*job.session_id) : json(nullptr)},
               {"bench", job.bench},
               {"state", std::string(store::to_string(job.state))},
               {"position", nullptr},
               {"progress", stored_progress(job, request, result)},
               {"error", error_json(job.error)},
               {"request", request},
               {"result", result},
               {"idempotency_key", job.idempotency_key.empty() ? json(nullptr) : json(job.idempotency_key)},
               {"created_at", detail::format_time(job.created_at)},
               {"started_at", job.started_at ? json(detail::format_time(*job.started_at)) : json(nullptr)},
               {"finished_at", job.finished_at ? json(detail::format_time(*job.finished_at)) : json(nullptr)}};
  // A finished record wins over live progress that has not been cleared yet.
  if (live && !finished(job.state)) show_live(view, *live, counts_spectra(job));
  return view;
}

store::Result<json> current_job_json(const store::Store& db, const JobWatch* watch, store::Id id) {
  // Read twice at most: a job whose record was created between the two reads has its
  // progress by the second.
  for (int round = 1;; ++round) {
    const auto live = watch ? watch->progress(id) : std::nullopt;
    auto job = db.job(id);
    if (!job) return std::unexpected(job.error());
    if (live || watch == nullptr || finished(job->state) || round == 2) return job_json(*job, live);
  }
}

JobEvents::JobEvents(const store::Store& db, const JobWatch* watch, store::Id job_id)
    : db_(db), watch_(watch), job_id_(job_id) {}

std::optional<std::string> JobEvents::next(std::chrono::milliseconds keep_alive) {
  using clock = std::chrono::steady_clock;
  const auto deadline = clock::now() + keep_alive;
  while (!ended_ && !closed_) {
    // The count is read before the job, so that a change after the read wakes the wait below.
    const std::uint64_t seen = watch_ ? watch_->changes() : 0;
    auto current = current_job_json(db_, watch_, job_id_);
    if (!current) break;
    const json& view = *current;
    // Without a watch nothing will change the job any more.
    const auto state = store::parse_job_state(view["state"].get<std::string>());
    const bool last = !state || finished(*state) || watch_ == nullptr;
    if (view != sent_) {
      sent_ = view;
      ended_ = last;
      return sse_event(++sequence_, view);
    }
    if (last) break;
    const auto now = clock::now();
    if (now >= deadline) return std::string(": keep-alive\n\n");
    watch_->wait_for_change(seen, std::chrono::ceil<std::chrono::milliseconds>(deadline - now), closed_);
  }
  ended_ = true;
  return std::nullopt;
}

void JobEvents::close() {
  closed_ = true;
  if (watch_) watch_->wake_waiters();
}

}  // namespace skinspec::api
