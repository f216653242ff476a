#pragma once
// One HTTP exchange apart from sockets: the parser a request is read with, the framing rules
// its header must meet before its body is read, the request the router sees, and the response
// written back. The server and the HTTP fuzzer both go through these functions, so that what
// is fuzzed is what is served.

#include <cstddef>
#include <optional>

#include <boost/beast/core/error.hpp>
#include <boost/beast/http/message.hpp>
#include <boost/beast/http/parser.hpp>
#include <boost/beast/http/string_body.hpp>

#include "skinspec/api/errors.hpp"
#include "skinspec/api/router.hpp"

namespace skinspec::api::detail {

namespace http = boost::beast::http;

struct RequestLimits {
  std::size_t body_limit = 1024 * 1024;
  std::size_t header_limit = 8 * 1024;
};

using RequestParser = http::request_parser<http::string_body>;
using RequestMessage = http::request<http::string_body>;
using Reply = http::response<http::string_body>;

// A fresh parser for one request with these limits.
void prepare_parser(RequestParser& parser, const RequestLimits& limits);

// The framing rules of RFC 9112 §6 that a complete header must meet, or the 400 to answer
// before closing the connection. Only `chunked` is understood, so Transfer-Encoding must be
// exactly that, in one field, on HTTP/1.1, and never beside Content-Length: any other framing
// could let a body be read as a second request.
std::optional<ApiError> check_framing(const http::request_header<>& header);

// Whether a read ended because the client went away or took too long, or its TLS broke:
// nothing to answer.
bool client_gone(const boost::beast::error_code& ec);
// The answer to a request that could not be read (too large, malformed); the connection is
// closed after it.
ApiError read_failure(const boost::beast::error_code& ec, const RequestLimits& limits);

// The request as the router sees it: header names in lower case; a HEAD as the GET it mirrors.
Request to_request(const RequestMessage& message);

// The response to `request` as written: its status, headers and body with its length. The
// answer to a HEAD keeps the headers and Content-Length of the GET's answer and has no body
// (a streamed answer's source is closed unread and only its headers go out).
Reply to_reply(const Response& response, const http::request_header<>& request, bool keep_alive);
// The header of a streamed answer (a GET with an event source): chunked, then closed.
Reply stream_header(const Response& response, unsigned version);
// An error answered outside any request (too many connections): HTTP/1.1, then close.
Reply error_reply(const ApiError& error, unsigned version, bool keep_alive);
bool is_head(const http::request_header<>& request);

}  // namespace skinspec::api::detail
