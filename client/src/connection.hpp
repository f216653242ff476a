#pragma once
// What the client's files share behind its header: Beast, and a connection's state.

#include <algorithm>
#include <optional>
#include <string>

// GCC 12 with the sanitizers sees Beast's parser return an uninitialised boost::optional where
// it returns boost::none; the warning points into these headers, so it is silenced for them only.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/ssl/ssl_stream.hpp>
#pragma GCC diagnostic pop

#include "skinspec/client/http_client.hpp"

namespace skinspec::client {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
using tcp = asio::ip::tcp;
using Clock = std::chrono::steady_clock;

struct HttpConnection::Impl {
  asio::io_context ioc;
  beast::tcp_stream stream{ioc};
  // HTTPS: the context, then TLS over `stream`, which keeps its timeouts.
  std::optional<asio::ssl::context> tls_context;
  std::optional<beast::ssl_stream<beast::tcp_stream&>> tls;
  beast::flat_buffer buffer;
  std::string host;
  Timeouts timeouts;
  std::string connect_error;
  Clock::time_point deadline = Clock::time_point::max();

  // The next reads and writes on the stream may take up to `wait`, and not past the deadline.
  void arm(std::chrono::milliseconds wait) { stream.expires_at(std::min(Clock::now() + wait, deadline)); }
  // `io(stream)` on the stream requests go over: TLS when there is TLS, else plain TCP.
  template <class Io>
  void on_stream(Io&& io) {
    if (tls) io(*tls);
    else io(stream);
  }
  // After connecting: the handshake, checking the server's certificate; why it failed, or "".
  std::string start_tls(const Tls& options);
  // Sends a request and reads its answer into `parser`, or only the answer's head; the reply's
  // status and headers, or the error that stopped it (the body is left in `parser`).
  HttpReply exchange(const std::string& method, const std::string& target, const std::string& body,
                     const Headers& headers, http::response_parser<http::string_body>& parser, bool head_only);

 private:
  std::string send(const std::string& method, const std::string& target, const std::string& body,
                   const Headers& headers);
};

// The status and header fields of a response, as HttpReply holds them.
void copy_head(const http::response_header<>& from, HttpReply& to);

}  // namespace skinspec::client
