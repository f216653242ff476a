// Work spread over threads (spectral/parallel.hpp): every index once, and bulk work on threads
// of lower priority while the caller goes on at its own.

#include <gtest/gtest.h>

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <mutex>
#include <set>
#include <thread>
#include <vector>

#include "skinspec/spectral/parallel.hpp"

namespace skinspec {
namespace {

int niceness_of_this_thread() { return ::getpriority(PRIO_PROCESS, static_cast<id_t>(::gettid())); }

TEST(Parallel, EveryIndexOnce) {
  for (const unsigned threads : {0u, 1u, 3u}) {
    std::vector<std::atomic<int>> runs(1000);
    parallel_for(runs.size(), threads, [&](std::size_t i) { ++runs[i]; });
    EXPECT_TRUE(std::ranges::all_of(runs, [](const auto& r) { return r == 1; })) << threads << " threads";
    std::vector<std::atomic<int>> background_runs(1000);
    parallel_for_in_background(background_runs.size(), threads, [&](std::size_t i) { ++background_runs[i]; });
    EXPECT_TRUE(std::ranges::all_of(background_runs, [](const auto& r) { return r == 1; })) << threads << " threads";
  }
}

TEST(Parallel, InTheBackgroundTheWorkIsNicerAndTheCallerKeepsItsPriority) {
  const int caller = niceness_of_this_thread();
  const std::thread::id caller_id = std::this_thread::get_id();
  std::mutex mutex;
  std::set<int> worker_niceness;
  std::set<std::thread::id> workers;
  std::atomic<bool> caller_ran_meanwhile = false;
  std::atomic<bool> meanwhile_running = false;
  std::atomic<bool> work_seen_meanwhile = false;
  parallel_for_in_background(
      64, 2,
      [&](std::size_t i) {
        // The first index waits for `meanwhile`, which runs while the work does, not after it.
        for (int waited = 0; i == 0 && !meanwhile_running && waited < 10'000; ++waited)
          std::this_thread::sleep_for(std::chrono::milliseconds(1));
        if (i == 0) work_seen_meanwhile = meanwhile_running.load();
        std::lock_guard lock(mutex);
        worker_niceness.insert(niceness_of_this_thread());
        workers.insert(std::this_thread::get_id());
      },
      [&] {
        caller_ran_meanwhile = std::this_thread::get_id() == caller_id;
        meanwhile_running = true;
        for (int waited = 0; !work_seen_meanwhile && waited < 10'000; ++waited)
          std::this_thread::sleep_for(std::chrono::milliseconds(1));
      });
  EXPECT_TRUE(caller_ran_meanwhile);
  EXPECT_TRUE(work_seen_meanwhile) << "meanwhile() did not run while the work did";
  EXPECT_EQ(workers.count(caller_id), 0u) << "the caller did some of the work";
  EXPECT_EQ(worker_niceness, std::set<int>{std::min(caller + kBackgroundNiceness, 19)});
  EXPECT_EQ(niceness_of_this_thread(), caller);
}

}  // namespace
}  // namespace skinspec
