#include "compute_pool.hpp"

#include <algorithm>

#include <boost/asio/post.hpp>

namespace skinspec::api::detail {

ComputePool::ComputePool(std::size_t threads, std::size_t queue,
                         std::function<void(std::size_t, std::size_t)> on_change)
    : threads_(std::max<std::size_t>(1, threads)), queue_(queue), on_change_(std::move(on_change)), pool_(threads_) {}

bool ComputePool::try_post(std::function<void()> work) {
  if (pending_.fetch_add(1) >= threads_ + queue_) {
    --pending_;
    return false;
  }
  report();
  boost::asio::post(pool_, [this, work = std::move(work)] {
    work();
    --pending_;
    report();
  });
  return true;
}

void ComputePool::report() {
  // Read under the lock, so that the last report made is of the latest load.
  std::lock_guard lock(report_mutex_);
  on_change_(running(), waiting());
}

std::size_t ComputePool::running() const { return std::min(pending_.load(), threads_); }
std::size_t ComputePool::waiting() const {
  const std::size_t pending = pending_.load();
  return pending - std::min(pending, threads_);
}

}  // namespace skinspec::api::detail
