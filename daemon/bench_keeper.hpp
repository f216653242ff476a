#pragma once
// This program's bench among those writing one database (docs/store.md, "Benches"): its
// heartbeat with its instrument's state, the jobs other programs queue for it, other benches'
// job progress for this program's followers and this bench's for theirs, and the recovery of a
// bench whose program is gone.

#include <atomic>
#include <chrono>
#include <map>
#include <optional>
#include <string>
#include <thread>

#include "skinspec/store/store.hpp"
#include "supervisor.hpp"

namespace skinspec::daemon {

struct BenchSettings {
  std::chrono::milliseconds lease{15000};
  // Several programs share the database (PostgreSQL): listen, publish and look after the
  // others. A SQLite file has one.
  bool shared = false;
};

// How often a bench with `lease` writes its heartbeat: 7.5 times per lease, 2 s for 15 s.
std::chrono::milliseconds heartbeat_interval(std::chrono::milliseconds lease);

// This machine's name, the default bench name.
std::string host_name();

// Whether `name` can name a bench: 1-64 letters, digits, '-', '_' or '.'.
bool valid_bench_name(const std::string& name);

class BenchKeeper {
 public:
  BenchKeeper(store::Store& db, Supervisor& supervisor, BenchSettings settings);
  ~BenchKeeper();
  BenchKeeper(const BenchKeeper&) = delete;
  BenchKeeper& operator=(const BenchKeeper&) = delete;

  // The first heartbeat (its refusal returned: the program cannot run as a bench), then the
  // threads.
  store::Result<void> start();
  // Ends the threads and records that the bench stopped.
  void stop();

 private:
  store::Bench record() const;
  void keep_beating(std::stop_token stop);
  void keep_listening(std::stop_token stop);
  void keep_publishing(std::stop_token stop);
  void adopt_queued();
  void recover_silent(std::chrono::steady_clock::duration heard_for);
  void forget_ended_remote_jobs();
  void on_notice(const store::Notification& notice);

  store::Store& db_;
  Supervisor& supervisor_;
  const BenchSettings settings_;
  const store::Time started_at_;
  std::atomic<bool> stopping_{false};
  bool started_ = false;  // its first heartbeat was written
  // Of the heartbeat thread: since when this bench's heartbeats have been written without a
  // failure, and the benches recovered, with the heartbeat they were silent after.
  std::optional<std::chrono::steady_clock::time_point> beating_since_;
  std::map<std::string, store::Time> recovered_;
  std::jthread beating_, listening_, publishing_;
};

}  // namespace skinspec::daemon
