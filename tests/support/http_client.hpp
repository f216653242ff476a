#pragma once
// Test helper: a small synchronous HTTP/1.1 client (Boost.Beast) for talking to skinspecd on
// loopback, and raw byte exchanges for requests a well-behaved client would never send.

#include <chrono>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

namespace skinspec::testing {

struct HttpReply {
  int status = 0;                              // 0: no reply (connection failed or closed)
  std::map<std::string, std::string> headers;  // names in lower case
  std::string body;
  std::string error;  // why there was no reply

  nlohmann::json json() const { return nlohmann::json::parse(body, nullptr, false); }
  std::string header(const std::string& name) const {
    const auto it = headers.find(name);
    return it == headers.end() ? std::string() : it->second;
  }
};

// One request on its own connection. A non-empty body is sent as application/json unless
// `headers` names a content-type.
HttpReply http_request(unsigned short port, const std::string& method, const std::string& target,
                       const std::string& body = "",
                       const std::vector<std::pair<std::string, std::string>>& headers = {});

// A kept-alive connection for several requests.
class HttpConnection {
 public:
  explicit HttpConnection(unsigned short port);
  ~HttpConnection();
  HttpConnection(const HttpConnection&) = delete;
  HttpConnection& operator=(const HttpConnection&) = delete;
  HttpReply request(const std::string& method, const std::string& target, const std::string& body = "",
                    const std::vector<std::pair<std::string, std::string>>& headers = {});
  struct Impl;

 private:
  Impl* impl_;
};

// GETs `target` and reads its Server-Sent Events as they come, calling `on_event` with each
// event's text (its lines, without the blank line that ends it; keep-alive comments included);
// returning false hangs up. Returns the reply's status and headers, with `error` set when the
// stream did not end normally (a hang-up by `on_event` is normal). A reply other than 200 has
// its body.
HttpReply follow_events(unsigned short port, const std::string& target,
                        const std::function<bool(const std::string&)>& on_event, std::chrono::milliseconds timeout);

// Writes `bytes` as they are and reads until the server closes the connection or `timeout`
// passes; everything the server sent.
std::string raw_exchange(unsigned short port, const std::string& bytes, std::chrono::milliseconds timeout);

// What a raw exchange got back, and whether the server closed the connection (rather than the
// timeout passing first).
struct RawExchange {
  std::string bytes;
  bool closed = false;
};
// As raw_exchange, connecting from `source`: any address of 127/8 (another client to the server).
RawExchange raw_exchange_from(const std::string& source, unsigned short port, const std::string& bytes,
                              std::chrono::milliseconds timeout);

// The responses in `bytes`, in order; `heads[i]` says the i-th answers a HEAD, so has no body
// whatever its Content-Length. A last entry with `error` set when the rest does not parse.
std::vector<HttpReply> parse_responses(const std::string& bytes, const std::vector<bool>& heads = {});

// A finished job's error as "code: message" ("" when it has none), for prefix checks.
inline std::string job_error_text(const nlohmann::json& job) {
  const auto it = job.find("error");
  if (it == job.end() || !it->is_object()) return "";
  return it->value("code", "") + ": " + it->value("message", "");
}

}  // namespace skinspec::testing
