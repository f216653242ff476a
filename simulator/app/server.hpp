#pragma once
// skinspec-sim's loop: one meter, one client at a time, on a TCP listener, a pseudo-terminal,
// or both.
//
// A TCP client is served from the moment it connects until it disconnects; one that connects
// while another client is being served, and still is 250 ms later, gets the line kBusyMessage
// and is closed. The
// pseudo-terminal counts as a client from the first byte a program writes to it until the last
// program that has it open closes it; while a TCP client is served, what is written to the
// pseudo-terminal waits in it. The meter's state carries over from client to client.
//
// SIGTERM and SIGINT stop the loop: no new clients, the current session ended at once. SIGHUP
// power-cycles the meter (docs/simulator.md).

#include <atomic>
#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "console.hpp"
#include "endpoints.hpp"
#include "fd_transport.hpp"
#include "signals.hpp"
#include "skinspec/simulator/meter.hpp"

namespace skinspec::sim_app {

inline constexpr std::string_view kBusyMessage = "skinspec-sim: busy: another client is connected\r\n";

class Server {
 public:
  Server(simulator::SimulatedMeter& meter, const Signals& signals, Console& console, std::optional<Listener> listener,
         std::optional<Pty> pty);
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  // Serves until SIGTERM or SIGINT.
  void run();

 private:
  struct Session {
    std::string who;  // "client 127.0.0.1:50312" or "pty /dev/pts/3"
    bool on_pty = false;
    std::unique_ptr<FdTransport> link;
    simulator::SimulatedMeter::ServeEnd end = simulator::SimulatedMeter::ServeEnd::stopped;  // set by the thread
    std::thread thread;
  };
  // A refused client: told it is busy, its input drained until it closes or time runs out, so
  // that closing does not reset the connection before it has read the message.
  struct Refused {
    UniqueFd fd;
    std::chrono::steady_clock::time_point until;
  };

  void handle_signals(bool& stopping);
  void accept_clients();
  void start_session(std::unique_ptr<FdTransport> link, std::string who, bool on_pty);
  void finish_session();
  void refuse(UniqueFd client, const std::string& peer);
  void drain_refused(const std::vector<short>& events);
  void stop_session();

  simulator::SimulatedMeter& meter_;
  const Signals& signals_;
  Console& console_;
  std::optional<Listener> listener_;
  std::optional<Pty> pty_;
  std::atomic<bool> stop_{false};
  UniqueFd ended_;  // eventfd: a session thread has finished
  std::unique_ptr<Session> session_;
  std::vector<Refused> refused_;
  // When a client began to wait in the listen queue while another was served.
  std::optional<std::chrono::steady_clock::time_point> client_waiting_since_;
};

}  // namespace skinspec::sim_app
