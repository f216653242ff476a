#include "api_client.hpp"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <fstream>
#include <utility>

#include "common.hpp"
#include "skinspec/client/http_client.hpp"

namespace skinspec::cli {

using nlohmann::json;

namespace {

[[noreturn]] void unreachable(const ServerUrl& server, const std::string& why) {
  throw Failure{kUnreachable, "cannot reach skinspecd at " + server.text + ": " + why};
}

// The message of the service's one error shape, or the body itself.
std::string error_message(const client::HttpReply& reply) {
  const json body = json::parse(reply.body, nullptr, false);
  if (body.is_object() && body.contains("error") && body["error"].is_object())
    return body["error"].value("message", reply.body) + " (" + body["error"].value("code", "error") + ")";
  return reply.body.empty() ? "no explanation" : reply.body;
}

[[noreturn]] void refuse(const client::HttpReply& reply) {
  const std::string message = "the server answered " + std::to_string(reply.status) + ": " + error_message(reply);
  throw Failure{reply.status >= 400 && reply.status < 500 ? kBadInput : kFailure, message};
}

// Every request names skinspec, closes its connection (one per request) and carries the token.
client::Headers headers_of(const std::string& token) {
  client::Headers headers = {{"User-Agent", "skinspec"}, {"Connection", "close"}};
  if (!token.empty()) headers.emplace_back("Authorization", "Bearer " + token);
  return headers;
}

// An event's name ("message" when it gives none) and its data lines joined.
std::pair<std::string, std::string> name_and_data(const std::string& event) {
  std::string name = "message", data;
  std::size_t pos = 0;
  while (pos <= event.size()) {
    const auto eol = std::min(event.find('\n', pos), event.size());
    const std::string line = event.substr(pos, eol - pos);
    pos = eol + 1;
    if (line.rfind("event: ", 0) == 0) name = line.substr(7);
    else if (line.rfind("data: ", 0) == 0) data += (data.empty() ? "" : "\n") + line.substr(6);
  }
  return {name, data};
}

}  // namespace

ServerUrl parse_server_url(const std::string& text) {
  const auto bad = [&](const std::string& why) { return Failure{kBadInput, "--server " + quote(text) + ": " + why}; };
  ServerUrl url;
  url.https = text.rfind("https://", 0) == 0;
  if (!url.https && text.rfind("http://", 0) != 0) throw bad("expected http[s]://HOST[:PORT][/PREFIX]");
  url.text = text;
  if (url.https) url.port = "443";
  std::string rest = text.substr(url.https ? 8 : 7);
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

std::optional<client::Tls> ApiClient::tls() const {
  if (!server_.https) return std::nullopt;
  // A mistyped path is the user's, not the server's: OpenSSL would only say "asio.ssl error".
  if (!ca_file_.empty() && !std::ifstream(ca_file_))
    throw Failure{kBadInput, "--ca-file " + quote(ca_file_) + ": cannot read it"};
  return client::Tls{ca_file_};
}

json ApiClient::request(const std::string& method, const std::string& target, const std::string& body,
                        const std::string& content_type) const {
  auto headers = headers_of(token_);
  if (!body.empty()) headers.emplace_back("Content-Type", content_type);
  client::HttpConnection connection(server_.host, server_.port, {}, tls());
  const auto reply = connection.request(method, server_.base + target, body, headers);
  if (reply.status == 0) unreachable(server_, reply.error);
  if (reply.status < 200 || reply.status >= 300) refuse(reply);
  json parsed = reply.json();
  if (parsed.is_discarded()) throw Failure{kFailure, "the server's reply to " + method + " " + target + " is not JSON"};
  return parsed;
}

json ApiClient::call(const std::string& method, const std::string& target, const json& body) const {
  return request(method, target, body.is_null() ? "" : body.dump(), "application/json");
}

json ApiClient::post_text(const std::string& target, const std::string& text, const std::string& content_type) const {
  return request("POST", target, text, content_type);
}

void ApiClient::follow_events(const std::string& target,
                              const std::function<void(const std::string&, const std::string&)>& on_event) const {
  client::HttpConnection connection(server_.host, server_.port, {}, tls());
  const auto reply = connection.follow_events(
      server_.base + target,
      [&](const std::string& event) {
        const auto [name, data] = name_and_data(event);
        if (!data.empty()) on_event(name, data);  // comments (keep-alive) carry no data
        return true;
      },
      headers_of(token_));
  if (reply.status == 0) unreachable(server_, reply.error);
  if (reply.status != 200) refuse(reply);
  if (!reply.error.empty()) unreachable(server_, reply.error);
}

std::string resolve_token(const std::string& token_file) {
  if (token_file.empty()) {
    const char* env = std::getenv("SKINSPEC_TOKEN");
    return env ? env : "";
  }
  std::string text = read_input(token_file);
  const json tokens = json::parse(text, nullptr, false);
  if (tokens.is_object()) {
    // skinspecd's file of named tokens holds their hashes only, which no request can carry.
    if (tokens.contains("tokens"))
      throw Failure{kBadInput, token_file +
                                   ": skinspecd's file of named tokens holds only their hashes; give a file holding "
                                   "your token's secret (as `skinspec token new` printed it), or $SKINSPEC_TOKEN"};
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
