#pragma once
// The threads that run the CPU-heavy routes (fits, renders), apart from the workers that
// answer everything else, so that /healthz and reads never wait behind them. Bounded twice:
// `threads` run at once and at most `queue` more wait; beyond that work is refused at once
// (the server answers 503 with Retry-After) instead of piling up.

#include <atomic>
#include <cstddef>
#include <functional>
#include <mutex>

#include <boost/asio/thread_pool.hpp>

namespace skinspec::api::detail {

class ComputePool {
 public:
  // `on_change(running, waiting)` is called after each change of the load (for the metrics).
  ComputePool(std::size_t threads, std::size_t queue, std::function<void(std::size_t, std::size_t)> on_change);

  // Runs `work` on a pool thread; false, without running it, when the pool and its queue are full.
  bool try_post(std::function<void()> work);
  // Work accepted and not finished yet: running, then waiting.
  std::size_t running() const;
  std::size_t waiting() const;
  std::size_t threads() const { return threads_; }
  std::size_t queue() const { return queue_; }
  // Waits for the work accepted so far, then ends the threads.
  void join() { pool_.join(); }

 private:
  void report();

  std::size_t threads_, queue_;
  std::mutex report_mutex_;
  std::function<void(std::size_t, std::size_t)> on_change_;
  std::atomic<std::size_t> pending_{0};
  boost::asio::thread_pool pool_;
};

}  // namespace skinspec::api::detail
