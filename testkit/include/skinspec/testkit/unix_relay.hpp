#pragma once
// A relay in front of a Unix socket, for tests of a network that fails between a client and its
// server: each connection made to the relay's socket is carried to the server's, byte for byte,
// until cut_clients() closes the client sides of those open then. Their server sides stay open
// and silent, as after a partition the server did not see: a PostgreSQL backend behind one
// lives on, holding what it held, until it next hears from its client or is ended.
// One thread carries every connection with blocking sends: it is meant for request and reply
// traffic of some kilobytes, as a database client's, not for bulk streams both ways at once.

#include <filesystem>
#include <memory>

namespace skinspec::testing {

class UnixRelay {
 public:
  // Listens on `listen_path` and carries each connection to `server_path`; throws
  // std::runtime_error if it cannot listen or a path is too long for a socket.
  UnixRelay(std::filesystem::path listen_path, std::filesystem::path server_path);
  // Stops carrying and closes every socket, server sides too.
  ~UnixRelay();
  UnixRelay(const UnixRelay&) = delete;
  UnixRelay& operator=(const UnixRelay&) = delete;

  // Closes the client side of every connection open now, and returns once it is closed; later
  // connections are carried as before.
  void cut_clients();
  // The network down: cut_clients(), and every connection made until come_back() closed at once.
  void go_down();
  void come_back();

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace skinspec::testing
