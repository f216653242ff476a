// A raw TCP byte stream to a serial server (ser2net style) or to a simulator, through
// Boost.Asio.
//
// Each transport owns an io_context that only the calling thread runs, and only for the
// length of one call: an operation is started asynchronously and the context is run until it
// completes or the deadline passes, after which it is cancelled and its handler awaited, so no
// handler outlives the call. interrupt() posts a cancellation to the same context, which is
// the one thread-safe way into it.

#include <fmt/format.h>
#include <poll.h>

#include <atomic>
#include <boost/asio/connect.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/write.hpp>
#include <vector>

#include "transport/transports.hpp"

namespace skinspec::drivers::detail {

namespace {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;
using boost::system::error_code;
using Kind = TransportError::Kind;

std::unexpected<TransportError> fail(Kind kind, std::string message) {
  return std::unexpected(TransportError{kind, std::move(message)});
}

// How one asynchronous operation ended.
struct Completion {
  bool done = false;
  bool timed_out = false;  // the deadline passed and the operation was cancelled
  error_code error;
  std::size_t bytes = 0;
};

bool peer_gone(const error_code& error) {
  return error == asio::error::eof || error == asio::error::connection_reset || error == asio::error::broken_pipe ||
         error == asio::error::connection_aborted || error == asio::error::not_connected;
}

bool nothing_there(const error_code& error) {
  return error == asio::error::connection_refused || error == asio::error::host_not_found ||
         error == asio::error::host_not_found_try_again || error == asio::error::no_data ||
         error == asio::error::service_not_found;
}

class TcpTransport final : public Transport {
 public:
  TcpTransport(const ConnectionUri& uri, std::chrono::milliseconds connect_timeout)
      : host_(uri.host), port_(uri.port), label_(uri.to_string()), connect_timeout_(connect_timeout) {}
  ~TcpTransport() override { close(); }

  std::expected<void, TransportError> open() override {
    if (socket_.is_open()) return {};
    if (interrupted_) return interrupted();
    const Deadline deadline = deadline_in(connect_timeout_);
    auto endpoints = resolve(deadline);
    if (!endpoints) return std::unexpected(endpoints.error());
    const Completion connected = await(
        [&](auto handler) {
          asio::async_connect(socket_, *endpoints,
                              [handler](const error_code& error, const tcp::endpoint&) mutable { handler(error, 0); });
        },
        deadline);
    if (connected.error) {
      close();
      return failure(connected, "connect");
    }
    // Commands are a few bytes each and wait for their reply: send them at once.
    error_code ignored;
    socket_.set_option(tcp::no_delay(true), ignored);
    socket_.non_blocking(true, ignored);  // for flush_input's reads; async operations do not mind
    return {};
  }

  void close() override {
    error_code ignored;
    socket_.shutdown(tcp::socket::shutdown_both, ignored);
    socket_.close(ignored);
  }

  bool is_open() const override { return socket_.is_open(); }
  int native_handle() const override {
    // native_handle() is not const in Asio, though it only reads the descriptor.
    return socket_.is_open() ? const_cast<tcp::socket&>(socket_).native_handle() : -1;
  }

  // Reads whatever the socket already holds, without waiting for more.
  std::expected<void, TransportError> flush_input() override {
    if (!socket_.is_open()) return not_open();
    char sink[512];
    for (;;) {
      error_code error;
      const std::size_t n = socket_.read_some(asio::buffer(sink), error);
      if (error == asio::error::would_block || error == asio::error::try_again) return {};
      if (error) return failure(Completion{true, false, error, 0}, "flush");
      if (n == 0) return {};
    }
  }

  std::expected<void, TransportError> write(std::string_view bytes, Deadline deadline) override {
    if (!socket_.is_open()) return not_open();
    if (interrupted_) return interrupted();
    const Completion written = await(
        [&](auto handler) { asio::async_write(socket_, asio::buffer(bytes.data(), bytes.size()), handler); }, deadline);
    if (!written.error) return {};
    if (written.timed_out && !interrupted_)
      return fail(Kind::timeout,
                  fmt::format("{}: wrote {} of {} bytes before the deadline", label_, written.bytes, bytes.size()));
    return failure(written, "write");
  }

  std::expected<std::size_t, TransportError> read(char* buffer, std::size_t size, Deadline deadline) override {
    if (!socket_.is_open()) return not_open();
    if (interrupted_) return interrupted();
    if (size == 0) return 0;
    const Completion received =
        await([&](auto handler) { socket_.async_read_some(asio::buffer(buffer, size), handler); }, deadline);
    if (!received.error) return received.bytes;
    return failure(received, "read");
  }

