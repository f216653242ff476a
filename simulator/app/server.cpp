#include "server.hpp"

#include <fmt/format.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdint>
#include <cstring>

namespace skinspec::sim_app {

namespace {

using namespace std::chrono_literals;
using SteadyClock = std::chrono::steady_clock;

constexpr auto kRefusedLinger = 1s;  // how long a refused client may take to read the message
// A client that connects while another is served is refused only if that session is still on
// after this long: a program that connects right after the previous one closed (a script
// measuring twice) must not be refused because the server had not noticed the close yet.
constexpr auto kBusyGrace = 250ms;
constexpr int kIdlePtyLookMs = 50;  // how often to look at a pseudo-terminal nobody has open

// What poll() reports for `fd` right now.
short ready_now(int fd) {
  pollfd one{fd, POLLIN, 0};
  return ::poll(&one, 1, 0) > 0 ? one.revents : 0;
}

int milliseconds_until(SteadyClock::time_point when) {
  const auto left = std::chrono::ceil<std::chrono::milliseconds>(when - SteadyClock::now()).count();
  return static_cast<int>(std::max<std::chrono::milliseconds::rep>(0, left));
}

// A shorter timeout wins; -1 (none) loses to any.
void at_most(int& timeout, int ms) { timeout = timeout < 0 ? ms : std::min(timeout, ms); }

}  // namespace

Server::Server(simulator::SimulatedMeter& meter, const Signals& signals, Console& console,
               std::optional<Listener> listener, std::optional<Pty> pty)
    : meter_(meter),
      signals_(signals),
      console_(console),
      listener_(std::move(listener)),
      pty_(std::move(pty)),
      ended_(::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC)) {}

Server::~Server() { stop_session(); }

void Server::run() {
  bool stopping = false;
  while (!stopping) {
    // A pseudo-terminal client is noticed by its first bytes. While nobody has the terminal
    // open it reports a hang-up without end, so then it is looked at every few ms instead.
    int timeout = -1;
    bool watch_pty = false;
    if (pty_ && !session_) {
      const short pty_state = ready_now(pty_->fd());
      if (pty_state & POLLIN) {
        start_session(
            std::make_unique<FdTransport>(pty_->fd(), "pty " + pty_->path(), FdTransport::Ownership::borrowed),
            "pty " + pty_->path(), true);
        continue;
      }
      if (pty_state & (POLLHUP | POLLERR)) at_most(timeout, kIdlePtyLookMs);
      else watch_pty = true;
    }

    // While a session is on, a new client is left waiting in the listen queue for a moment.
    const bool watch_listener = listener_ && !(session_ && client_waiting_since_);
    if (session_ && client_waiting_since_) at_most(timeout, milliseconds_until(*client_waiting_since_ + kBusyGrace));

    std::vector<pollfd> fds{{signals_.fd(), POLLIN, 0}, {ended_.get(), POLLIN, 0}};
    const std::size_t listener_at = fds.size();
    if (watch_listener) fds.push_back({listener_->fd(), POLLIN, 0});
    if (watch_pty) fds.push_back({pty_->fd(), POLLIN, 0});
    const std::size_t refused_at = fds.size();
    for (const auto& r : refused_) {
      fds.push_back({r.fd.get(), POLLIN, 0});
      at_most(timeout, milliseconds_until(r.until));
    }

    if (::poll(fds.data(), fds.size(), timeout) < 0 && errno != EINTR) {
      console_.error(fmt::format("poll: {}", std::strerror(errno)));
      break;
    }
    handle_signals(stopping);
    if (stopping) break;
    if (fds[1].revents != 0) finish_session();
    if (watch_listener && fds[listener_at].revents != 0) {
      if (session_) client_waiting_since_ = SteadyClock::now();
      else accept_clients();
    } else if (client_waiting_since_ && (!session_ || SteadyClock::now() >= *client_waiting_since_ + kBusyGrace)) {
      client_waiting_since_.reset();
      accept_clients();  // served if the session has ended, else told it is busy
    }
    std::vector<short> refused_events;
    for (std::size_t i = refused_at; i < fds.size(); ++i) refused_events.push_back(fds[i].revents);
    drain_refused(refused_events);
  }
  stop_session();
}

void Server::handle_signals(bool& stopping) {
  for (int signal = signals_.take(); signal != 0; signal = signals_.take()) {
    if (signal == SIGHUP) {
      console_.note("SIGHUP: power-cycling the meter");
      meter_.power_cycle();
    } else {
      console_.note(fmt::format("{}: stopping", signal == SIGINT ? "SIGINT" : "SIGTERM"));
      stopping = true;
    }
  }
}

// With no session on, the first waiting client is served and the others stay in the listen
// queue: they get the grace period too, since the one served may be a probe that has already
// closed. With a session on (its grace period over), every waiting client is refused.
void Server::accept_clients() {
  for (;;) {
    std::string peer;
    UniqueFd client = listener_->accept(peer);
    if (!client.valid()) {
      if (errno != EAGAIN && errno != EWOULDBLOCK) console_.error(fmt::format("accept: {}", std::strerror(errno)));
      return;
    }
    if (session_) {
      refuse(std::move(client), peer);
      continue;
    }
    const std::string who = "client " + peer;
    start_session(std::make_unique<FdTransport>(client.release(), who, FdTransport::Ownership::owned), who, false);
    return;
  }
}

void Server::start_session(std::unique_ptr<FdTransport> link, std::string who, bool on_pty) {
  session_ = std::make_unique<Session>();
  session_->who = std::move(who);
  session_->on_pty = on_pty;
  session_->link = std::move(link);
  console_.note(fmt::format("{}: connected", session_->who));
  Session* session = session_.get();
  session->thread = std::thread([this, session] {
    session->end = meter_.serve(*session->link, stop_);
    const std::uint64_t one = 1;
    [[maybe_unused]] const ssize_t n = ::write(ended_.get(), &one, sizeof one);
  });
}

void Server::finish_session() {
  std::uint64_t count = 0;
  [[maybe_unused]] const ssize_t n = ::read(ended_.get(), &count, sizeof count);
  if (!session_) return;
  session_->thread.join();
  console_.note(fmt::format("{}: {}", session_->who, simulator::to_string(session_->end)));
  session_.reset();
}

void Server::refuse(UniqueFd client, const std::string& peer) {
  console_.note(fmt::format("client {}: refused, busy with {}", peer, session_->who));
  [[maybe_unused]] const ssize_t n = ::send(client.get(), kBusyMessage.data(), kBusyMessage.size(), MSG_NOSIGNAL);
  ::shutdown(client.get(), SHUT_WR);
  refused_.push_back({std::move(client), SteadyClock::now() + kRefusedLinger});
}

void Server::drain_refused(const std::vector<short>& events) {
  const auto now = SteadyClock::now();
  std::vector<Refused> still;
  for (std::size_t i = 0; i < refused_.size(); ++i) {
    bool done = now >= refused_[i].until;
    if (!done && i < events.size() && events[i] != 0) {
      char sink[512];
      ssize_t got = 0;
      while ((got = ::recv(refused_[i].fd.get(), sink, sizeof sink, MSG_DONTWAIT)) > 0) {
      }
      done = got == 0 || (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR);
    }
    if (!done) still.push_back(std::move(refused_[i]));
  }
  refused_ = std::move(still);
}

void Server::stop_session() {
  stop_ = true;
  if (!session_) return;
  session_->link->interrupt();
  session_->thread.join();
  console_.note(fmt::format("{}: {}", session_->who, simulator::to_string(session_->end)));
  session_.reset();
}

}  // namespace skinspec::sim_app
