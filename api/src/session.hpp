#pragma once
// One connection: wait for a request, read its header, check its framing, read its body, let
// the router answer it (on the workers, or on the compute pool for a heavy route), write the
// answer, and again while the connection is kept alive. The connection table is told when it
// waits (and may be evicted) and when a request is on its way. Over HTTPS the same, after a TLS
// handshake that is held to the time a request has to arrive, and counts as waiting.

#include <memory>

#include <boost/asio/ip/tcp.hpp>

#include "connection_table.hpp"
#include "skinspec/api/server.hpp"

namespace skinspec::api::detail {

// What the server asks of a connection, whichever stream it is on.
class Session {
 public:
  virtual ~Session() = default;
  virtual void run() = 0;
  // From stop(): idle connections close now, busy ones after their response.
  virtual void shut_down() = 0;
  // Displaced by a newcomer while it waited for a request: closes now.
  virtual void evict() = 0;
};

// A session on `socket`: HTTPS when the server has a TLS context, plain HTTP otherwise.
std::shared_ptr<Session> make_session(boost::asio::ip::tcp::socket socket, std::shared_ptr<Server::State> state,
                                      ConnectionTable::Id id);

}  // namespace skinspec::api::detail
