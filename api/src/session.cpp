#include "session.hpp"

#include <algorithm>
#include <chrono>
#include <optional>
#include <string>
#include <type_traits>

#include <boost/asio/dispatch.hpp>
#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/ssl/context.hpp>
#include <boost/asio/ssl/stream_base.hpp>
#include <boost/asio/write.hpp>
#include <boost/beast/core/flat_buffer.hpp>
#include <boost/beast/core/stream_traits.hpp>
#include <boost/beast/core/tcp_stream.hpp>
#include <boost/beast/http/chunk_encode.hpp>
#include <boost/beast/http/read.hpp>
#include <boost/beast/http/serializer.hpp>
#include <boost/beast/http/write.hpp>
#include <boost/beast/ssl/ssl_stream.hpp>

#include "event_pipe.hpp"
#include "http_exchange.hpp"
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

using PlainStream = beast::tcp_stream;
using TlsStream = beast::ssl_stream<beast::tcp_stream>;

// The one logic of a connection, over plain TCP or TLS: the two differ only in the handshake
// before the first request and in how the connection ends (kTls, below).
template <class Stream>
class StreamSession final : public Session, public std::enable_shared_from_this<StreamSession<Stream>> {
 public:
  // `stream_args` make the stream: the socket, and the TLS context for HTTPS, which `tls` keeps
  // alive while the connection lasts (a certificate reloaded meanwhile replaces it for others).
  template <class... StreamArgs>
  StreamSession(std::shared_ptr<Server::State> state, ConnectionTable::Id id, std::string peer,
                std::shared_ptr<boost::asio::ssl::context> tls, StreamArgs&&... stream_args)
      : peer_(std::move(peer)),
        tls_(std::move(tls)),
        stream_(std::forward<StreamArgs>(stream_args)...),
        state_(std::move(state)),
        id_(id) {}
  ~StreamSession() override;
  StreamSession(const StreamSession&) = delete;
  StreamSession& operator=(const StreamSession&) = delete;

  void run() override;
  void shut_down() override;
  void evict() override;

 private:
  static constexpr bool kTls = std::is_same_v<Stream, TlsStream>;

  beast::tcp_stream& lowest() { return beast::get_lowest_layer(stream_); }

  void handshake();
  void do_read();
  void on_first_bytes(const beast::error_code& ec);
  void read_header();
  void on_header(const beast::error_code& ec);
  void on_read(const beast::error_code& ec);
  void on_read_failure(const beast::error_code& ec);
  void answer(const std::shared_ptr<RequestMessage>& message);
  void refuse_busy(const RequestMessage& message);
  void respond(const RequestMessage& message, const Response& response);
  void send_error(const ApiError& error, unsigned version);
  void write(Reply reply);

  void start_events(const Response& response, unsigned version);
  void pull_events();
  void write_chunk(const std::shared_ptr<std::string>& piece);
  void watch_for_hang_up();

  bool set_busy();
  void set_idle();
  // After the last response: stop sending, read and drop what the client still sends for a
  // moment (so that closing does not reset the connection before it read the answer), close.
  // Over TLS, a close_notify each way does the same.
  void finish();
  void drain();
  void do_close();

  std::string peer_;                                // the client's address
  std::shared_ptr<boost::asio::ssl::context> tls_;  // before stream_, which refers to it
  Stream stream_;
  std::shared_ptr<Server::State> state_;
  ConnectionTable::Id id_;
  beast::flat_buffer buffer_;
  std::optional<RequestParser> parser_;
  RequestLimits limits_;  // those of the request being read: an upload's are larger
  std::shared_ptr<Reply> reply_;
  std::shared_ptr<EventPipe> events_;  // while a body is streamed
  bool busy_ = false, stopping_ = false;
};

std::shared_ptr<Session> make_session(tcp::socket socket, std::shared_ptr<Server::State> state,
                                      ConnectionTable::Id id) {
  std::string peer = peer_of(socket);
  if (state->options.tls) {
    auto tls = state->options.tls->current();
    auto& context = *tls;
    return std::make_shared<StreamSession<TlsStream>>(std::move(state), id, std::move(peer), std::move(tls),
                                                      std::move(socket), context);
  }
  return std::make_shared<StreamSession<PlainStream>>(std::move(state), id, std::move(peer), nullptr,
                                                      std::move(socket));
}

template <class Stream>
StreamSession<Stream>::~StreamSession() {
  std::lock_guard lock(state_->mutex);
  state_->connections->remove(id_);
  state_->sessions.erase(id_);
  state_->router.metrics().set_open_connections(static_cast<std::int64_t>(state_->connections->size()));
}

template <class Stream>
void StreamSession<Stream>::run() {
  asio::dispatch(stream_.get_executor(), [self = this->shared_from_this()] {
    if constexpr (kTls) self->handshake();
    else self->do_read();
  });
}

