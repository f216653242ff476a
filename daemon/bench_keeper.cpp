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
  supervisor_.wake_waiters();
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
    if (auto beaten = db_.beat(record()); !beaten) log_refusal("heartbeat_failed", beaten.error());
    adopt_queued();
    if (settings_.shared) recover_silent();
  }
}

void BenchKeeper::adopt_queued() {
  auto queued = db_.queued_jobs();
  if (!queued) return log_refusal("queue_read_failed", queued.error());
  for (const auto& job : *queued) supervisor_.adopt(job);
}

void BenchKeeper::recover_silent() {
  auto benches = db_.benches();
  if (!benches) return log_refusal("list_failed", benches.error());
  const auto now = to_store_time(std::chrono::system_clock::now());
  for (const auto& bench : *benches) {
    if (bench.name == db_.bench() || store::bench_running(bench, now)) continue;
    auto recovered = db_.recover_bench(bench.name);
    if (!recovered) {
      log_refusal("recovery_failed", recovered.error());
      continue;
    }
    for (const auto id : recovered->failed_jobs) {
      spdlog::warn("event=job_interrupted job={} bench={} message=\"its bench went silent\"", id, bench.name);
      supervisor_.note_remote(id, std::nullopt);
    }
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
      continue;  // made again at once; a failure to connect pauses above
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
  std::uint64_t seen = 0;
  const auto equal = [](const api::JobProgress& a, const api::JobProgress& b) {
    return a.position == b.position && a.phase == b.phase && a.readings_done == b.readings_done &&
           a.readings_total == b.readings_total;
  };
  while (!stop.stop_requested()) {
    seen = supervisor_.changes();
    const auto now = supervisor_.local_progress();
    for (const auto& [id, progress] : now) {
      const auto before = published.find(id);
      if (before != published.end() && equal(before->second, progress)) continue;
      if (auto sent = db_.notify(std::string(kJobEventsChannel), job_event_json({db_.bench(), id, progress})); !sent)
        log_refusal("publish_failed", sent.error());
    }
    for (const auto& [id, progress] : published)
      if (!now.contains(id))
        if (auto sent = db_.notify(std::string(kJobEventsChannel), job_event_json({db_.bench(), id, std::nullopt}));
            !sent)
          log_refusal("publish_failed", sent.error());
    published = now;
    std::atomic<bool> abandoned{false};
    std::stop_callback wake(stop, [&] {
      abandoned = true;
      supervisor_.wake_waiters();
    });
    supervisor_.wait_for_change(seen, std::chrono::milliseconds(1000), abandoned);
  }
}

}  // namespace skinspec::daemon
