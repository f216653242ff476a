#include "connection_pool.hpp"

#include <algorithm>

namespace skinspec::store::detail {

void ConnectionPool::configure(Opener open, int max_connections, Check broken) {
  open_connection_ = std::move(open);
  broken_ = std::move(broken);
  max_ = static_cast<std::size_t>(std::max(1, max_connections));
}

ConnectionLease ConnectionPool::acquire() {
  std::unique_lock lock(mutex_);
  returned_.wait(lock, [&] { return !idle_.empty() || open_.size() + opening_ < max_; });
  if (!idle_.empty()) {
    auto* connection = idle_.back();
    idle_.pop_back();
    return ConnectionLease(*this, *connection);
  }
  ++opening_;
  lock.unlock();
  std::unique_ptr<Connection> connection;
  try {
    connection = open_connection_();
  } catch (...) {
    lock.lock();
    --opening_;
    returned_.notify_one();
    throw;
  }
  lock.lock();
  --opening_;
  auto& opened = *open_.emplace_back(std::move(connection));
  return ConnectionLease(*this, opened);
}

void ConnectionPool::give_back(Connection& connection) noexcept {
  {
    std::lock_guard lock(mutex_);
    if (broken_ && broken_(connection)) {
      std::erase_if(open_, [&](const auto& owned) { return owned.get() == &connection; });
    } else {
      idle_.push_back(&connection);
    }
  }
  returned_.notify_one();
}

void ConnectionPool::close() {
  std::lock_guard lock(mutex_);
  idle_.clear();
  open_.clear();
}

}  // namespace skinspec::store::detail
