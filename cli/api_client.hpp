#pragma once
// The command line's client of skinspecd, over skinspec/client/http_client.hpp: one connection
// per request, a bearer token when one is given, answers as JSON, and Server-Sent Events read
// as they come. A server that cannot be reached ends the command with kUnreachable.

#include <functional>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "skinspec/client/http_client.hpp"

namespace skinspec::cli {

struct ServerUrl {
  std::string host;
  std::string port = "80";
  std::string base;  // a path prefix without the trailing slash, often empty
  std::string text;  // as given, for messages
  bool https = false;
};

// "http://HOST[:PORT][/PREFIX]" or "https://..."; Failure kBadInput otherwise.
ServerUrl parse_server_url(const std::string& text);

class ApiClient {
 public:
  // `ca_file`: for an https:// server, the PEM file of the CA its certificate must chain to
  // (empty: the system's CAs).
  ApiClient(ServerUrl server, std::string token, std::string ca_file = {})
      : server_(std::move(server)), token_(std::move(token)), ca_file_(std::move(ca_file)) {}

  // The body as JSON when the status is 2xx; Failure kBadInput with the server's message for
  // a 4xx, kFailure for anything else.
  nlohmann::json call(const std::string& method, const std::string& target, const nlohmann::json& body = nullptr) const;
  // POSTs `text` (a file) with its content type; the answer as call() gives it.
  nlohmann::json post_text(const std::string& target, const std::string& text, const std::string& content_type) const;
  // GETs `target` as Server-Sent Events, calling `on_event(name, data)` for each event until
  // the server ends the stream. A reply other than 200 is refused as call() refuses it.
  void follow_events(const std::string& target,
                     const std::function<void(const std::string&, const std::string&)>& on_event) const;

  const ServerUrl& server() const { return server_; }

 private:
  nlohmann::json request(const std::string& method, const std::string& target, const std::string& body,
                         const std::string& content_type) const;
  std::optional<client::Tls> tls() const;
  ServerUrl server_;
  std::string token_;
  std::string ca_file_;
};

// The token for --token-file FILE (a file holding the token alone, or the service's old
// two-token file, whose operator_token is used), else $SKINSPEC_TOKEN, else none.
std::string resolve_token(const std::string& token_file);

// Percent-encodes a query parameter's value.
std::string url_encode(const std::string& text);

}  // namespace skinspec::cli
