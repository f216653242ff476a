#include "http_exchange.hpp"

#include <algorithm>
#include <cctype>
#include <string>
#include <string_view>

#include <boost/asio/error.hpp>
#include <boost/asio/ssl/error.hpp>
#include <boost/beast/core/error.hpp>
#include <boost/beast/core/string.hpp>
#include <boost/beast/http/error.hpp>

#include "text.hpp"

namespace skinspec::api::detail {

namespace beast = boost::beast;

namespace {

ApiError bad_framing(std::string message) { return {ErrorKind::bad_request, "invalid_framing", std::move(message)}; }

// Status and headers of `response`, without a body.
Reply head_of(const Response& response, unsigned version) {
  Reply reply{static_cast<http::status>(response.status), version};
  reply.set(http::field::server, "skinspecd");
  reply.set(http::field::content_type, response.content_type);
  for (const auto& [name, value] : response.headers) reply.set(name, value);
  return reply;
}

Reply with_body(const Response& response, unsigned version, bool keep_alive) {
  Reply reply = head_of(response, version);
  reply.keep_alive(keep_alive);
  reply.body() = response.body;
  reply.prepare_payload();
  return reply;
}

// Over HTTPS: the client closed without a close_notify, or sent what is not TLS. Nothing can be
// answered on such a connection.
bool tls_broken(const beast::error_code& ec) {
  return ec == boost::asio::ssl::error::stream_truncated || ec.category() == boost::asio::error::get_ssl_category();
}

}  // namespace

void prepare_parser(RequestParser& parser, const RequestLimits& limits) {
  parser.body_limit(limits.body_limit);
  parser.header_limit(static_cast<std::uint32_t>(std::min<std::size_t>(limits.header_limit, UINT32_MAX)));
}

std::optional<ApiError> check_framing(const http::request_header<>& header) {
  const auto fields = header.count(http::field::transfer_encoding);
  if (fields == 0) return std::nullopt;
  if (fields > 1) return bad_framing("Transfer-Encoding must be given once");
  if (header.count(http::field::content_length) > 0)
    return bad_framing("a request must not have both Transfer-Encoding and Content-Length");
  if (header.version() < 11) return bad_framing("Transfer-Encoding needs HTTP/1.1");
  const auto field = header[http::field::transfer_encoding];
  const std::string_view value = trimmed(std::string_view(field.data(), field.size()));
  if (!beast::iequals(beast::string_view(value.data(), value.size()), "chunked"))
    return bad_framing("the only transfer coding understood is 'chunked' on its own, not '" +
                       std::string(value.substr(0, 64)) + "'");
  return std::nullopt;
}

bool client_gone(const beast::error_code& ec) {
  return ec == http::error::end_of_stream || ec == beast::error::timeout ||
         ec == boost::asio::error::operation_aborted || ec == boost::asio::error::connection_reset ||
         ec == boost::asio::error::eof || tls_broken(ec);
}

ApiError read_failure(const beast::error_code& ec, const RequestLimits& limits) {
  if (ec == http::error::body_limit)
    return {ErrorKind::payload_too_large, "payload_too_large",
            "the body is larger than " + std::to_string(limits.body_limit) + " bytes"};
  if (ec == http::error::header_limit)
    return {ErrorKind::payload_too_large, "headers_too_large", "the request headers are too large"};
  if (ec == http::error::bad_transfer_encoding)
    return bad_framing("Transfer-Encoding is repeated or beside Content-Length");
  if (ec == http::error::bad_content_length)
    return bad_framing("Content-Length is malformed, repeated with another value or beside Transfer-Encoding");
  return {ErrorKind::bad_request, "malformed_http", ec.message()};
}

Request to_request(const RequestMessage& message) {
  Request out;
  out.method = is_head(message) ? "GET" : std::string(message.method_string());
  out.target = std::string(message.target());
  for (const auto& field : message) {
    std::string name(field.name_string());
    std::transform(name.begin(), name.end(), name.begin(),
                   [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
    out.headers[name] = std::string(field.value());
  }
  out.body = message.body();
  return out;
}

bool is_head(const http::request_header<>& request) { return request.method() == http::verb::head; }

Reply to_reply(const Response& response, const http::request_header<>& request, bool keep_alive) {
  if (response.events) {
    // Only a HEAD gets here: a GET's stream is written by the connection, chunk by chunk.
    response.events->close();
    Reply reply = head_of(response, request.version());
    reply.keep_alive(false);
    return reply;
  }
  Reply reply = with_body(response, request.version(), keep_alive);
  if (is_head(request)) reply.body().clear();  // Content-Length stays that of the GET
  return reply;
}

Reply stream_header(const Response& response, unsigned version) {
  Reply reply = head_of(response, version);
  reply.keep_alive(false);
  reply.chunked(true);
  return reply;
}

Reply error_reply(const ApiError& error, unsigned version, bool keep_alive) {
  return with_body(error_response(error), version, keep_alive);
}

}  // namespace skinspec::api::detail
