#include "skinspec/api/server.hpp"

#include <algorithm>
#include <cctype>
#include <mutex>
#include <optional>
#include <set>
#include <thread>
#include <vector>

#include <boost/asio/dispatch.hpp>
#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>

#include "event_pipe.hpp"

namespace skinspec::api {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
using tcp = asio::ip::tcp;

class Session;

// What the listener and the sessions share.
struct Server::State {
  const Router& router;
  ServerOptions options;
  asio::thread_pool workers;
  std::optional<tcp::acceptor> acceptor;
  std::mutex mutex;  // sessions, stopping
  std::set<std::weak_ptr<Session>, std::owner_less<std::weak_ptr<Session>>> sessions;
  std::atomic<std::size_t> open{0};
  bool stopping = false;
  detail::EventPullers pullers;

  State(const Router& r, ServerOptions o)
      : router(r), options(std::move(o)), workers(static_cast<std::size_t>(std::max(1, options.worker_threads))) {}
};

namespace {

http::response<http::string_body> to_beast(const Response& r, unsigned version, bool keep_alive) {
  http::response<http::string_body> res{static_cast<http::status>(r.status), version};
  res.set(http::field::server, "skinspecd");
  res.set(http::field::content_type, r.content_type);
  for (const auto& [name, value] : r.headers) res.set(name, value);
  res.keep_alive(keep_alive);
  res.body() = r.body;
  res.prepare_payload();
  return res;
}

Request to_request(const http::request<http::string_body>& req) {
  Request out;
  out.method = std::string(req.method_string());
  out.target = std::string(req.target());
  for (const auto& field : req) {
    std::string name(field.name_string());
    std::transform(name.begin(), name.end(), name.begin(), [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
    out.headers[name] = std::string(field.value());
  }
  out.body = req.body();
  return out;
}

}  // namespace

// One connection: read a request, let the router answer it on a worker, write the answer,
// and again while the connection is kept alive.
class Session : public std::enable_shared_from_this<Session> {
 public:
  Session(tcp::socket socket, std::shared_ptr<Server::State> state) : stream_(std::move(socket)), state_(std::move(state)) {}
  ~Session() { state_->router.metrics().set_open_connections(static_cast<std::int64_t>(--state_->open)); }

  void run() { asio::dispatch(stream_.get_executor(), [self = shared_from_this()] { self->do_read(); }); }

  // From stop(): idle connections close now, busy ones after their response.
  void shut_down() {
    asio::dispatch(stream_.get_executor(), [self = shared_from_this()] {
      self->stopping_ = true;
      if (self->events_) self->events_->source().close();
      if (!self->busy_) self->do_close();
    });
  }

 private:
  void do_read() {
    if (stopping_) return do_close();
    parser_.emplace();
    parser_->body_limit(state_->options.body_limit);
    parser_->header_limit(static_cast<std::uint32_t>(state_->options.header_limit));
    stream_.expires_after(state_->options.read_timeout);
    http::async_read(stream_, buffer_, *parser_, [self = shared_from_this()](beast::error_code ec, std::size_t) { self->on_read(ec); });
  }

  void on_read(beast::error_code ec) {
    if (ec == http::error::end_of_stream || ec == beast::error::timeout || ec == asio::error::operation_aborted ||
        ec == asio::error::connection_reset || ec == asio::error::eof)
      return do_close();
    if (ec == http::error::body_limit)
      return send_error(ApiError{ErrorKind::payload_too_large, "payload_too_large",
                                 "the body is larger than " + std::to_string(state_->options.body_limit) + " bytes"}, 11);
    if (ec == http::error::header_limit)
      return send_error(ApiError{ErrorKind::payload_too_large, "headers_too_large", "the request headers are too large"}, 11);
    if (ec) return send_error(ApiError{ErrorKind::bad_request, "malformed_http", ec.message()}, 11);
    busy_ = true;
    auto request = std::make_shared<http::request<http::string_body>>(parser_->release());
    // The guard keeps the I/O threads running while a worker answers, even once the listener
    // has stopped and nothing else is pending, so that the answer is still written.
    auto guard = asio::make_work_guard(stream_.get_executor());
    asio::post(state_->workers, [self = shared_from_this(), request, guard = std::move(guard)]() mutable {
      auto response = std::make_shared<Response>(self->state_->router.handle(to_request(*request)));
      auto executor = self->stream_.get_executor();
      asio::post(executor, [self = std::move(self), request, response, guard = std::move(guard)] {
        if (response->events) return self->start_events(*response, request->version());
        self->write(to_beast(*response, request->version(), request->keep_alive() && !self->stopping_));
      });
    });
  }

  void send_error(const ApiError& error, unsigned version) {
    state_->router.metrics().record_error(error.code);
    busy_ = true;
    write(to_beast(error_response(error), version, false));
  }

  void write(http::response<http::string_body> response) {
    response_ = std::make_shared<http::response<http::string_body>>(std::move(response));
    stream_.expires_after(state_->options.write_timeout);
    http::async_write(stream_, *response_, [self = shared_from_this()](beast::error_code ec, std::size_t) {
      self->busy_ = false;
      const bool again = !ec && self->response_->keep_alive() && !self->stopping_;
      self->response_.reset();
      if (again) return self->do_read();
      self->do_close();
    });
  }

  // A streamed body (Server-Sent Events): the header, then each piece of the source as one
  // chunk, then the last chunk and the end of the connection. The source is pulled on a thread
  // of its own (it blocks); the stream is free of the read timeout, and a client that hangs up
  // ends it at once.
  void start_events(const Response& r, unsigned version) {
    events_ = std::make_shared<detail::EventPipe>(r.events);
    if (stopping_) events_->source().close();
    auto header = std::make_shared<http::response<http::empty_body>>(static_cast<http::status>(r.status), version);
    header->set(http::field::server, "skinspecd");
    header->set(http::field::content_type, r.content_type);
    for (const auto& [name, value] : r.headers) header->set(name, value);
    header->keep_alive(false);
    header->chunked(true);
    auto serializer = std::make_shared<http::response_serializer<http::empty_body>>(*header);
    stream_.expires_after(state_->options.write_timeout);
    http::async_write_header(stream_, *serializer, [self = shared_from_this(), header, serializer](beast::error_code ec, std::size_t) {
      self->stream_.expires_never();
      if (ec) {
        self->events_->hang_up();
        return self->do_close();
      }
      self->watch_for_hang_up();
      self->state_->pullers.start(self->events_, [self] { self->pull_events(); });
    });
  }

  // On the puller's thread: until the source ends or the client is gone.
  void pull_events() {
    const auto keep_alive = state_->options.event_keep_alive;
    while (auto piece = events_->source().next(keep_alive)) {
      if (!events_->claim_write()) break;
      asio::post(stream_.get_executor(), [self = shared_from_this(), piece = std::make_shared<std::string>(std::move(*piece))] {
        self->write_chunk(piece);
      });
    }
    const bool client_there = events_->claim_write();
    asio::post(stream_.get_executor(), [self = shared_from_this(), client_there] {
      if (!client_there) return self->do_close();
      self->stream_.expires_after(self->state_->options.write_timeout);
      asio::async_write(self->stream_, http::make_chunk_last(), [self](beast::error_code, std::size_t) {
        self->events_->written(false);
        self->do_close();
      });
    });
  }

  void write_chunk(const std::shared_ptr<std::string>& piece) {
    stream_.expires_after(state_->options.write_timeout);
    asio::async_write(stream_, http::make_chunk(asio::buffer(*piece)), [self = shared_from_this(), piece](beast::error_code ec, std::size_t) {
      self->stream_.expires_never();
      self->events_->written(!ec);
    });
  }

  // A client of a stream sends nothing more; the socket turning readable means it hung up.
  void watch_for_hang_up() {
    stream_.socket().async_wait(tcp::socket::wait_read, [self = shared_from_this()](beast::error_code) { self->events_->hang_up(); });
  }

  void do_close() {
    beast::error_code ignored;
    stream_.socket().shutdown(tcp::socket::shutdown_both, ignored);
    stream_.socket().close(ignored);
  }

  beast::tcp_stream stream_;
  std::shared_ptr<Server::State> state_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::string_body>> parser_;
  std::shared_ptr<http::response<http::string_body>> response_;
  std::shared_ptr<detail::EventPipe> events_;  // while a body is streamed
  bool busy_ = false, stopping_ = false;
};

namespace {

// Accepts connections, each on its own strand, until the acceptor is closed.
void do_accept(const std::shared_ptr<Server::State>& state, asio::io_context& ioc) {
  state->acceptor->async_accept(asio::make_strand(ioc), [state, &ioc](beast::error_code ec, tcp::socket socket) {
    if (ec == asio::error::operation_aborted || !state->acceptor->is_open()) return;
    if (!ec) {
      if (state->open.load() >= state->options.max_connections) {
        // Over the cap: a short 503 written without waiting, then the connection is closed.
        state->router.metrics().record_rejected_connection();
        const std::string body = error_body({ErrorKind::unavailable, "too_many_connections", "too many connections"});
        const std::string reply = "HTTP/1.1 503 Service Unavailable\r\nContent-Type: application/json\r\nConnection: close\r\n"
                                  "Content-Length: " + std::to_string(body.size()) + "\r\n\r\n" + body;
        beast::error_code ignored;
        socket.non_blocking(true, ignored);
        socket.write_some(asio::buffer(reply), ignored);
        socket.shutdown(tcp::socket::shutdown_both, ignored);
        socket.close(ignored);
      } else {
        state->router.metrics().set_open_connections(static_cast<std::int64_t>(++state->open));
        auto session = std::make_shared<Session>(std::move(socket), state);
        std::lock_guard lock(state->mutex);
        for (auto it = state->sessions.begin(); it != state->sessions.end();)
          it = it->expired() ? state->sessions.erase(it) : std::next(it);
        if (state->stopping) {
          session->shut_down();
        } else {
          state->sessions.insert(session);
          session->run();
        }
      }
    }
    do_accept(state, ioc);
  });
}

}  // namespace

Server::Server(const Router& router, ServerOptions options) : state_(std::make_shared<State>(router, std::move(options))) {}

Server::~Server() {
  stop();
  ioc_.stop();
  state_->workers.join();
  state_->pullers.hang_up_and_join();
}

std::expected<void, std::string> Server::listen() {
  beast::error_code ec;
  const auto address = asio::ip::make_address(state_->options.address, ec);
  if (ec) return std::unexpected("bad listen address '" + state_->options.address + "': " + ec.message());
  const tcp::endpoint endpoint{address, state_->options.port};
  auto& acceptor = state_->acceptor.emplace(asio::make_strand(ioc_));
  if (acceptor.open(endpoint.protocol(), ec); ec) return std::unexpected("open: " + ec.message());
  if (acceptor.set_option(asio::socket_base::reuse_address(true), ec); ec) return std::unexpected("reuse_address: " + ec.message());
  if (acceptor.bind(endpoint, ec); ec)
    return std::unexpected("cannot bind " + state_->options.address + ":" + std::to_string(state_->options.port) + ": " + ec.message());
  if (acceptor.listen(asio::socket_base::max_listen_connections, ec); ec) return std::unexpected("listen: " + ec.message());
  do_accept(state_, ioc_);
  return {};
}

unsigned short Server::port() const { return state_->acceptor ? state_->acceptor->local_endpoint().port() : 0; }

void Server::run() {
  std::vector<std::thread> threads;
  for (int i = 1; i < state_->options.io_threads; ++i) threads.emplace_back([this] { ioc_.run(); });
  ioc_.run();
  for (auto& t : threads) t.join();
  state_->workers.join();
  state_->pullers.join_all();
}

void Server::stop() {
  std::vector<std::shared_ptr<Session>> sessions;
  {
    std::lock_guard lock(state_->mutex);
    if (state_->stopping) return;
    state_->stopping = true;
    for (const auto& weak : state_->sessions)
      if (auto s = weak.lock()) sessions.push_back(std::move(s));
  }
  if (state_->acceptor)
    asio::dispatch(state_->acceptor->get_executor(), [state = state_] {
      beast::error_code ignored;
      state->acceptor->close(ignored);
    });
  for (auto& s : sessions) s->shut_down();
  state_->pullers.close_all();
}

}  // namespace skinspec::api
