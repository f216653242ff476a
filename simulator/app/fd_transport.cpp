#include "fd_transport.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstring>

namespace skinspec::sim_app {

namespace {

using drivers::TransportError;
using Kind = TransportError::Kind;

std::unexpected<TransportError> fail(Kind kind, std::string message) {
  return std::unexpected(TransportError{kind, std::move(message)});
}

// The peer went away: a closed socket, or a pseudo-terminal whose last client closed it (EIO).
bool peer_gone(int error) { return error == EPIPE || error == ECONNRESET || error == EIO || error == ENOTCONN; }

int poll_timeout_ms(drivers::Deadline deadline) {
  const auto left = std::chrono::ceil<std::chrono::milliseconds>(deadline - drivers::Clock::now()).count();
  return static_cast<int>(std::clamp<std::chrono::milliseconds::rep>(left, 0, 60'000));
}

}  // namespace

FdTransport::FdTransport(int fd, std::string label, Ownership ownership)
    : fd_(fd), ownership_(ownership), label_(std::move(label)), wake_(::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC)) {
  const int flags = ::fcntl(fd_, F_GETFL);
  if (flags >= 0) ::fcntl(fd_, F_SETFL, flags | O_NONBLOCK);
}

FdTransport::~FdTransport() { close(); }

std::expected<void, TransportError> FdTransport::open() {
  if (open_) return {};
  if (ownership_ == Ownership::owned) return fail(Kind::closed, label_ + ": closed");
  open_ = true;
  return {};
}

void FdTransport::close() {
  if (!open_) return;
  open_ = false;
  if (ownership_ == Ownership::owned) {
    ::shutdown(fd_, SHUT_RDWR);  // fails harmlessly on anything but a socket
    ::close(fd_);
    fd_ = -1;
  }
}

bool FdTransport::is_open() const { return open_; }

FdTransport::Wait FdTransport::wait_for(short events, drivers::Deadline deadline) const {
  for (;;) {
    if (interrupted_) return Wait::interrupted;
    pollfd fds[2] = {{fd_, events, 0}, {wake_.get(), POLLIN, 0}};
    const int ready = ::poll(fds, 2, poll_timeout_ms(deadline));
    if (ready < 0 && errno == EINTR) continue;
    if (ready < 0) return Wait::failed;
    if (interrupted_) return Wait::interrupted;
    if (fds[0].revents != 0) return Wait::ready;  // data, room, or an error or hang-up to read
    if (drivers::Clock::now() >= deadline) return Wait::timeout;
  }
}

std::expected<void, TransportError> FdTransport::flush_input() {
  if (!open_) return fail(Kind::closed, label_ + ": not open");
  char sink[512];
  for (;;) {
    const ssize_t n = ::read(fd_, sink, sizeof sink);
    if (n > 0) continue;
    if (n == 0) return fail(Kind::closed, label_ + ": closed by the peer");
    if (errno == EINTR) continue;
    if (errno == EAGAIN || errno == EWOULDBLOCK) return {};
    if (peer_gone(errno)) return fail(Kind::closed, fmt::format("{}: {}", label_, std::strerror(errno)));
    return fail(Kind::io, fmt::format("{}: flush: {}", label_, std::strerror(errno)));
  }
}

std::expected<void, TransportError> FdTransport::write(std::string_view bytes, drivers::Deadline deadline) {
  if (!open_) return fail(Kind::closed, label_ + ": not open");
  std::size_t sent = 0;
  while (sent < bytes.size()) {
    if (interrupted_) return fail(Kind::interrupted, label_ + ": interrupted");
    const ssize_t n = ::write(fd_, bytes.data() + sent, bytes.size() - sent);
    if (n > 0) {
      sent += static_cast<std::size_t>(n);
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK) {
      if (peer_gone(errno)) return fail(Kind::closed, fmt::format("{}: {}", label_, std::strerror(errno)));
      return fail(Kind::io, fmt::format("{}: write: {}", label_, std::strerror(errno)));
    }
    switch (wait_for(POLLOUT, deadline)) {
      case Wait::ready:
        break;
      case Wait::interrupted:
        return fail(Kind::interrupted, label_ + ": interrupted");
      case Wait::timeout:
        return fail(Kind::timeout,
                    fmt::format("{}: wrote {} of {} bytes before the deadline", label_, sent, bytes.size()));
      case Wait::failed:
        return fail(Kind::io, fmt::format("{}: poll: {}", label_, std::strerror(errno)));
    }
  }
  return {};
}

std::expected<std::size_t, TransportError> FdTransport::read(char* buffer, std::size_t size,
                                                             drivers::Deadline deadline) {
  if (!open_) return fail(Kind::closed, label_ + ": not open");
  if (size == 0) return 0;
  for (;;) {
    if (interrupted_) return fail(Kind::interrupted, label_ + ": interrupted");
    const ssize_t n = ::read(fd_, buffer, size);
    if (n > 0) return static_cast<std::size_t>(n);
    if (n == 0) return fail(Kind::closed, label_ + ": closed by the peer");
    if (errno == EINTR) continue;
    if (errno != EAGAIN && errno != EWOULDBLOCK) {
      if (peer_gone(errno)) return fail(Kind::closed, fmt::format("{}: {}", label_, std::strerror(errno)));
      return fail(Kind::io, fmt::format("{}: read: {}", label_, std::strerror(errno)));
    }
    switch (wait_for(POLLIN, deadline)) {
      case Wait::ready:
        break;
      case Wait::interrupted:
        return fail(Kind::interrupted, label_ + ": interrupted");
      case Wait::timeout:
        return fail(Kind::timeout, label_ + ": nothing received before the deadline");
      case Wait::failed:
        return fail(Kind::io, fmt::format("{}: poll: {}", label_, std::strerror(errno)));
    }
  }
}

std::expected<void, TransportError> FdTransport::set_modem_lines(bool, bool) { return {}; }

void FdTransport::interrupt() {
  interrupted_ = true;
  const std::uint64_t one = 1;
  [[maybe_unused]] const ssize_t n = ::write(wake_.get(), &one, sizeof one);
}

void FdTransport::clear_interrupt() {
  interrupted_ = false;
  std::uint64_t count = 0;
  [[maybe_unused]] const ssize_t n = ::read(wake_.get(), &count, sizeof count);
}

std::string FdTransport::describe() const { return label_; }

}  // namespace skinspec::sim_app
