#include "session.hpp"

#include <algorithm>

#include <boost/asio/dispatch.hpp>
#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/write.hpp>
#include <boost/beast/http/chunk_encode.hpp>
#include <boost/beast/http/read.hpp>
#include <boost/beast/http/serializer.hpp>
#include <boost/beast/http/write.hpp>

#include "server_state.hpp"

namespace skinspec::api::detail {

namespace asio = boost::asio;
namespace beast = boost::beast;
using tcp = asio::ip::tcp;

namespace {
// What an idle connection's first read asks for; the parser reads the rest.
constexpr std::size_t kFirstRead = 4096;
// How long a closing connection waits for the client to stop sending.
constexpr std::chrono::seconds kLinger{1};

std::string peer_of(const tcp::socket& socket) {
  beast::error_code ec;
  const auto endpoint = socket.remote_endpoint(ec);
  return ec ? std::string("unknown") : endpoint.address().to_string();
}
}  // namespace

Session::Session(tcp::socket socket, std::shared_ptr<Server::State> state, ConnectionTable::Id id)
    : peer_(peer_of(socket)), stream_(std::move(socket)), state_(std::move(state)), id_(id) {}

Session::~Session() {
  std::lock_guard lock(state_->mutex);
  state_->connections->remove(id_);
  state_->sessions.erase(id_);
  state_->router.metrics().set_open_connections(static_cast<std::int64_t>(state_->connections->size()));
}

void Session::run() {
  asio::dispatch(stream_.get_executor(), [self = shared_from_this()] { self->do_read(); });
}

void Session::shut_down() {
  asio::dispatch(stream_.get_executor(), [self = shared_from_this()] {
    self->stopping_ = true;
    if (self->events_) self->events_->source().close();
    if (!self->busy_) self->do_close();
  });
}

void Session::evict() {
  asio::dispatch(stream_.get_executor(), [self = shared_from_this()] { self->do_close(); });
}

void Session::do_read() {
  if (stopping_) return do_close();
  parser_.emplace();
  limits_ = state_->limits;
  prepare_parser(*parser_, limits_);
  // The parser refuses a Content-Length over its limit as soon as it reads the header, before
  // the route is known; so it allows an upload's, and on_header holds other routes to theirs.
  parser_->body_limit(std::max(limits_.body_limit, state_->options.upload_limit));
  stream_.expires_after(state_->options.read_timeout);
  if (buffer_.size() > 0) return read_header();  // a pipelined request is here already
  set_idle();
  stream_.async_read_some(buffer_.prepare(kFirstRead),
                          [self = shared_from_this()](beast::error_code ec, std::size_t n) {
                            self->buffer_.commit(n);
                            self->on_first_bytes(ec);
                          });
}

void Session::on_first_bytes(const beast::error_code& ec) {
  if (ec || !set_busy()) return do_close();  // gone, too slow, or evicted meanwhile
  read_header();
}

void Session::read_header() {
  http::async_read_header(stream_, buffer_, *parser_,
                          [self = shared_from_this()](beast::error_code ec, std::size_t) { self->on_header(ec); });
}

void Session::on_header(const beast::error_code& ec) {
  if (ec) return on_read_failure(ec);
  if (auto refused = check_framing(parser_->get())) return send_error(*refused, parser_->get().version());
  const auto& header = parser_->get();
  // Only a POST takes a file: every other request is spared the route lookup.
  if (header.method() == http::verb::post &&
      Router::is_upload(std::string(header.method_string()), std::string(header.target()))) {
    if (auto refused = state_->router.refuse_upload(to_request(header))) return send_error(*refused, header.version());
    limits_.body_limit = state_->options.upload_limit;
    stream_.expires_after(state_->options.upload_timeout);
  }
  if (parser_->content_length().value_or(0) > limits_.body_limit) return on_read_failure(http::error::body_limit);
  parser_->body_limit(limits_.body_limit);  // a chunked body is counted as it comes
  http::async_read(stream_, buffer_, *parser_,
                   [self = shared_from_this()](beast::error_code read_ec, std::size_t) { self->on_read(read_ec); });
}

void Session::on_read(const beast::error_code& ec) {
  if (ec) return on_read_failure(ec);
  busy_ = true;
  answer(std::make_shared<RequestMessage>(parser_->release()));
}

void Session::on_read_failure(const beast::error_code& ec) {
  if (client_gone(ec)) return do_close();
  send_error(read_failure(ec, limits_), 11);
}

void Session::answer(const std::shared_ptr<RequestMessage>& message) {
  auto request = std::make_shared<Request>(to_request(*message));
  request->peer = peer_;
  message->body() = std::string();  // the router's copy is the one needed
  // Handing a request to a worker and its answer back costs two threads woken; an answer held
  // in memory costs less than that to make here.
  if (auto answer = state_->router.answer_from_memory(*request)) return respond(*message, *answer);
  // The guard keeps the I/O threads running while the router answers, even once the listener
  // has stopped and nothing else is pending, so that the answer is still written.
  auto work = [self = shared_from_this(), message, request,
               guard = asio::make_work_guard(stream_.get_executor())]() mutable {
    auto response = std::make_shared<Response>(self->state_->router.handle(*request));
    auto executor = self->stream_.get_executor();
    asio::post(executor, [self = std::move(self), message, response, guard = std::move(guard)] {
      self->respond(*message, *response);
    });
  };
  if (!Router::is_heavy(request->method, request->target)) return asio::post(state_->workers, std::move(work));
  if (!state_->compute.try_post(std::move(work))) refuse_busy(*message);
}

void Session::refuse_busy(const RequestMessage& message) {
  const auto& pool = state_->compute;
  Response busy = error_response({ErrorKind::unavailable, "compute_busy",
                                  "every fit and render slot is taken (" + std::to_string(pool.threads()) +
                                      " running, " + std::to_string(pool.queue()) + " waiting); retry later"});
  state_->router.metrics().record_error("compute_busy");
  respond(message, busy);
}

void Session::respond(const RequestMessage& message, const Response& response) {
  if (response.events && !is_head(message)) return start_events(response, message.version());
  write(to_reply(response, message, message.keep_alive() && !stopping_));
}

void Session::send_error(const ApiError& error, unsigned version) {
  state_->router.metrics().record_error(error.code);
  busy_ = true;
  write(error_reply(error, version, false));
}

void Session::write(Reply reply) {
  reply_ = std::make_shared<Reply>(std::move(reply));
  stream_.expires_after(state_->options.write_timeout);
  http::async_write(stream_, *reply_, [self = shared_from_this()](beast::error_code ec, std::size_t) {
    self->busy_ = false;
    const bool again = !ec && self->reply_->keep_alive() && !self->stopping_;
    self->reply_.reset();
    if (again) return self->do_read();
    if (ec) return self->do_close();
    self->finish();
  });
}

// A streamed body (Server-Sent Events): the header, then each piece of the source as one
// chunk, then the last chunk and the end of the connection. The source is pulled on a thread
// of its own (it blocks); the stream is free of the read timeout, and a client that hangs up
// ends it at once.
void Session::start_events(const Response& response, unsigned version) {
  events_ = std::make_shared<EventPipe>(response.events);
  if (stopping_) events_->source().close();
  auto header = std::make_shared<Reply>(stream_header(response, version));
  auto serializer = std::make_shared<http::response_serializer<http::string_body>>(*header);
  stream_.expires_after(state_->options.write_timeout);
  http::async_write_header(stream_, *serializer,
                           [self = shared_from_this(), header, serializer](beast::error_code ec, std::size_t) {
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
void Session::pull_events() {
  const auto keep_alive = state_->options.event_keep_alive;
  while (auto piece = events_->source().next(keep_alive)) {
    if (!events_->claim_write()) break;
    asio::post(stream_.get_executor(),
               [self = shared_from_this(), piece = std::make_shared<std::string>(std::move(*piece))] {
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

void Session::write_chunk(const std::shared_ptr<std::string>& piece) {
  stream_.expires_after(state_->options.write_timeout);
  asio::async_write(stream_, http::make_chunk(asio::buffer(*piece)),
                    [self = shared_from_this(), piece](beast::error_code ec, std::size_t) {
                      self->stream_.expires_never();
                      self->events_->written(!ec);
                    });
}

// A client of a stream sends nothing more; the socket turning readable means it hung up.
void Session::watch_for_hang_up() {
  stream_.socket().async_wait(tcp::socket::wait_read,
                              [self = shared_from_this()](beast::error_code) { self->events_->hang_up(); });
}

bool Session::set_busy() {
  std::lock_guard lock(state_->mutex);
  return state_->connections->set_busy(id_);
}

void Session::set_idle() {
  std::lock_guard lock(state_->mutex);
  state_->connections->set_idle(id_);
}

void Session::finish() {
  beast::error_code ignored;
  stream_.socket().shutdown(tcp::socket::shutdown_send, ignored);
  stream_.expires_after(kLinger);
  drain();
}

void Session::drain() {
  buffer_.clear();
  stream_.async_read_some(buffer_.prepare(kFirstRead), [self = shared_from_this()](beast::error_code ec, std::size_t) {
    if (ec) return self->do_close();
    self->drain();
  });
}

void Session::do_close() {
  beast::error_code ignored;
  stream_.socket().shutdown(tcp::socket::shutdown_both, ignored);
  stream_.socket().close(ignored);
}

}  // namespace skinspec::api::detail
