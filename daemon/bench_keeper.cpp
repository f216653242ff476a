#include "bench_keeper.hpp"

#include <unistd.h>

#include <algorithm>
#include <condition_variable>
#include <mutex>

#include <spdlog/spdlog.h>

#include "bench_channels.hpp"
#include "supervisor_common.hpp"

namespace skinspec::daemon {

namespace {

// Sleeps `period` or until `stop` is asked for; false when it was.
bool pause(std::stop_token stop, std::chrono::milliseconds period) {
  std::mutex mutex;
  std::condition_variable_any woken;
  std::unique_lock lock(mutex);
  woken.wait_for(lock, stop, period, [] { return false; });
  return !stop.stop_requested();
}

void log_refusal(std::string_view what, const store::StoreError& error) {
  spdlog::warn("event=bench_{} kind={} error=\"{}\"", what, store::to_string(error.kind), error.message);
}

}  // namespace

std::string host_name() {
  char name[256] = {};
  if (gethostname(name, sizeof name - 1) != 0) return "unknown";
  return name;
}

std::chrono::milliseconds heartbeat_interval(std::chrono::milliseconds lease) { return lease * 2 / 15; }

bool valid_bench_name(const std::string& name) {
  return !name.empty() && name.size() <= 64 && std::ranges::all_of(name, [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' || c == '_' ||
           c == '.';
  });
}

BenchKeeper::BenchKeeper(store::Store& db, Supervisor& supervisor, BenchSettings settings)
    : db_(db),
      supervisor_(supervisor),
      settings_(settings),
      started_at_(to_store_time(std::chrono::system_clock::now())) {}

BenchKeeper::~BenchKeeper() { stop(); }

store::Bench BenchKeeper::record() const {
  store::Bench b;
  b.name = db_.bench();
  b.host = host_name();
  b.pid = getpid();
  b.started_at = started_at_;
  b.lease = settings_.lease;
  b.instrument = supervisor_.instrument_status().dump();
  return b;
}

store::Result<void> BenchKeeper::start() {
  if (auto first = db_.beat(record()); !first) return first;
  started_ = true;
  beating_since_ = std::chrono::steady_clock::now();
  spdlog::info("event=bench name={} lease_ms={} shared={}", db_.bench(), settings_.lease.count(), settings_.shared);
  beating_ = std::jthread([this](std::stop_token stop) { keep_beating(stop); });
  if (settings_.shared) {
    listening_ = std::jthread([this](std::stop_token stop) { keep_listening(stop); });
    publishing_ = std::jthread([this](std::stop_token stop) { keep_publishing(stop); });
  }
  return {};
}

void BenchKeeper::stop() {
  if (stopping_.exchange(true)) return;
  for (auto* thread : {&beating_, &listening_, &publishing_}) thread->request_stop();
  supervisor_.jobs().wake_waiters();
  for (auto* thread : {&beating_, &listening_, &publishing_})
    if (thread->joinable()) thread->join();
  if (!started_) return;
  if (auto left = db_.leave_bench(); !left) log_refusal("leave_failed", left.error());
}

// Every heartbeat also takes in what notices may have missed: jobs queued for this bench, and
// benches gone silent.
void BenchKeeper::keep_beating(std::stop_token stop) {
  const auto period = heartbeat_interval(settings_.lease);
  while (pause(stop, period)) {
    const auto now = std::chrono::steady_clock::now();
    if (auto beaten = db_.beat(record()); !beaten) {
      log_refusal("heartbeat_failed", beaten.error());
      beating_since_.reset();
      continue;
    }
    if (!beating_since_) beating_since_ = now;
    supervisor_.record_unrecorded_ends();
    adopt_queued();
    if (settings_.shared) {
      recover_silent(now - *beating_since_);
      forget_ended_remote_jobs();
    }
  }
}

void BenchKeeper::adopt_queued() {
  auto queued = db_.queued_jobs();
  if (!queued) return log_refusal("queue_read_failed", queued.error());
  for (const auto& job : *queued) supervisor_.adopt(job);
}

// A bench is judged only by a program that has itself been heard without a break for longer
// than that bench's lease: after an outage of the database every bench's heartbeat is old and
// its lock free until its program connects again, which the first one back must not take for
// death.
void BenchKeeper::recover_silent(std::chrono::steady_clock::duration heard_for) {
  auto benches = db_.benches();
  if (!benches) return log_refusal("list_failed", benches.error());
  // By the database's clock, which wrote the heartbeats: this machine's may be minutes off.
  const auto now = db_.database_time();
  if (!now) return log_refusal("clock_read_failed", now.error());
  for (const auto& bench : *benches) {
    if (bench.name == db_.bench() || store::bench_running(bench, *now)) continue;
    if (heard_for <= bench.lease + heartbeat_interval(bench.lease)) continue;
    // One recovery per silence: nothing of it can start again until it beats again.
    if (const auto done = recovered_.find(bench.name); done != recovered_.end() && done->second == bench.heartbeat_at)
      continue;
    auto recovered = db_.recover_bench(bench.name);
    if (!recovered) {
      log_refusal("recovery_failed", recovered.error());
      continue;
    }
    if (!recovered->failed_jobs.empty() || bench.stopped_at) recovered_[bench.name] = bench.heartbeat_at;
    for (const auto id : recovered->failed_jobs) {
      spdlog::warn("event=job_interrupted job={} bench={} message=\"its bench went silent\"", id, bench.name);
      supervisor_.note_remote(id, std::nullopt);
    }
  }
}

// Other benches' jobs this program shows live whose records have ended meanwhile (an end
// notice lost, or a bench recovered by a third program): shown from their records again.
void BenchKeeper::forget_ended_remote_jobs() {
  for (const auto id : supervisor_.remote_jobs()) {
    const auto job = db_.job(id);
    if (!job) continue;
    if (job->state != store::JobState::queued && job->state != store::JobState::running)
      supervisor_.note_remote(id, std::nullopt);
  }
}

void BenchKeeper::keep_listening(std::stop_token stop) {
  std::unique_ptr<store::Subscription> subscription;
  while (!stop.stop_requested()) {
    if (!subscription) {
      auto made = db_.subscribe({std::string(kJobsChannel), std::string(kJobEventsChannel)});
      if (!made) {
        log_refusal("listen_failed", made.error());
        if (!pause(stop, heartbeat_interval(settings_.lease))) return;
        continue;
      }
      subscription = std::move(*made);
      adopt_queued();  // what was queued while nobody listened
    }
    auto notices = subscription->wait(std::chrono::milliseconds(250));
    if (!notices) {
      log_refusal("listen_failed", notices.error());
      subscription.reset();  // made again after a pause, not in a loop against a server that is down
      if (!pause(stop, heartbeat_interval(settings_.lease))) return;
      continue;
    }
    for (const auto& notice : *notices) on_notice(notice);
  }
}

void BenchKeeper::on_notice(const store::Notification& notice) {
  if (notice.channel == kJobsChannel) {
    if (notice.payload == db_.bench()) adopt_queued();
    if (const auto cancelled = parse_cancel_notice(notice.payload)) supervisor_.cancel_here(*cancelled);
    return;
  }
  const auto event = parse_job_event(notice.payload);
  if (!event || event->bench == db_.bench()) return;
  supervisor_.note_remote(event->job_id, event->progress);
}

// Each change of this bench's jobs, after their records were written (the supervisor counts a
// change only then), published for the followers connected to other programs.
void BenchKeeper::keep_publishing(std::stop_token stop) {
  std::map<store::Id, api::JobProgress> published;
  std::vector<store::Id> ended;  // jobs whose end is still to be told
  std::uint64_t seen = 0;
  const auto equal = [](const api::JobProgress& a, const api::JobProgress& b) {
    return a.position == b.position && a.phase == b.phase && a.readings_done == b.readings_done &&
           a.readings_total == b.readings_total;
  };
  // `progress` null: the job ended.
  const auto publish = [&](store::Id id, const api::JobProgress* progress) {
    JobEvent event;
    event.bench = db_.bench();
    event.job_id = id;
    if (progress) event.progress.emplace(*progress);
    auto sent = db_.notify(std::string(kJobEventsChannel), job_event_json(event));
    if (!sent) log_refusal("publish_failed", sent.error());
    return sent.has_value();
  };
  while (!stop.stop_requested()) {
    seen = supervisor_.jobs().changes();
    auto jobs = supervisor_.local_jobs();
    for (const auto& [id, progress] : published)
      if (!jobs.live.contains(id)) jobs.ended.push_back(id);
    std::ranges::sort(jobs.ended);
    for (const auto id : jobs.ended)
      if (std::ranges::find(ended, id) == ended.end()) ended.push_back(id);
    std::map<store::Id, api::JobProgress> told;
    for (const auto& [id, progress] : jobs.live) {
      const auto before = published.find(id);
      const bool same = before != published.end() && equal(before->second, progress);
      if (same || publish(id, &progress)) told.emplace(id, progress);
    }
    published = std::move(told);
    std::erase_if(ended, [&](store::Id id) { return publish(id, nullptr); });
    std::atomic<bool> abandoned{false};
    std::stop_callback wake(stop, [&] {
      abandoned = true;
      supervisor_.jobs().wake_waiters();
    });
    // Told ends that could not be sent are tried again at the next change, or after a second.
    supervisor_.jobs().wait_for_change(seen, std::chrono::milliseconds(1000), abandoned);
  }
}

}  // namespace skinspec::daemon