// A client that connects and never completes its handshake is one that sends no request: it
// has as long as a request would, and may be displaced meanwhile (the table counts it idle
// from its admission). A failed handshake (plain HTTP, anything but TLS) just closes.
template <class Stream>
void StreamSession<Stream>::handshake() {
  lowest().expires_after(state_->options.read_timeout);
  stream_.async_handshake(asio::ssl::stream_base::server, [self = this->shared_from_this()](beast::error_code ec) {
    if (ec || self->stopping_) return self->do_close();
    self->do_read();
  });
}

template <class Stream>
void StreamSession<Stream>::shut_down() {
  asio::dispatch(stream_.get_executor(), [self = this->shared_from_this()] {
    self->stopping_ = true;
    if (self->events_) self->events_->source().close();
    if (!self->busy_) self->do_close();
  });
}

template <class Stream>
void StreamSession<Stream>::evict() {
  asio::dispatch(stream_.get_executor(), [self = this->shared_from_this()] { self->do_close(); });
}

template <class Stream>
void StreamSession<Stream>::do_read() {
  if (stopping_) return do_close();
  parser_.emplace();
  limits_ = state_->limits;
  prepare_parser(*parser_, limits_);
  // The parser refuses a Content-Length over its limit as soon as it reads the header, before
  // the route is known; so it allows an upload's, and on_header holds other routes to theirs.
  parser_->body_limit(std::max(limits_.body_limit, state_->options.upload_limit));
  lowest().expires_after(state_->options.read_timeout);
  if (buffer_.size() > 0) return read_header();  // a pipelined request is here already
  set_idle();
  stream_.async_read_some(buffer_.prepare(kFirstRead),
                          [self = this->shared_from_this()](beast::error_code ec, std::size_t n) {
                            self->buffer_.commit(n);
                            self->on_first_bytes(ec);
                          });
}

template <class Stream>
void StreamSession<Stream>::on_first_bytes(const beast::error_code& ec) {
  if (ec || !set_busy()) return do_close();  // gone, too slow, or evicted meanwhile
  read_header();
}

template <class Stream>
void StreamSession<Stream>::read_header() {
  http::async_read_header(
      stream_, buffer_, *parser_,
      [self = this->shared_from_this()](beast::error_code ec, std::size_t) { self->on_header(ec); });
}

template <class Stream>
void StreamSession<Stream>::on_header(const beast::error_code& ec) {
  if (ec) return on_read_failure(ec);
  if (auto refused = check_framing(parser_->get())) return send_error(*refused, parser_->get().version());
  const auto& header = parser_->get();
  // Only a POST takes a file: every other request is spared the route lookup.
  if (header.method() == http::verb::post &&
      Router::is_upload(std::string(header.method_string()), std::string(header.target()))) {
    if (auto refused = state_->router.refuse_upload(to_request(header))) return send_error(*refused, header.version());
    limits_.body_limit = state_->options.upload_limit;
    lowest().expires_after(state_->options.upload_timeout);
  }
  if (parser_->content_length().value_or(0) > limits_.body_limit) return on_read_failure(http::error::body_limit);
  parser_->body_limit(limits_.body_limit);  // a chunked body is counted as it comes
  http::async_read(
      stream_, buffer_, *parser_,
      [self = this->shared_from_this()](beast::error_code read_ec, std::size_t) { self->on_read(read_ec); });
}

template <class Stream>
void StreamSession<Stream>::on_read(const beast::error_code& ec) {
  if (ec) return on_read_failure(ec);
  busy_ = true;
  answer(std::make_shared<RequestMessage>(parser_->release()));
}

template <class Stream>
void StreamSession<Stream>::on_read_failure(const beast::error_code& ec) {
  if (client_gone(ec)) return do_close();
  send_error(read_failure(ec, limits_), 11);
}

