#include <cstdint>
#include <string_view>

#include "connection.hpp"

namespace skinspec::client {

namespace {

// A stream's bytes cut into events ("...\n\n") as they come.
class EventSplitter {
 public:
  explicit EventSplitter(const EventHandler& on_event) : on_event_(on_event) {}

  // Hands on every event `bytes` completes; false once `on_event` has hung up.
  bool add(std::string_view bytes) {
    pending_.append(bytes);
    for (auto end = pending_.find("\n\n"); end != std::string::npos && !hung_up_; end = pending_.find("\n\n")) {
      const std::string event = pending_.substr(0, end);
      pending_.erase(0, end + 2);
      hung_up_ = !on_event_(event);
    }
    return !hung_up_;
  }
  // The stream has ended: what is left is its last event, without its blank line.
  void finish() {
    if (!hung_up_ && !pending_.empty()) hung_up_ = !on_event_(pending_);
    pending_.clear();
  }
  bool hung_up() const { return hung_up_; }

 private:
  const EventHandler& on_event_;
  std::string pending_;
  bool hung_up_ = false;
};

// Reads the events of a stream whose head `parser` has read, until it ends or is hung up; why
// it broke off, or "".
std::string read_events(HttpConnection::Impl& connection, http::response_parser<http::string_body>& parser,
                        const EventHandler& on_event) {
  EventSplitter events(on_event);
  auto on_chunk = [&](std::uint64_t, beast::string_view piece, beast::error_code& stop) -> std::size_t {
    if (!events.add({piece.data(), piece.size()})) stop = beast::error::timeout;  // any error ends the read
    return piece.size();
  };
  parser.on_chunk_body(on_chunk);
  beast::error_code ec;
  while (!parser.is_done() && !events.hung_up()) {
    connection.arm(connection.timeouts.silence);
    connection.on_stream([&](auto& s) { http::read_some(s, connection.buffer, parser, ec); });
    if (ec && !events.hung_up()) return "read: " + ec.message();
  }
  // A server that does not chunk the stream leaves it all in the body.
  if (events.add(parser.get().body())) events.finish();
  return "";
}

}  // namespace

HttpReply HttpConnection::follow_events(const std::string& target, const EventHandler& on_event, const Headers& headers,
                                        std::chrono::steady_clock::time_point deadline) {
  impl_->deadline = deadline;
  Headers asking = headers;
  asking.emplace_back("Accept", "text/event-stream");
  http::response_parser<http::string_body> parser;
  parser.body_limit(std::uint64_t{1} << 40);  // a stream is as long as its job
  auto reply = impl_->exchange("GET", target, "", asking, parser, true);
  if (!reply.error.empty()) return reply;
  beast::error_code ec;
  if (reply.status != 200) {
    impl_->on_stream([&](auto& s) { http::read(s, impl_->buffer, parser, ec); });
    reply.body = parser.get().body();
  } else {
    reply.error = read_events(*impl_, parser, on_event);
  }
  impl_->stream.socket().close(ec);
  return reply;
}

HttpReply follow_events(unsigned short port, const std::string& target, const EventHandler& on_event,
                        std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  HttpConnection connection(port, {.connect = timeout, .reply = timeout, .silence = timeout});
  return connection.follow_events(target, on_event, {}, deadline);
}

}  // namespace skinspec::client
