#pragma once
// Read connections of any engine, opened on demand up to a maximum; a caller beyond it waits
// for one to come back. A connection that comes back broken is closed, not handed out again.

#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <vector>

#include "engine.hpp"

namespace skinspec::store::detail {

class ConnectionPool final : public ConnectionLease::Owner {
 public:
  using Opener = std::function<std::unique_ptr<Connection>()>;
  using Check = std::function<bool(const Connection&)>;

  // `open` makes a connection (or throws); `broken`, when given, says one must not be reused.
  void configure(Opener open, int max_connections, Check broken = {});
  ConnectionLease acquire();
  void give_back(Connection& connection) noexcept override;
  void close();

 private:
  Opener open_connection_;
  Check broken_;
  std::size_t max_ = 1;
  std::mutex mutex_;
  std::condition_variable returned_;
  std::vector<std::unique_ptr<Connection>> open_;
  std::vector<Connection*> idle_;
  std::size_t opening_ = 0;
};

}  // namespace skinspec::store::detail
