#pragma once
// A byte stream to an instrument: a serial port, a TCP serial server, or an in-process peer.
// Every blocking call takes a deadline, and interrupt() wakes a blocked call from another
// thread, so that no caller can hang on a silent instrument.

#include <chrono>
#include <expected>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

namespace skinspec::drivers {

using Clock = std::chrono::steady_clock;
using Deadline = Clock::time_point;

inline Deadline deadline_in(std::chrono::milliseconds from_now) { return Clock::now() + from_now; }

struct TransportError {
  enum class Kind {
    timeout,      // nothing (more) arrived before the deadline
    interrupted,  // interrupt() was called
    closed,       // the peer closed the connection or the device went away
    io,           // the operating system reported an error
    not_found,    // the port or host does not exist
  };
  Kind kind;
  std::string message;
};

std::string_view to_string(TransportError::Kind kind);

class Transport {
 public:
  virtual ~Transport() = default;

  virtual std::expected<void, TransportError> open() = 0;
  virtual void close() = 0;
  virtual bool is_open() const = 0;

  // Discards whatever has been received and not yet read.
  virtual std::expected<void, TransportError> flush_input() = 0;
  // Writes all bytes or fails.
  virtual std::expected<void, TransportError> write(std::string_view bytes, Deadline deadline) = 0;
  // Reads at least one byte (at most buffer size) or fails with timeout/interrupted/closed.
  virtual std::expected<std::size_t, TransportError> read(char* buffer, std::size_t size, Deadline deadline) = 0;
  // DTR and RTS; transports without modem lines accept and ignore this.
  virtual std::expected<void, TransportError> set_modem_lines(bool dtr, bool rts) = 0;
  // Whether the other end is known to be gone (a TCP peer that closed or reset the connection,
  // a device that vanished), told without reading or waiting; false where the transport cannot
  // tell. For noticing a dead link while nothing is exchanged on it.
  virtual bool peer_closed() { return false; }

  // Makes a blocked or the next read/write return `interrupted`. Safe from any thread.
  virtual void interrupt() = 0;
  // Clears a pending interrupt so the transport can be used again.
  virtual void clear_interrupt() = 0;

  // The open link's file descriptor, for writing to it from a signal handler
  // (emergency_quit.hpp); -1 when closed or when the link has none.
  virtual int native_handle() const { return -1; }

  // "serial:/dev/ttyUSB0", "tcp:127.0.0.1:4001", ...
  virtual std::string describe() const = 0;
};

// Where an instrument is, parsed from a connection URI:
//   serial:/dev/ttyUSB0[?baud=9600&flow=none|rtscts|xonxoff&terminator=lf|cr&pacing_ms=N]
//   tcp:HOST:PORT[?terminator=lf|cr&pacing_ms=N]
//   usb:VID:PID[:SERIAL][?baud=...&terminator=...&pacing_ms=...]     (VID and PID in hex)
struct ConnectionUri {
  enum class Scheme { serial, tcp, usb };
  Scheme scheme = Scheme::serial;
  std::string path;                              // serial: device path
  std::string host;                              // tcp
  unsigned short port = 0;                       // tcp
  unsigned short vendor_id = 0, product_id = 0;  // usb
  std::string usb_serial;                        // usb, optional
  unsigned baud = 9600;
  enum class Flow { none, rtscts, xonxoff } flow = Flow::none;
  // What commands end with, for every family; unset: each family's own (LF for the PR-650,
  // CR for the newer meters).
  std::optional<char> terminator;
  // The newer meters' pause between the bytes of a command (0: whole strings); unset: the
  // model's. The PR-650 takes whole strings.
  std::optional<int> pacing_ms;

  std::string to_string() const;
};

std::expected<ConnectionUri, std::string> parse_connection_uri(std::string_view text);

// Opens nothing yet: returns the transport for the URI (usb: resolves the adapter's current
// tty through discovery). Errors name what is wrong with the URI or what was not found.
std::expected<std::unique_ptr<Transport>, std::string> make_transport(const ConnectionUri& uri);

}  // namespace skinspec::drivers
