#include "support/unix_relay.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <future>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace skinspec::testing {

namespace {

sockaddr_un address_of(const std::filesystem::path& path) {
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  const auto text = path.string();
  if (text.size() >= sizeof(address.sun_path)) throw std::runtime_error("UnixRelay: socket path too long: " + text);
  std::memcpy(address.sun_path, text.c_str(), text.size() + 1);
  return address;
}

int unix_socket() {
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) throw std::runtime_error(std::string("UnixRelay: socket: ") + std::strerror(errno));
  return fd;
}

// Writes all of `size` bytes, or returns false.
bool write_all(int fd, const char* data, ssize_t size) {
  while (size > 0) {
    const ssize_t written = ::send(fd, data, static_cast<std::size_t>(size), MSG_NOSIGNAL);
    if (written < 0 && errno == EINTR) continue;
    if (written <= 0) return false;
    data += written;
    size -= written;
  }
  return true;
}

}  // namespace

struct UnixRelay::State {
  // One connection carried: its client side (-1 once cut or closed) and its server side.
  struct Pair {
    int client = -1;
    int server = -1;
  };

  std::filesystem::path listen_path;
  std::filesystem::path server_path;
  int listener = -1;
  std::array<int, 2> wake{-1, -1};  // written to, to have the loop look at its orders
  std::mutex orders;
  bool stopping = false;
  std::vector<std::promise<void>> cuts;  // each kept once every client side is closed
  std::vector<Pair> pairs;
  std::thread loop;

  ~State() {
    for (auto& pair : pairs) close_pair(pair);
    for (const int fd : {listener, wake[0], wake[1]})
      if (fd >= 0) ::close(fd);
  }

  void accept_one() {
    const int client = ::accept4(listener, nullptr, nullptr, SOCK_CLOEXEC);
    if (client < 0) return;
    const int server = unix_socket();
    const auto address = address_of(server_path);
    if (::connect(server, reinterpret_cast<const sockaddr*>(&address), sizeof(address)) != 0) {
      ::close(server);
      ::close(client);
      return;
    }
    pairs.push_back({client, server});
  }

  // Carries what is waiting on `from` to `to`; false when either side has closed.
  static bool carry(int from, int to) {
    std::array<char, 65536> buffer;
    const ssize_t got = ::recv(from, buffer.data(), buffer.size(), 0);
    if (got < 0 && errno == EINTR) return true;
    return got > 0 && write_all(to, buffer.data(), got);
  }

  static void close_pair(Pair& pair) {
    if (pair.client >= 0) ::close(pair.client);
    if (pair.server >= 0) ::close(pair.server);
    pair = {};
  }

  // Returns false once told to stop.
  bool follow_orders() {
    std::array<char, 64> drained;
    while (::read(wake[0], drained.data(), drained.size()) > 0) {
    }
    std::lock_guard lock(orders);
    if (!cuts.empty()) {
      for (auto& pair : pairs) {
        if (pair.client >= 0) ::close(pair.client);
        pair.client = -1;  // the server side stays open, and is no longer read
      }
    }
    for (auto& cut : cuts) cut.set_value();
    cuts.clear();
    return !stopping;
  }

  void run() {
    for (;;) {
      std::vector<pollfd> polled{{wake[0], POLLIN, 0}, {listener, POLLIN, 0}};
      for (const auto& pair : pairs)
        if (pair.client >= 0) {
          polled.push_back({pair.client, POLLIN, 0});
          polled.push_back({pair.server, POLLIN, 0});
        }
      if (::poll(polled.data(), polled.size(), -1) < 0) {
        if (errno == EINTR) continue;
        return;
      }
      if (polled[0].revents != 0 && !follow_orders()) return;
      if (polled[1].revents != 0) accept_one();
      std::size_t next = 2;
      for (auto& pair : pairs) {
        if (pair.client < 0 || next >= polled.size() || polled[next].fd != pair.client) continue;
        const bool from_client = polled[next].revents != 0, from_server = polled[next + 1].revents != 0;
        next += 2;
        if ((from_client && !carry(pair.client, pair.server)) || (from_server && !carry(pair.server, pair.client)))
          close_pair(pair);
      }
      std::erase_if(pairs, [](const Pair& pair) { return pair.client < 0 && pair.server < 0; });
    }
  }

  void order(bool stop, std::promise<void>* cut) {
    {
      std::lock_guard lock(orders);
      stopping = stopping || stop;
      if (cut) cuts.push_back(std::move(*cut));
    }
    const char one = 1;
    if (::write(wake[1], &one, 1) != 1) throw std::runtime_error("UnixRelay: cannot wake its thread");
  }
};

UnixRelay::UnixRelay(std::filesystem::path listen_path, std::filesystem::path server_path)
    : state_(std::make_unique<State>()) {
  auto& s = *state_;
  s.listen_path = std::move(listen_path);
  s.server_path = std::move(server_path);
  if (::pipe2(s.wake.data(), O_CLOEXEC | O_NONBLOCK) != 0)
    throw std::runtime_error(std::string("UnixRelay: pipe: ") + std::strerror(errno));
  s.listener = unix_socket();
  const auto address = address_of(s.listen_path);
  if (::bind(s.listener, reinterpret_cast<const sockaddr*>(&address), sizeof(address)) != 0 ||
      ::listen(s.listener, 16) != 0)
    throw std::runtime_error("UnixRelay: cannot listen on " + s.listen_path.string() + ": " + std::strerror(errno));
  s.loop = std::thread([&s] { s.run(); });
}

UnixRelay::~UnixRelay() {
  auto& s = *state_;
  s.order(true, nullptr);
  s.loop.join();
  std::error_code ignored;
  std::filesystem::remove(s.listen_path, ignored);
}  // ~State closes the sockets

void UnixRelay::cut_clients() {
  std::promise<void> cut;
  auto done = cut.get_future();
  state_->order(false, &cut);
  done.wait();
}

}  // namespace skinspec::testing
