#pragma once
// The HTTP/1.1 client of skinspecd, over plain TCP or TLS, synchronous: requests with any method, headers and bytes
// as body, on a connection kept alive for as many as the caller sends; a stream of Server-Sent
// Events read as it comes; and the responses in bytes read off a socket. A failure is an
// answer, not an exception: status 0, and `error` saying which step failed and why.

#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json_fwd.hpp>

namespace skinspec::client {

using Headers = std::vector<std::pair<std::string, std::string>>;

struct HttpReply {
  int status = 0;                              // 0: no reply (connection failed or closed)
  std::map<std::string, std::string> headers;  // names in lower case
  std::string body;
  std::string error;  // why there was no reply, or why an event stream broke off: "read: ..."

  nlohmann::json json() const;  // discarded when the body is not JSON
  std::string header(const std::string& name) const;
};

struct Timeouts {
  std::chrono::milliseconds connect = std::chrono::seconds(10);
  // To send a request and read its answer, or an event stream's head.
  std::chrono::milliseconds reply = std::chrono::seconds(120);
  // Between two reads of an event stream: longer than the service's 15 s between keep-alive
  // comments.
  std::chrono::milliseconds silence = std::chrono::seconds(60);
};

// HTTPS: the server's certificate must chain to a CA of `ca_file` (PEM; empty: the system's
// CAs) and name the host connected to.
struct Tls {
  std::string ca_file;
};

// An event's text: its lines, without the blank line that ends it (keep-alive comments too).
// Returning false hangs up.
using EventHandler = std::function<bool(const std::string& text)>;

class HttpConnection {
 public:
  // Resolves `host`, connects, and with `tls` completes a TLS handshake checking the server's
  // certificate; a failure is kept, and is the answer to every request.
  HttpConnection(const std::string& host, const std::string& port, Timeouts timeouts = {},
                 const std::optional<Tls>& tls = std::nullopt);
  // To 127.0.0.1, where a test's service listens.
  explicit HttpConnection(unsigned short port, Timeouts timeouts = {});
  ~HttpConnection();
  HttpConnection(const HttpConnection&) = delete;
  HttpConnection& operator=(const HttpConnection&) = delete;

  // One request and its answer. Host is the host connected to; a non-empty body is sent as
  // application/json unless `headers` name a content-type.
  HttpReply request(const std::string& method, const std::string& target, const std::string& body = "",
                    const Headers& headers = {});

  // GETs `target` as Server-Sent Events and hands each event to `on_event` as it comes, until
  // the server ends the stream or `on_event` hangs up; then closes the connection. The reply's
  // status and headers, with `error` set when the stream did not end normally (a hang-up is
  // normal); a reply other than 200 has its body. No wait lasts past `deadline`.
  HttpReply follow_events(
      const std::string& target, const EventHandler& on_event, const Headers& headers = {},
      std::chrono::steady_clock::time_point deadline = std::chrono::steady_clock::time_point::max());

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

// One request on a connection of its own to 127.0.0.1:port.
HttpReply http_request(unsigned short port, const std::string& method, const std::string& target,
                       const std::string& body = "", const Headers& headers = {});

// follow_events on a connection of its own to 127.0.0.1:port, all of it within `timeout`.
HttpReply follow_events(unsigned short port, const std::string& target, const EventHandler& on_event,
                        std::chrono::milliseconds timeout);

// The responses in `bytes`, in order; `heads[i]` says the i-th answers a HEAD, so has no body
// whatever its Content-Length. A last entry with `error` set when the rest does not parse.
std::vector<HttpReply> parse_responses(const std::string& bytes, const std::vector<bool>& heads = {});

}  // namespace skinspec::client