  // A TCP serial server has its own idea of the modem lines; there is nothing to set here.
  std::expected<void, TransportError> set_modem_lines(bool, bool) override { return {}; }

  // The peer's FIN shows as POLLRDHUP even while unread bytes wait before it; a reset as
  // POLLERR or POLLHUP.
  bool peer_closed() override {
    if (!socket_.is_open()) return false;
    pollfd one{socket_.native_handle(), POLLRDHUP, 0};
    if (::poll(&one, 1, 0) <= 0) return false;
    return (one.revents & (POLLRDHUP | POLLHUP | POLLERR)) != 0;
  }

  void interrupt() override {
    interrupted_ = true;
    // A cancellation queued after clear_interrupt() must not cancel the next operation,
    // hence the second look at the flag when it runs.
    asio::post(io_, [this] {
      if (interrupted_) cancel_operations();
    });
  }
  void clear_interrupt() override { interrupted_ = false; }
  std::string describe() const override { return label_; }

 private:
  // Runs the operation `start` begins until it completes or `deadline` passes; a late one is
  // cancelled, and its handler still awaited so that nothing refers to this call's locals.
  template <typename Start>
  Completion await(Start&& start, Deadline deadline) {
    Completion completion;
    io_.restart();
    start([&completion](const error_code& error, std::size_t bytes) {
      completion.done = true;
      completion.error = error;
      completion.bytes = bytes;
    });
    while (!completion.done && io_.run_one_until(deadline) > 0) {
    }
    if (!completion.done) {
      completion.timed_out = true;
      cancel_operations();
      while (!completion.done && io_.run_one() > 0) {
      }
    }
    return completion;
  }

  void cancel_operations() {
    error_code ignored;
    socket_.cancel(ignored);
    resolver_.cancel();
  }

  // Numeric addresses need no lookup; names are resolved with the connect deadline. (A name
  // lookup already under way cannot be abandoned: getaddrinfo() has its own time limit.)
  std::expected<std::vector<tcp::endpoint>, TransportError> resolve(Deadline deadline) {
    error_code error;
    const auto address = asio::ip::make_address(host_, error);
    if (!error) return std::vector<tcp::endpoint>{tcp::endpoint(address, port_)};
    std::vector<tcp::endpoint> endpoints;
    const Completion resolved = await(
        [&](auto handler) {
          resolver_.async_resolve(
              host_, std::to_string(port_),
              [&endpoints, handler](const error_code& e, const tcp::resolver::results_type& results) mutable {
                for (const auto& entry : results) endpoints.push_back(entry.endpoint());
                handler(e, 0);
              });
        },
        deadline);
    if (resolved.error) return failure(resolved, "resolve");
    return endpoints;
  }

  std::unexpected<TransportError> failure(const Completion& completion, std::string_view action) const {
    const error_code& error = completion.error;
    if (interrupted_ && error == asio::error::operation_aborted) return interrupted();
    if (completion.timed_out)
      return fail(Kind::timeout, fmt::format("{}: {} did not finish before the deadline", label_, action));
    if (peer_gone(error))
      return fail(Kind::closed, fmt::format("{}: the peer closed the connection ({})", label_, error.message()));
    if (nothing_there(error)) return fail(Kind::not_found, fmt::format("{}: {}: {}", label_, action, error.message()));
    return fail(Kind::io, fmt::format("{}: {}: {}", label_, action, error.message()));
  }

  std::unexpected<TransportError> interrupted() const { return fail(Kind::interrupted, label_ + ": interrupted"); }
  std::unexpected<TransportError> not_open() const { return fail(Kind::closed, label_ + ": not open"); }

  std::string host_;
  unsigned short port_;
  std::string label_;
  std::chrono::milliseconds connect_timeout_;
  std::atomic<bool> interrupted_{false};
  // The context first: it must outlive the objects whose operations it runs.
  asio::io_context io_;
  tcp::resolver resolver_{io_};
  tcp::socket socket_{io_};
};

}  // namespace

std::unique_ptr<Transport> make_tcp_transport(const ConnectionUri& uri, std::chrono::milliseconds connect_timeout) {
  return std::make_unique<TcpTransport>(uri, connect_timeout);
}

}  // namespace skinspec::drivers::detail
