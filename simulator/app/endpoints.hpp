#pragma once
// Where skinspec-sim meets its clients: a TCP listener and a pseudo-terminal.

#include <expected>
#include <string>
#include <string_view>

#include "unique_fd.hpp"

namespace skinspec::sim_app {

// "127.0.0.1:4001", "localhost:0", "[::1]:4001": a numeric address (or localhost) and a port,
// 0 for any free one.
struct ListenAddress {
  std::string host;  // numeric, without brackets
  unsigned short port = 0;
};

std::expected<ListenAddress, std::string> parse_listen_address(std::string_view text);

// A listening TCP socket (non-blocking).
class Listener {
 public:
  static std::expected<Listener, std::string> open(const ListenAddress& address);

  int fd() const { return fd_.get(); }
  // The address it listens on, with the port the system chose: "127.0.0.1:40123".
  const std::string& address() const { return address_; }

  // The next waiting connection (non-blocking, close-on-exec, no Nagle delay) and the peer's
  // address, or an invalid descriptor when none is waiting.
  UniqueFd accept(std::string& peer) const;

 private:
  UniqueFd fd_;
  std::string address_;
};

// The master side of a pseudo-terminal in raw mode (8 bits, no echo, no line editing, no
// CR/LF translation), non-blocking. Clients open path(), the slave side.
class Pty {
 public:
  static std::expected<Pty, std::string> open();

  int fd() const { return fd_.get(); }
  const std::string& path() const { return path_; }

 private:
  UniqueFd fd_;
  std::string path_;
};

}  // namespace skinspec::sim_app
