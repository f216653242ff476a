#include "connection.hpp"

#include <cctype>
#include <cstdint>

#include <boost/asio/ssl/host_name_verification.hpp>

#include <nlohmann/json.hpp>

namespace skinspec::client {

namespace {

// Room for the largest answers (an export of many sessions), not for a runaway.
constexpr std::uint64_t kBodyLimit = 256 * 1024 * 1024;

std::string lower_case(std::string text) {
  std::ranges::transform(text, text.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

}  // namespace

nlohmann::json HttpReply::json() const { return nlohmann::json::parse(body, nullptr, false); }

std::string HttpReply::header(const std::string& name) const {
  const auto it = headers.find(name);
  return it == headers.end() ? std::string() : it->second;
}

void copy_head(const http::response_header<>& from, HttpReply& to) {
  to.status = static_cast<int>(from.result_int());
  for (const auto& field : from) to.headers[lower_case(std::string(field.name_string()))] = std::string(field.value());
}

std::string HttpConnection::Impl::send(const std::string& method, const std::string& target, const std::string& body,
                                       const Headers& headers) {
  http::request<http::string_body> req;
  req.method_string(method);
  req.target(target);
  req.version(11);
  req.set(http::field::host, host);
  bool has_type = false;
  for (const auto& [name, value] : headers) {
    req.set(name, value);
    has_type = has_type || beast::iequals(name, "content-type");
  }
  if (!body.empty() && !has_type) req.set(http::field::content_type, "application/json");
  req.body() = body;
  req.prepare_payload();
  beast::error_code ec;
  arm(timeouts.reply);
  on_stream([&](auto& s) { http::write(s, req, ec); });
  return ec ? "write: " + ec.message() : "";
}

HttpReply HttpConnection::Impl::exchange(const std::string& method, const std::string& target, const std::string& body,
                                         const Headers& headers, http::response_parser<http::string_body>& parser,
                                         bool head_only) {
  HttpReply reply;
  reply.error = connect_error;
  if (reply.error.empty()) reply.error = send(method, target, body, headers);
  if (!reply.error.empty()) return reply;
  beast::error_code ec;
  on_stream([&](auto& s) {
    if (head_only) http::read_header(s, buffer, parser, ec);
    else http::read(s, buffer, parser, ec);
  });
  if (ec) reply.error = "read: " + ec.message();
  else copy_head(parser.get(), reply);
  return reply;
}

std::string HttpConnection::Impl::start_tls(const Tls& options) {
  beast::error_code ec;
  tls_context.emplace(asio::ssl::context::tls_client);
  tls_context->set_verify_mode(asio::ssl::verify_peer);
  if (options.ca_file.empty()) tls_context->set_default_verify_paths(ec);
  else tls_context->load_verify_file(options.ca_file, ec);
  if (ec) return "CA file " + options.ca_file + ": " + ec.message();
  tls.emplace(stream, *tls_context);
  tls->set_verify_callback(asio::ssl::host_name_verification(host));
  // A name, not an address, is sent for servers that hold certificates for several.
  beast::error_code not_an_address;
  asio::ip::make_address(host, not_an_address);
  // (SSL_set_tlsext_host_name spelled out: the macro casts in the old style.)
  if (not_an_address)
    SSL_ctrl(tls->native_handle(), SSL_CTRL_SET_TLSEXT_HOSTNAME, TLSEXT_NAMETYPE_host_name, host.data());
  arm(timeouts.connect);
  tls->handshake(asio::ssl::stream_base::client, ec);
  return ec ? "TLS handshake: " + ec.message() : "";
}

HttpConnection::HttpConnection(const std::string& host, const std::string& port, Timeouts timeouts,
                               const std::optional<Tls>& tls)
    : impl_(std::make_unique<Impl>()) {
  impl_->host = host;
  impl_->timeouts = timeouts;
  beast::error_code ec;
  tcp::resolver resolver(impl_->ioc);
  const auto endpoints = resolver.resolve(host, port, ec);
  if (ec) {
    impl_->connect_error = "resolve: " + ec.message();
    return;
  }
  impl_->arm(timeouts.connect);
  impl_->stream.connect(endpoints, ec);
  if (ec) impl_->connect_error = "connect: " + ec.message();
  else if (tls) impl_->connect_error = impl_->start_tls(*tls);
}

// No resolver: a test may have used up its file descriptors, which name lookups need.
HttpConnection::HttpConnection(unsigned short port, Timeouts timeouts) : impl_(std::make_unique<Impl>()) {
  impl_->host = "127.0.0.1";
  impl_->timeouts = timeouts;
  beast::error_code ec;
  impl_->arm(timeouts.connect);
  impl_->stream.connect(tcp::endpoint(asio::ip::make_address(impl_->host), port), ec);
  if (ec) impl_->connect_error = "connect: " + ec.message();
}

HttpConnection::~HttpConnection() {
  beast::error_code ignored;
  impl_->stream.socket().shutdown(tcp::socket::shutdown_both, ignored);
}

HttpReply HttpConnection::request(const std::string& method, const std::string& target, const std::string& body,
                                  const Headers& headers) {
  http::response_parser<http::string_body> parser;
  parser.body_limit(kBodyLimit);
  auto reply = impl_->exchange(method, target, body, headers, parser, false);
  if (reply.error.empty()) reply.body = std::move(parser.get().body());
  return reply;
}

HttpReply http_request(unsigned short port, const std::string& method, const std::string& target,
                       const std::string& body, const Headers& headers) {
  HttpConnection connection(port);
  return connection.request(method, target, body, headers);
}

}  // namespace skinspec::client
