#include "skinspec/testkit/unix_relay.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
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

// Carries what is waiting on `from` to `to`; false once either side has closed.
bool carry(int from, int to) {
  std::array<char, 65536> buffer;
  const ssize_t got = ::recv(from, buffer.data(), buffer.size(), 0);
  if (got < 0 && errno == EINTR) return true;
  return got > 0 && write_all(to, buffer.data(), got);
}

}  // namespace

struct UnixRelay::State {
  // One connection carried: its client side (-1 once cut or closed) and its server side.
  struct Pair {
    int client = -1;
    int server = -1;
  };

  std::filesystem::path listen_path;
  sockaddr_un server_address{};
  int listener = -1;
  std::array<int, 2> wake{-1, -1};  // written to, to have the loop look at its orders
  std::mutex orders;
  bool stopping = false;
  bool refusing = false;                 // new connections closed at once (the network down)
  std::vector<std::promise<void>> cuts;  // each kept once the client sides are closed
  std::vector<Pair> pairs;               // the loop's alone while it runs
  std::thread loop;

  ~State() {
    for (auto& pair : pairs) close_pair(pair);
    for (const int fd : {listener, wake[0], wake[1]})
      if (fd >= 0) ::close(fd);
  }

  static void close_pair(Pair& pair) {
    if (pair.client >= 0) ::close(pair.client);
    if (pair.server >= 0) ::close(pair.server);
    pair = {};
  }

  void accept_one() {
    const int client = ::accept4(listener, nullptr, nullptr, SOCK_CLOEXEC);
    if (client < 0) return;
    if (std::lock_guard lock(orders); refusing) {
      ::close(client);
      return;
    }
    const int server = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (server < 0 ||
        ::connect(server, reinterpret_cast<const sockaddr*>(&server_address), sizeof(server_address)) != 0) {
      if (server >= 0) ::close(server);
      ::close(client);  // the client sees its connection refused
      return;
    }
    pairs.push_back({client, server});
  }

  // Takes the orders given since the last look; false once told to stop.
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
      for (auto& cut : cuts) cut.set_value();
      cuts.clear();
    }
    return !stopping;
  }

  // One poll of the wake pipe, the listener and every carried pair, and what it found done:
  // orders first (a cut closes client sides, which this pass then skips), the pairs by their
  // index as polled, and a new connection last, so that a descriptor closed in this pass and
  // reused by it is never taken for the old one. False once told to stop.
  bool carry_once() {
    std::vector<pollfd> polled{{wake[0], POLLIN, 0}, {listener, POLLIN, 0}};
    std::vector<std::size_t> polled_pairs;  // pairs' indexes, two pollfds each after the first two
    for (std::size_t i = 0; i < pairs.size(); ++i) {
      if (pairs[i].client < 0) continue;
      polled.push_back({pairs[i].client, POLLIN, 0});
      polled.push_back({pairs[i].server, POLLIN, 0});
      polled_pairs.push_back(i);
    }
    if (::poll(polled.data(), polled.size(), -1) < 0) {
      if (errno == EINTR) return true;
      std::perror("UnixRelay: poll");
      std::abort();  // a relay that no longer carries would leave its test waiting forever
    }
    if (polled[0].revents != 0 && !follow_orders()) return false;
    for (std::size_t k = 0; k < polled_pairs.size(); ++k) {
      auto& pair = pairs[polled_pairs[k]];
      if (pair.client < 0) continue;  // cut by the orders above
      const bool from_client = polled[2 + 2 * k].revents != 0, from_server = polled[3 + 2 * k].revents != 0;
      if ((from_client && !carry(pair.client, pair.server)) || (from_server && !carry(pair.server, pair.client)))
        close_pair(pair);
    }
    std::erase_if(pairs, [](const Pair& pair) { return pair.client < 0 && pair.server < 0; });
    if (polled[1].revents != 0) accept_one();
    return true;
  }

  void tell_to_stop() {
    {
      std::lock_guard lock(orders);
      stopping = true;
    }
    wake_loop();
  }

  void tell_to_cut(std::promise<void> cut) {
    {
      std::lock_guard lock(orders);
      cuts.push_back(std::move(cut));
    }
    wake_loop();
  }

  void wake_loop() {
    const char one = 1;
    if (::write(wake[1], &one, 1) < 0) {
      // Only a full pipe refuses a byte, and a full pipe wakes the loop already.
    }
  }
};

UnixRelay::UnixRelay(std::filesystem::path listen_path, std::filesystem::path server_path)
    : state_(std::make_unique<State>()) {
  auto& s = *state_;
  s.listen_path = std::move(listen_path);
  s.server_address = address_of(server_path);
  const auto listen_address = address_of(s.listen_path);
  if (::pipe2(s.wake.data(), O_CLOEXEC | O_NONBLOCK) != 0)
    throw std::runtime_error(std::string("UnixRelay: pipe: ") + std::strerror(errno));
  s.listener = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (s.listener < 0) throw std::runtime_error(std::string("UnixRelay: socket: ") + std::strerror(errno));
  if (::bind(s.listener, reinterpret_cast<const sockaddr*>(&listen_address), sizeof(listen_address)) != 0)
    throw std::runtime_error(std::string("UnixRelay: bind: ") + std::strerror(errno) + ": " + s.listen_path.string());
  if (::listen(s.listener, 16) != 0) {
    const std::string reason = std::strerror(errno);
    std::filesystem::remove(s.listen_path);
    throw std::runtime_error("UnixRelay: listen: " + reason);
  }
  s.loop = std::thread([&s] {
    while (s.carry_once()) {
    }
  });
}

void UnixRelay::go_down() {
  {
    std::lock_guard lock(state_->orders);
    state_->refusing = true;
  }
  cut_clients();
}

void UnixRelay::come_back() {
  std::lock_guard lock(state_->orders);
  state_->refusing = false;
}

UnixRelay::~UnixRelay() {
  auto& s = *state_;
  s.tell_to_stop();
  s.loop.join();
  std::error_code ignored;
  std::filesystem::remove(s.listen_path, ignored);
}  // ~State closes the sockets

void UnixRelay::cut_clients() {
  std::promise<void> cut;
  auto done = cut.get_future();
  state_->tell_to_cut(std::move(cut));
  done.wait();
}

}  // namespace skinspec::testing
