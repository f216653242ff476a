#pragma once
// One connection: wait for a request, read its header, check its framing, read its body, let
// the router answer it (on the workers, or on the compute pool for a heavy route), write the
// answer, and again while the connection is kept alive. The connection table is told when it
// waits (and may be evicted) and when a request is on its way.

#include <memory>
#include <optional>

#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core/flat_buffer.hpp>
#include <boost/beast/core/tcp_stream.hpp>

#include "connection_table.hpp"
#include "event_pipe.hpp"
#include "http_exchange.hpp"
#include "skinspec/api/server.hpp"

namespace skinspec::api::detail {

class Session : public std::enable_shared_from_this<Session> {
 public:
  Session(boost::asio::ip::tcp::socket socket, std::shared_ptr<Server::State> state, ConnectionTable::Id id);
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

  void run();
  // From stop(): idle connections close now, busy ones after their response.
  void shut_down();
  // Displaced by a newcomer while it waited for a request: closes now.
  void evict();

 private:
  void do_read();
  void on_first_bytes(const boost::beast::error_code& ec);
  void read_header();
  void on_header(const boost::beast::error_code& ec);
  void on_read(const boost::beast::error_code& ec);
  void on_read_failure(const boost::beast::error_code& ec);
  void answer(const std::shared_ptr<RequestMessage>& message);
  void refuse_busy(const RequestMessage& message);
  void respond(const RequestMessage& message, const Response& response);
  void send_error(const ApiError& error, unsigned version);
  void write(Reply reply);

  void start_events(const Response& response, unsigned version);
  void pull_events();
  void write_chunk(const std::shared_ptr<std::string>& piece);
  void watch_for_hang_up();

  bool set_busy();
  void set_idle();
  // After the last response: stop sending, read and drop what the client still sends for a
  // moment (so that closing does not reset the connection before it read the answer), close.
  void finish();
  void drain();
  void do_close();

  std::string peer_;  // the client's address
  boost::beast::tcp_stream stream_;
  std::shared_ptr<Server::State> state_;
  ConnectionTable::Id id_;
  boost::beast::flat_buffer buffer_;
  std::optional<RequestParser> parser_;
  RequestLimits limits_;  // those of the request being read: an upload's are larger
  std::shared_ptr<Reply> reply_;
  std::shared_ptr<EventPipe> events_;  // while a body is streamed
  bool busy_ = false, stopping_ = false;
};

}  // namespace skinspec::api::detail
