#include "http_client.hpp"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdlib>

// GCC 12 with the sanitizers sees Beast's parser return an uninitialised boost::optional where
// it returns boost::none; the warning points into these headers, so it is silenced for them only.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <boost/asio/connect.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#pragma GCC diagnostic pop

#include "common.hpp"

namespace skinspec::cli {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
using tcp = asio::ip::tcp;
using nlohmann::json;

namespace {

constexpr auto kConnectTimeout = std::chrono::seconds(10);
constexpr auto kReplyTimeout = std::chrono::seconds(120);
// Longer than the service's 15 s between keep-alive comments.
constexpr auto kEventSilence = std::chrono::seconds(60);

// One connection to the server, opened on construction.
struct Connection {
  asio::io_context ioc;
  beast::tcp_stream stream{ioc};
  beast::flat_buffer buffer;
  const ServerUrl& server;

  explicit Connection(const ServerUrl& url) : server(url) {
    beast::error_code ec;
    tcp::resolver resolver(ioc);
    const auto endpoints = resolver.resolve(server.host, server.port, ec);
    if (ec) unreachable(ec);
    stream.expires_after(kConnectTimeout);
    stream.connect(endpoints, ec);
    if (ec) unreachable(ec);
  }
  ~Connection() {
    beast::error_code ignored;
    stream.socket().shutdown(tcp::socket::shutdown_both, ignored);
  }
  [[noreturn]] void unreachable(const beast::error_code& ec) const {
    throw Failure{kUnreachable, "cannot reach skinspecd at " + server.text + ": " + ec.message()};
  }
  void send(const std::string& method, const std::string& target, const std::string& body, const std::string& token,
            const std::string& content_type = "application/json") {
    http::request<http::string_body> req;
    req.method_string(method);
    req.target(server.base + target);
    req.version(11);
    req.set(http::field::host, server.host);
    req.set(http::field::user_agent, "skinspec");
    req.keep_alive(false);
    if (!token.empty()) req.set(http::field::authorization, "Bearer " + token);
    if (!body.empty()) req.set(http::field::content_type, content_type);
    req.body() = body;
    req.prepare_payload();
    beast::error_code ec;
    stream.expires_after(kReplyTimeout);
    http::write(stream, req, ec);
    if (ec) unreachable(ec);
  }
};

// The message of the service's one error shape, or the body itself.
std::string error_message(const HttpResult& reply) {
  const json body = json::parse(reply.body, nullptr, false);
  if (body.is_object() && body.contains("error") && body["error"].is_object())
    return body["error"].value("message", reply.body) + " (" + body["error"].value("code", "error") + ")";
  return reply.body.empty() ? "no explanation" : reply.body;
}

[[noreturn]] void refuse(const HttpResult& reply) {
  const std::string message = "the server answered " + std::to_string(reply.status) + ": " + error_message(reply);
  throw Failure{reply.status >= 400 && reply.status < 500 ? kBadInput : kFailure, message};
}

// Splits complete events ("...\n\n") off `pending` and hands each to `on_event`.
void dispatch_events(std::string& pending,
                     const std::function<void(const std::string&, const std::string&)>& on_event) {
  for (auto end = pending.find("\n\n"); end != std::string::npos; end = pending.find("\n\n")) {
    const std::string block = pending.substr(0, end);
    pending.erase(0, end + 2);
    std::string name = "message", data;
    std::size_t pos = 0;
    while (pos <= block.size()) {
      const auto eol = std::min(block.find('\n', pos), block.size());
      const std::string line = block.substr(pos, eol - pos);
      pos = eol + 1;
      if (line.rfind("event: ", 0) == 0) name = line.substr(7);
      else if (line.rfind("data: ", 0) == 0) data += (data.empty() ? "" : "\n") + line.substr(6);
    }
    if (!data.empty()) on_event(name, data);  // comments (keep-alive) carry no data
  }
}

}  // namespace

ServerUrl parse_server_url(const std::string& text) {
  const std::string scheme = "http://";
  const auto bad = [&](const std::string& why) { return Failure{kBadInput, "--server " + quote(text) + ": " + why}; };
  if (text.rfind(scheme, 0) != 0) throw bad("expected http://HOST[:PORT][/PREFIX]");
  ServerUrl url;
  url.text = text;
  std::string rest = text.substr(scheme.size());
  if (const auto slash = rest.find('/'); slash != std::string::npos) {
    url.base = rest.substr(slash);
    rest.erase(slash);
    while (!url.base.empty() && url.base.back() == '/') url.base.pop_back();
  }
  if (const auto colon = rest.rfind(':'); colon != std::string::npos && rest.find(']', colon) == std::string::npos) {
    url.port = rest.substr(colon + 1);
    rest.erase(colon);
    if (url.port.empty() || url.port.find_first_not_of("0123456789") != std::string::npos)
      throw bad("the port must be a number");
  }
  if (rest.size() > 2 && rest.front() == '[' && rest.back() == ']') rest = rest.substr(1, rest.size() - 2);
  if (rest.empty()) throw bad("no host");
  url.host = rest;
  return url;
}

HttpResult ApiClient::request(const std::string& method, const std::string& target, const std::string& body,
                              const std::string& content_type) const {
  Connection connection(server_);
  connection.send(method, target, body, token_, content_type);
  http::response_parser<http::string_body> parser;
  parser.body_limit(256 * 1024 * 1024);
  beast::error_code ec;
  http::read(connection.stream, connection.buffer, parser, ec);
  if (ec) connection.unreachable(ec);
  return {static_cast<int>(parser.get().result_int()), parser.get().body()};
}

json ApiClient::call(const std::string& method, const std::string& target, const json& body) const {
  return reply_json(request(method, target, body.is_null() ? "" : body.dump()), method, target);
}

json ApiClient::post_text(const std::string& target, const std::string& text, const std::string& content_type) const {
  return reply_json(request("POST", target, text, content_type), "POST", target);
}

json ApiClient::reply_json(const HttpResult& reply, const std::string& method, const std::string& target) {
  if (reply.status < 200 || reply.status >= 300) refuse(reply);
  json parsed = json::parse(reply.body, nullptr, false);
  if (parsed.is_discarded()) throw Failure{kFailure, "the server's reply to " + method + " " + target + " is not JSON"};
  return parsed;
}

void ApiClient::follow_events(const std::string& target,
                              const std::function<void(const std::string&, const std::string&)>& on_event) const {
  Connection connection(server_);
  connection.send("GET", target, "", token_);
  http::response_parser<http::string_body> parser;
  parser.body_limit(std::uint64_t{1} << 40);  // a stream is as long as its job
  beast::error_code ec;
  connection.stream.expires_after(kReplyTimeout);
  http::read_header(connection.stream, connection.buffer, parser, ec);
  if (ec) connection.unreachable(ec);
  if (parser.get().result_int() != 200) {
    http::read(connection.stream, connection.buffer, parser, ec);
    refuse({static_cast<int>(parser.get().result_int()), parser.get().body()});
  }
  std::string pending;
  auto on_chunk = [&](std::uint64_t, beast::string_view piece, beast::error_code&) -> std::size_t {
    pending.append(piece.data(), piece.size());
    dispatch_events(pending, on_event);
    return piece.size();
  };
  parser.on_chunk_body(on_chunk);
  while (!parser.is_done()) {
    connection.stream.expires_after(kEventSilence);
    http::read_some(connection.stream, connection.buffer, parser, ec);
    if (ec) connection.unreachable(ec);
  }
  pending += parser.get().body();  // a server that did not chunk the stream
  pending += "\n\n";
  dispatch_events(pending, on_event);
}

std::string resolve_token(const std::string& token_file) {
  if (token_file.empty()) {
    const char* env = std::getenv("SKINSPEC_TOKEN");
    return env ? env : "";
  }
  std::string text = read_input(token_file);
  const json tokens = json::parse(text, nullptr, false);
  if (tokens.is_object()) {
    for (const char* key : {"operator_token", "read_token"})
      if (tokens.contains(key) && tokens[key].is_string()) return tokens[key].get<std::string>();
    throw Failure{kBadInput, token_file + ": a JSON token file needs operator_token or read_token"};
  }
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r' || text.back() == ' ')) text.pop_back();
  if (text.empty() || text.find_first_of(" \n\r\t") != std::string::npos)
    throw Failure{kBadInput, token_file + ": expected one token, or a JSON object with operator_token"};
  return text;
}

std::string url_encode(const std::string& text) {
  static const char* hex = "0123456789ABCDEF";
  std::string out;
  for (const unsigned char ch : text) {
    if (std::isalnum(ch) || ch == '-' || ch == '_' || ch == '.' || ch == '~') {
      out += static_cast<char>(ch);
    } else {
      out += '%';
      out += hex[ch >> 4];
      out += hex[ch & 15];
    }
  }
  return out;
}

}  // namespace skinspec::cli
