#include "endpoints.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <fmt/format.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <stdlib.h>
#include <sys/socket.h>
#include <termios.h>

#include <cerrno>
#include <charconv>
#include <cstring>

namespace skinspec::sim_app {

namespace {

std::string system_error(std::string_view what) { return fmt::format("{}: {}", what, std::strerror(errno)); }

// A socket address from a numeric host; the family tells which member is in use.
struct SocketAddress {
  sockaddr_storage storage{};
  socklen_t length = 0;

  sockaddr* get() { return reinterpret_cast<sockaddr*>(&storage); }
};

std::expected<SocketAddress, std::string> socket_address(const ListenAddress& address) {
  SocketAddress out;
  auto* v4 = reinterpret_cast<sockaddr_in*>(&out.storage);
  auto* v6 = reinterpret_cast<sockaddr_in6*>(&out.storage);
  if (::inet_pton(AF_INET, address.host.c_str(), &v4->sin_addr) == 1) {
    v4->sin_family = AF_INET;
    v4->sin_port = htons(address.port);
    out.length = sizeof(sockaddr_in);
  } else if (::inet_pton(AF_INET6, address.host.c_str(), &v6->sin6_addr) == 1) {
    v6->sin6_family = AF_INET6;
    v6->sin6_port = htons(address.port);
    out.length = sizeof(sockaddr_in6);
  } else {
    return std::unexpected(fmt::format("'{}' is not a numeric IPv4 or IPv6 address", address.host));
  }
  return out;
}

std::string describe_address(const sockaddr_storage& storage) {
  char text[INET6_ADDRSTRLEN] = {};
  if (storage.ss_family == AF_INET6) {
    const auto* v6 = reinterpret_cast<const sockaddr_in6*>(&storage);
    ::inet_ntop(AF_INET6, &v6->sin6_addr, text, sizeof text);
    return fmt::format("[{}]:{}", text, ntohs(v6->sin6_port));
  }
  const auto* v4 = reinterpret_cast<const sockaddr_in*>(&storage);
  ::inet_ntop(AF_INET, &v4->sin_addr, text, sizeof text);
  return fmt::format("{}:{}", text, ntohs(v4->sin_port));
}

}  // namespace

std::expected<ListenAddress, std::string> parse_listen_address(std::string_view text) {
  const auto bad = [&](std::string_view why) {
    return std::unexpected(fmt::format("--listen '{}': {} (expected HOST:PORT, e.g. 127.0.0.1:4001)", text, why));
  };
  const auto colon = text.rfind(':');
  if (colon == std::string_view::npos) return bad("no port");
  std::string_view host = text.substr(0, colon);
  const std::string_view port = text.substr(colon + 1);
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  if (host.empty()) return bad("no host");
  unsigned value = 0;
  const auto [end, ec] = std::from_chars(port.data(), port.data() + port.size(), value);
  if (port.empty() || ec != std::errc() || end != port.data() + port.size() || value > 65535)
    return bad("the port is not a number 0-65535");
  ListenAddress address{host == "localhost" ? std::string("127.0.0.1") : std::string(host),
                        static_cast<unsigned short>(value)};
  if (auto checked = socket_address(address); !checked) return bad(checked.error());
  return address;
}

std::expected<Listener, std::string> Listener::open(const ListenAddress& address) {
  auto where = socket_address(address);
  if (!where) return std::unexpected(where.error());
  const std::string label = fmt::format("listen on {}:{}", address.host, address.port);
  Listener listener;
  listener.fd_.reset(::socket(where->storage.ss_family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0));
  if (!listener.fd_.valid()) return std::unexpected(system_error(label));
  const int on = 1;
  ::setsockopt(listener.fd(), SOL_SOCKET, SO_REUSEADDR, &on, sizeof on);
  if (::bind(listener.fd(), where->get(), where->length) != 0) return std::unexpected(system_error(label));
  if (::listen(listener.fd(), 8) != 0) return std::unexpected(system_error(label));
  sockaddr_storage bound{};
  socklen_t length = sizeof bound;
  if (::getsockname(listener.fd(), reinterpret_cast<sockaddr*>(&bound), &length) != 0)
    return std::unexpected(system_error(label));
  listener.address_ = describe_address(bound);
  return listener;
}

UniqueFd Listener::accept(std::string& peer) const {
  for (;;) {
    sockaddr_storage from{};
    socklen_t length = sizeof from;
    UniqueFd client(::accept4(fd(), reinterpret_cast<sockaddr*>(&from), &length, SOCK_NONBLOCK | SOCK_CLOEXEC));
    if (!client.valid() && (errno == EINTR || errno == ECONNABORTED)) continue;
    if (!client.valid()) return client;
    const int on = 1;
    ::setsockopt(client.get(), IPPROTO_TCP, TCP_NODELAY, &on, sizeof on);
    peer = describe_address(from);
    return client;
  }
}

std::expected<Pty, std::string> Pty::open() {
  Pty pty;
  pty.fd_.reset(::posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC));
  if (!pty.fd_.valid()) return std::unexpected(system_error("pseudo-terminal: posix_openpt"));
  if (::grantpt(pty.fd()) != 0) return std::unexpected(system_error("pseudo-terminal: grantpt"));
  if (::unlockpt(pty.fd()) != 0) return std::unexpected(system_error("pseudo-terminal: unlockpt"));
  char name[128] = {};
  if (const int error = ::ptsname_r(pty.fd(), name, sizeof name); error != 0)
    return std::unexpected(fmt::format("pseudo-terminal: ptsname: {}", std::strerror(error)));
  pty.path_ = name;
  // Raw, as a serial line to a meter: every byte as it comes, nothing added or taken away.
  // The settings belong to the terminal, so they hold for every client that opens it.
  termios settings{};
  if (::tcgetattr(pty.fd(), &settings) != 0) return std::unexpected(system_error("pseudo-terminal: tcgetattr"));
  ::cfmakeraw(&settings);
  ::cfsetispeed(&settings, B9600);
  ::cfsetospeed(&settings, B9600);
  settings.c_cflag |= CLOCAL | CREAD;
  if (::tcsetattr(pty.fd(), TCSANOW, &settings) != 0)
    return std::unexpected(system_error("pseudo-terminal: tcsetattr"));
  const int flags = ::fcntl(pty.fd(), F_GETFL);
  if (flags < 0 || ::fcntl(pty.fd(), F_SETFL, flags | O_NONBLOCK) != 0)
    return std::unexpected(system_error("pseudo-terminal: fcntl"));
  return pty;
}

}  // namespace skinspec::sim_app
