#pragma once
// Notifications within one Store, for a SQLite file: one program writes it, so what that
// program sends is all there is to hear.

#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "skinspec/store/store.hpp"

namespace skinspec::store::detail {

class LocalHub : public std::enable_shared_from_this<LocalHub> {
 public:
  void publish(const Notification& notification);
  std::unique_ptr<Subscription> subscribe(const std::vector<std::string>& channels);

 private:
  class Listener;
  void drop(const Listener* listener);

  std::mutex mutex_;
  std::vector<Listener*> listeners_;
};

}  // namespace skinspec::store::detail
