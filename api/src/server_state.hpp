#pragma once
// What the listener, the sessions and the Server share.

#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <unordered_map>

#include <boost/asio/thread_pool.hpp>

#include "compute_pool.hpp"
#include "connection_table.hpp"
#include "event_pipe.hpp"
#include "http_exchange.hpp"
#include "listener.hpp"
#include "skinspec/api/server.hpp"

namespace skinspec::api {

namespace detail {
class Session;
}

struct Server::State {
  const Router& router;
  ServerOptions options;
  detail::RequestLimits limits;
  boost::asio::thread_pool workers;  // the router, for all but the heavy routes
  detail::ComputePool compute;       // the heavy routes
  detail::EventPullers pullers;
  std::shared_ptr<detail::Listener> listener;  // from listen()

  std::mutex mutex;                                    // what follows
  std::optional<detail::ConnectionTable> connections;  // from listen(), with the affordable cap
  std::unordered_map<detail::ConnectionTable::Id, std::weak_ptr<detail::Session>> sessions;
  detail::ConnectionTable::Id last_id = 0;
  bool stopping = false;

  State(const Router& r, ServerOptions o);
};

}  // namespace skinspec::api
