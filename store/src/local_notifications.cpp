#include "local_notifications.hpp"

#include <algorithm>

namespace skinspec::store::detail {

class LocalHub::Listener final : public Subscription {
 public:
  Listener(std::shared_ptr<LocalHub> hub, std::vector<std::string> channels)
      : hub_(std::move(hub)), channels_(std::move(channels)) {}
  ~Listener() override { hub_->drop(this); }

  // With the hub's mutex held.
  void offer(const Notification& notification) {
    if (std::ranges::find(channels_, notification.channel) == channels_.end()) return;
    std::lock_guard lock(mutex_);
    arrived_.push_back(notification);
    ready_.notify_all();
  }

  Result<std::vector<Notification>> wait(std::chrono::milliseconds timeout) override {
    std::unique_lock lock(mutex_);
    ready_.wait_for(lock, timeout, [&] { return !arrived_.empty(); });
    std::vector<Notification> out(arrived_.begin(), arrived_.end());
    arrived_.clear();
    return out;
  }

 private:
  std::shared_ptr<LocalHub> hub_;
  const std::vector<std::string> channels_;
  std::mutex mutex_;
  std::condition_variable ready_;
  std::deque<Notification> arrived_;
};

void LocalHub::publish(const Notification& notification) {
  std::lock_guard lock(mutex_);
  for (Listener* listener : listeners_) listener->offer(notification);
}

std::unique_ptr<Subscription> LocalHub::subscribe(const std::vector<std::string>& channels) {
  auto listener = std::make_unique<Listener>(shared_from_this(), channels);
  std::lock_guard lock(mutex_);
  listeners_.push_back(listener.get());
  return listener;
}

void LocalHub::drop(const Listener* listener) {
  std::lock_guard lock(mutex_);
  std::erase(listeners_, listener);
}

}  // namespace skinspec::store::detail
