#include "listener.hpp"

#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <sstream>

#include <boost/asio/dispatch.hpp>
#include <boost/asio/socket_base.hpp>
#include <boost/beast/http/write.hpp>

#include "http_exchange.hpp"

namespace skinspec::api::detail {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;

namespace {

ApiError out_of_connections() { return {ErrorKind::unavailable, "too_many_connections", "too many connections"}; }

bool out_of_descriptors(const boost::system::error_code& ec) {
  return ec.category() == boost::system::system_category() && (ec.value() == EMFILE || ec.value() == ENFILE);
}

}  // namespace

std::string refusal_bytes(const ApiError& error) {
  std::ostringstream out;
  out << error_reply(error, 11, false);
  return out.str();
}

void refuse_connection(tcp::socket& socket, std::string_view reply) {
  boost::system::error_code ignored;
  socket.non_blocking(true, ignored);
  socket.write_some(asio::buffer(reply.data(), reply.size()), ignored);
  socket.shutdown(tcp::socket::shutdown_both, ignored);
  socket.close(ignored);
}

Listener::Listener(std::vector<asio::io_context*> contexts, Admit admit, std::function<void()> shed)
    : contexts_(std::move(contexts)),
      ioc_(*contexts_.front()),
      strand_(asio::make_strand(ioc_)),
      acceptor_(strand_),
      pause_(strand_),
      admit_(std::move(admit)),
      shed_(std::move(shed)),
      shed_reply_(refusal_bytes(out_of_connections())) {}

std::expected<void, std::string> Listener::open(const tcp::endpoint& endpoint) {
  boost::system::error_code ec;
  if (acceptor_.open(endpoint.protocol(), ec); ec) return std::unexpected("open: " + ec.message());
  if (acceptor_.set_option(asio::socket_base::reuse_address(true), ec); ec)
    return std::unexpected("reuse_address: " + ec.message());
  if (acceptor_.bind(endpoint, ec); ec)
    return std::unexpected("cannot bind " + endpoint.address().to_string() + ":" + std::to_string(endpoint.port()) +
                           ": " + ec.message());
  if (acceptor_.listen(asio::socket_base::max_listen_connections, ec); ec)
    return std::unexpected("listen: " + ec.message());
  // shed_one() accepts directly, and must never block.
  if (acceptor_.non_blocking(true, ec); ec) return std::unexpected("non_blocking: " + ec.message());
  return {};
}

unsigned short Listener::port() const {
  boost::system::error_code ec;
  const auto endpoint = acceptor_.local_endpoint(ec);
  return ec ? 0 : endpoint.port();
}

void Listener::start() {
  asio::dispatch(strand_, [self = shared_from_this()] { self->accept(); });
}

void Listener::close() {
  asio::dispatch(strand_, [self = shared_from_this()] {
    self->closed_ = true;
    boost::system::error_code ignored;
    self->pause_.cancel();
    self->acceptor_.close(ignored);
  });
}

void Listener::accept() {
  if (closed_) return;
  // The turn passes only to a connection accepted: after an error the same context is tried.
  const std::size_t context = next_ % contexts_.size();
  acceptor_.async_accept(asio::make_strand(*contexts_[context]),
                         [self = shared_from_this(), context](boost::system::error_code ec, tcp::socket socket) {
                           if (self->closed_ || ec == asio::error::operation_aborted) return;
                           if (ec) return self->on_error(ec);
                           ++self->next_;
                           self->admit_(std::move(socket), context);
                           self->accept();
                         });
}

void Listener::on_error(const boost::system::error_code& ec) {
  if (out_of_descriptors(ec)) {
    if (shed_one()) return accept();
    return pause();
  }
  // A connection reset before it was accepted is the client's business; anything else
  // (no buffers, no memory) is given time to pass.
  if (ec == asio::error::connection_aborted) return accept();
  pause();
}

bool Listener::shed_one() {
  if (!spare_.release()) {
    spare_.restore();  // it may have become possible again
    return false;
  }
  const int fd = ::accept4(acceptor_.native_handle(), nullptr, nullptr, SOCK_CLOEXEC);
  if (fd >= 0) {
    tcp::socket socket(ioc_);
    boost::system::error_code ec;
    socket.assign(acceptor_.local_endpoint(ec).protocol(), fd, ec);
    if (ec) ::close(fd);
    else refuse_connection(socket, shed_reply_);
    shed_();
  }
  spare_.restore();
  return fd >= 0;
}

void Listener::pause() {
  pause_.expires_after(kPause);
  pause_.async_wait([self = shared_from_this()](boost::system::error_code ec) {
    if (!ec) self->accept();
  });
}

}  // namespace skinspec::api::detail