template <class Stream>
void StreamSession<Stream>::answer(const std::shared_ptr<RequestMessage>& message) {
  auto request = std::make_shared<Request>(to_request(*message));
  request->peer = peer_;
  message->body() = std::string();  // the router's copy is the one needed
  // Handing a request to a worker and its answer back costs two threads woken; an answer held
  // in memory costs less than that to make here.
  if (auto answer = state_->router.answer_from_memory(*request)) return respond(*message, *answer);
  // The guard keeps the I/O threads running while the router answers, even once the listener
  // has stopped and nothing else is pending, so that the answer is still written.
  auto work = [self = this->shared_from_this(), message, request,
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

template <class Stream>
void StreamSession<Stream>::refuse_busy(const RequestMessage& message) {
  const auto& pool = state_->compute;
  Response busy = error_response({ErrorKind::unavailable, "compute_busy",
                                  "every fit and render slot is taken (" + std::to_string(pool.threads()) +
                                      " running, " + std::to_string(pool.queue()) + " waiting); retry later"});
  state_->router.metrics().record_error("compute_busy");
  respond(message, busy);
}

template <class Stream>
void StreamSession<Stream>::respond(const RequestMessage& message, const Response& response) {
  if (response.events && !is_head(message)) return start_events(response, message.version());
  write(to_reply(response, message, message.keep_alive() && !stopping_));
}

template <class Stream>
void StreamSession<Stream>::send_error(const ApiError& error, unsigned version) {
  state_->router.metrics().record_error(error.code);
  busy_ = true;
  write(error_reply(error, version, false));
}

template <class Stream>
void StreamSession<Stream>::write(Reply reply) {
  reply_ = std::make_shared<Reply>(std::move(reply));
  lowest().expires_after(state_->options.write_timeout);
  http::async_write(stream_, *reply_, [self = this->shared_from_this()](beast::error_code ec, std::size_t) {
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
template <class Stream>
void StreamSession<Stream>::start_events(const Response& response, unsigned version) {
  events_ = std::make_shared<EventPipe>(response.events);
  if (stopping_) events_->source().close();
  auto header = std::make_shared<Reply>(stream_header(response, version));
  auto serializer = std::make_shared<http::response_serializer<http::string_body>>(*header);
  lowest().expires_after(state_->options.write_timeout);
  http::async_write_header(stream_, *serializer,
                           [self = this->shared_from_this(), header, serializer](beast::error_code ec, std::size_t) {
                             self->lowest().expires_never();
                             if (ec) {
                               self->events_->hang_up();
                               return self->do_close();
                             }
                             self->watch_for_hang_up();
                             self->state_->pullers.start(self->events_, [self] { self->pull_events(); });
                           });
}

// On the puller's thread: until the source ends or the client is gone.
template <class Stream>
void StreamSession<Stream>::pull_events() {
  const auto keep_alive = state_->options.event_keep_alive;
  while (auto piece = events_->source().next(keep_alive)) {
    if (!events_->claim_write()) break;
    asio::post(stream_.get_executor(),
               [self = this->shared_from_this(), piece = std::make_shared<std::string>(std::move(*piece))] {
                 self->write_chunk(piece);
               });
  }
  const bool client_there = events_->claim_write();
  asio::post(stream_.get_executor(), [self = this->shared_from_this(), client_there] {
    if (!client_there) return self->do_close();
    self->lowest().expires_after(self->state_->options.write_timeout);
    asio::async_write(self->stream_, http::make_chunk_last(), [self](beast::error_code, std::size_t) {
      self->events_->written(false);
      self->do_close();
    });
  });
}

template <class Stream>
void StreamSession<Stream>::write_chunk(const std::shared_ptr<std::string>& piece) {
  lowest().expires_after(state_->options.write_timeout);
  asio::async_write(stream_, http::make_chunk(asio::buffer(*piece)),
                    [self = this->shared_from_this(), piece](beast::error_code ec, std::size_t) {
                      self->lowest().expires_never();
                      self->events_->written(!ec);
                    });
}

// A client of a stream sends nothing more; the socket turning readable means it hung up.
template <class Stream>
void StreamSession<Stream>::watch_for_hang_up() {
  lowest().socket().async_wait(tcp::socket::wait_read,
                               [self = this->shared_from_this()](beast::error_code) { self->events_->hang_up(); });
}

template <class Stream>
bool StreamSession<Stream>::set_busy() {
  std::lock_guard lock(state_->mutex);
  return state_->connections->set_busy(id_);
}

template <class Stream>
void StreamSession<Stream>::set_idle() {
  std::lock_guard lock(state_->mutex);
  state_->connections->set_idle(id_);
}

template <class Stream>
void StreamSession<Stream>::finish() {
  lowest().expires_after(kLinger);
  if constexpr (kTls) {
    stream_.async_shutdown([self = this->shared_from_this()](beast::error_code) { self->do_close(); });
  } else {
    beast::error_code ignored;
    lowest().socket().shutdown(tcp::socket::shutdown_send, ignored);
    drain();
  }
}

template <class Stream>
void StreamSession<Stream>::drain() {
  buffer_.clear();
  stream_.async_read_some(buffer_.prepare(kFirstRead),
                          [self = this->shared_from_this()](beast::error_code ec, std::size_t) {
                            if (ec) return self->do_close();
                            self->drain();
                          });
}

template <class Stream>
void StreamSession<Stream>::do_close() {
  beast::error_code ignored;
  lowest().socket().shutdown(tcp::socket::shutdown_both, ignored);
  lowest().socket().close(ignored);
}

}  // namespace skinspec::api::detail
