#include "support/http_client.hpp"

#include <algorithm>
#include <cctype>
#include <thread>

#include <boost/asio/connect.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/read.hpp>
#include <boost/asio/write.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>

namespace skinspec::testing {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
using tcp = asio::ip::tcp;

namespace {

void copy_headers(const http::response_header<>& from, HttpReply& to) {
  to.status = static_cast<int>(from.result_int());
  for (const auto& field : from) {
    std::string name(field.name_string());
    std::transform(name.begin(), name.end(), name.begin(),
                   [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
    to.headers[name] = std::string(field.value());
  }
}

}  // namespace

struct HttpConnection::Impl {
  asio::io_context ioc;
  beast::tcp_stream stream{ioc};
  beast::flat_buffer buffer;
  std::string connect_error;
};

HttpConnection::HttpConnection(unsigned short port) : impl_(new Impl) {
  beast::error_code ec;
  impl_->stream.expires_after(std::chrono::seconds(60));
  impl_->stream.connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), port), ec);
  if (ec) impl_->connect_error = ec.message();
}

HttpConnection::~HttpConnection() {
  beast::error_code ignored;
  impl_->stream.socket().shutdown(tcp::socket::shutdown_both, ignored);
  delete impl_;
}

HttpReply HttpConnection::request(const std::string& method, const std::string& target, const std::string& body,
                                  const std::vector<std::pair<std::string, std::string>>& headers) {
  HttpReply reply;
  if (!impl_->connect_error.empty()) {
    reply.error = impl_->connect_error;
    return reply;
  }
  http::request<http::string_body> req;
  req.method_string(method);
  req.target(target);
  req.version(11);
  req.set(http::field::host, "127.0.0.1");
  req.keep_alive(true);
  bool has_type = false;
  for (const auto& [name, value] : headers) {
    req.set(name, value);
    std::string lower = name;
    std::transform(lower.begin(), lower.end(), lower.begin(),
                   [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
    has_type = has_type || lower == "content-type";
  }
  if (!body.empty() && !has_type) req.set(http::field::content_type, "application/json");
  req.body() = body;
  req.prepare_payload();
  beast::error_code ec;
  impl_->stream.expires_after(std::chrono::seconds(60));
  http::write(impl_->stream, req, ec);
  if (ec) {
    reply.error = "write: " + ec.message();
    return reply;
  }
  http::response_parser<http::string_body> parser;
  parser.body_limit(64 * 1024 * 1024);
  http::read(impl_->stream, impl_->buffer, parser, ec);
  if (ec) {
    reply.error = "read: " + ec.message();
    return reply;
  }
  copy_headers(parser.get(), reply);
  reply.body = parser.get().body();
  return reply;
}

HttpReply http_request(unsigned short port, const std::string& method, const std::string& target,
                       const std::string& body, const std::vector<std::pair<std::string, std::string>>& headers) {
  HttpConnection connection(port);
  return connection.request(method, target, body, headers);
}

HttpReply follow_events(unsigned short port, const std::string& target,
                        const std::function<bool(const std::string&)>& on_event, std::chrono::milliseconds timeout) {
  HttpReply reply;
  asio::io_context ioc;
  beast::tcp_stream stream(ioc);
  beast::error_code ec;
  const auto failed = [&](const char* what) {
    reply.error = std::string(what) + ": " + ec.message();
    return reply;
  };
  stream.expires_after(timeout);
  stream.connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), port), ec);
  if (ec) return failed("connect");
  http::request<http::empty_body> req{http::verb::get, target, 11};
  req.set(http::field::host, "127.0.0.1");
  req.set(http::field::accept, "text/event-stream");
  http::write(stream, req, ec);
  if (ec) return failed("write");
  beast::flat_buffer buffer;
  http::response_parser<http::string_body> parser;
  parser.body_limit(std::uint64_t{1} << 40);  // a stream is as long as its job
  http::read_header(stream, buffer, parser, ec);
  if (ec) return failed("read");
  copy_headers(parser.get(), reply);
  if (reply.status != 200) {
    http::read(stream, buffer, parser, ec);
    reply.body = parser.get().body();
    return reply;
  }
  std::string pending;
  bool hung_up = false;
  auto on_chunk = [&](std::uint64_t, beast::string_view piece, beast::error_code& stop) -> std::size_t {
    pending.append(piece.data(), piece.size());
    for (auto end = pending.find("\n\n"); end != std::string::npos && !hung_up; end = pending.find("\n\n")) {
      const std::string event = pending.substr(0, end);
      pending.erase(0, end + 2);
      if (!on_event(event)) {
        hung_up = true;
        stop = beast::error::timeout;  // any error ends the read
      }
    }
    return piece.size();
  };
  parser.on_chunk_body(on_chunk);
  while (!parser.is_done() && !hung_up) {
    http::read_some(stream, buffer, parser, ec);
    if (ec && !hung_up) return failed("read");
  }
  stream.socket().close(ec);
  return reply;
}

std::string raw_exchange(unsigned short port, const std::string& bytes, std::chrono::milliseconds timeout) {
  return raw_exchange_from("127.0.0.1", port, bytes, timeout).bytes;
}

RawExchange raw_exchange_from(const std::string& source, unsigned short port, const std::string& bytes,
                              std::chrono::milliseconds timeout) {
  RawExchange out;
  asio::io_context ioc;
  beast::tcp_stream stream(ioc);
  beast::error_code ec;
  stream.socket().open(tcp::v4(), ec);
  stream.socket().bind(tcp::endpoint(asio::ip::make_address(source), 0), ec);
  if (ec) return out;
  stream.expires_after(timeout);
  stream.connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), port), ec);
  if (ec) return out;
  stream.expires_after(timeout);
  asio::write(stream, asio::buffer(bytes), ec);
  char chunk[4096];
  for (;;) {
    const std::size_t n = stream.read_some(asio::buffer(chunk), ec);
    out.bytes.append(chunk, n);
    if (ec) break;
  }
  out.closed = ec == asio::error::eof || ec == asio::error::connection_reset;
  return out;
}

std::vector<HttpReply> parse_responses(const std::string& bytes, const std::vector<bool>& heads) {
  std::vector<HttpReply> replies;
  std::size_t offset = 0;
  while (offset < bytes.size()) {
    http::response_parser<http::string_body> parser;
    parser.eager(true);
    parser.skip(replies.size() < heads.size() && heads[replies.size()]);
    beast::error_code ec;
    const std::size_t used = parser.put(asio::buffer(bytes.data() + offset, bytes.size() - offset), ec);
    if (ec || !parser.is_done()) {
      HttpReply broken;
      broken.error =
          "unparsable response at byte " + std::to_string(offset) + (ec ? ": " + ec.message() : ": incomplete");
      replies.push_back(std::move(broken));
      break;
    }
    HttpReply reply;
    copy_headers(parser.get(), reply);
    reply.body = parser.get().body();
    replies.push_back(std::move(reply));
    offset += used;
  }
  return replies;
}

}  // namespace skinspec::testing
