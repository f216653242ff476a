// A serial port through libserialport (the one transport file that sees it).
//
// Reads and writes are nonblocking calls between waits of at most 50 ms, so a blocked call
// notices interrupt() from another thread within one slice and no wake-up descriptor of our
// own is needed. libserialport's sp_wait() does not say whether it woke for data or for a
// hang-up, so a wait that brings no bytes is followed by a FIONREAD (sp_input_waiting): the
// kernel fails it with EIO once a USB adapter has been pulled, which is how "closed" is told
// apart from "nothing yet".

#include <libserialport.h>

#include <fmt/format.h>
#include <poll.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <filesystem>
#include <optional>

#include "transport/transports.hpp"

namespace skinspec::drivers::detail {

namespace {

using namespace std::chrono_literals;
using Kind = TransportError::Kind;

constexpr auto kSlice = 50ms;

struct PortDeleter {
  void operator()(sp_port* port) const {
    sp_close(port);
    sp_free_port(port);
  }
};
struct EventSetDeleter {
  void operator()(sp_event_set* events) const { sp_free_event_set(events); }
};
struct ConfigDeleter {
  void operator()(sp_port_config* config) const { sp_free_config(config); }
};
using PortPtr = std::unique_ptr<sp_port, PortDeleter>;
using EventSetPtr = std::unique_ptr<sp_event_set, EventSetDeleter>;
using ConfigPtr = std::unique_ptr<sp_port_config, ConfigDeleter>;

std::unexpected<TransportError> fail(Kind kind, std::string message) {
  return std::unexpected(TransportError{kind, std::move(message)});
}

// The OS error behind the last SP_ERR_FAIL, as errno and text.
std::pair<int, std::string> last_os_error() {
  const int code = sp_last_error_code();
  char* text = sp_last_error_message();
  std::string message = text ? text : "unknown error";
  sp_free_error_message(text);
  return {code, message};
}

std::string_view library_error_text(sp_return code) {
  switch (code) {
    case SP_ERR_ARG:
      return "invalid argument";
    case SP_ERR_MEM:
      return "out of memory";
    case SP_ERR_SUPP:
      return "not supported by this port";
    default:
      return "failed";
  }
}

// An error while opening: a missing device is not_found, anything else is io with a hint
// for the two causes people meet most.
TransportError open_error(sp_return code, const std::string& what) {
  if (code != SP_ERR_FAIL) return {Kind::io, fmt::format("{}: {}", what, library_error_text(code))};
  const auto [errno_code, message] = last_os_error();
  if (errno_code == ENOENT || errno_code == ENODEV || errno_code == ENXIO)
    return {Kind::not_found, fmt::format("{}: no such device ({})", what, message)};
  if (errno_code == EACCES || errno_code == EPERM)
    return {Kind::io, fmt::format("{}: {} (is the user in the 'dialout' group?)", what, message)};
  if (errno_code == EBUSY) return {Kind::io, fmt::format("{}: {} (another program has the port open?)", what, message)};
  return {Kind::io, fmt::format("{}: {}", what, message)};
}

// An error on an open port: these errno values mean the device itself is gone.
TransportError io_error(sp_return code, const std::string& what) {
  if (code != SP_ERR_FAIL) return {Kind::io, fmt::format("{}: {}", what, library_error_text(code))};
  const auto [errno_code, message] = last_os_error();
  if (errno_code == EIO || errno_code == ENXIO || errno_code == ENODEV || errno_code == EPIPE || errno_code == EBADF)
    return {Kind::closed, fmt::format("{}: the device went away ({})", what, message)};
  return {Kind::io, fmt::format("{}: {}", what, message)};
}

// How long the next wait may be: up to one slice, never past the deadline, and never zero,
// which libserialport takes to mean "forever". Nothing once the deadline has passed.
std::optional<unsigned> next_slice(Deadline deadline) {
  const auto remaining = std::chrono::ceil<std::chrono::milliseconds>(deadline - Clock::now());
  if (remaining <= 0ms) return std::nullopt;
  return static_cast<unsigned>(std::clamp<std::chrono::milliseconds>(remaining, 1ms, kSlice).count());
}

sp_flowcontrol flow_control(ConnectionUri::Flow flow) {
  switch (flow) {
    case ConnectionUri::Flow::none:
      return SP_FLOWCONTROL_NONE;
    case ConnectionUri::Flow::rtscts:
      return SP_FLOWCONTROL_RTSCTS;
    case ConnectionUri::Flow::xonxoff:
      return SP_FLOWCONTROL_XONXOFF;
  }
  return SP_FLOWCONTROL_NONE;
}

class SerialTransport final : public Transport {
 public:
  SerialTransport(std::string path, const ConnectionUri& settings, std::string label)
      : path_(std::move(path)), baud_(settings.baud), flow_(settings.flow), label_(std::move(label)) {}
  ~SerialTransport() override { close(); }

  std::expected<void, TransportError> open() override {
    if (port_) return {};
    sp_port* raw = nullptr;
    if (const auto code = sp_get_port_by_name(path_.c_str(), &raw); code != SP_OK) {
      if (!std::filesystem::exists(path_)) return fail(Kind::not_found, fmt::format("{}: no such device", label_));
      // libserialport refuses what it does not take for a serial port, pseudo-terminals included.
      if (code == SP_ERR_ARG)
        return fail(Kind::io, fmt::format("{}: not a serial port libserialport can open", label_));
      return std::unexpected(open_error(code, label_));
    }
    // Free the port structure on every path; sp_close() on a port that failed to open is harmless.
    PortPtr port(raw);
    if (const auto code = sp_open(port.get(), SP_MODE_READ_WRITE); code != SP_OK)
      return std::unexpected(open_error(code, label_));
    if (auto configured = configure(port.get()); !configured) return configured;
    if (auto watched = watch(port.get()); !watched) {
      close();
      return watched;
    }
    port_ = std::move(port);
    return {};
  }

  void close() override {
    rx_events_.reset();
    tx_events_.reset();
    port_.reset();
  }

  bool is_open() const override { return port_ != nullptr; }
  int native_handle() const override {
    int fd = -1;
    if (port_ && sp_get_port_handle(port_.get(), &fd) == SP_OK) return fd;
    return -1;
  }

  std::expected<void, TransportError> flush_input() override {
    if (!port_) return not_open();
    if (const auto code = sp_flush(port_.get(), SP_BUF_INPUT); code != SP_OK)
      return std::unexpected(io_error(code, label_ + ": flush"));
    return {};
  }

  std::expected<void, TransportError> write(std::string_view bytes, Deadline deadline) override {
    if (!port_) return not_open();
    std::size_t written = 0;
    for (;;) {
      if (interrupted_) return fail(Kind::interrupted, label_ + ": interrupted");
      const auto result = sp_nonblocking_write(port_.get(), bytes.data() + written, bytes.size() - written);
      if (result < 0) return std::unexpected(io_error(result, label_ + ": write"));
      written += static_cast<std::size_t>(result);
      if (written == bytes.size()) return {};
      const auto slice = next_slice(deadline);
      if (!slice)
        return fail(Kind::timeout,
                    fmt::format("{}: wrote {} of {} bytes before the deadline", label_, written, bytes.size()));
      if (const auto code = sp_wait(tx_events_.get(), *slice); code != SP_OK)
        return std::unexpected(io_error(code, label_ + ": wait to write"));
    }
  }

  std::expected<std::size_t, TransportError> read(char* buffer, std::size_t size, Deadline deadline) override {
    if (!port_) return not_open();
    if (size == 0) return 0;
    for (;;) {
      if (interrupted_) return fail(Kind::interrupted, label_ + ": interrupted");
      const auto result = sp_nonblocking_read(port_.get(), buffer, size);
      if (result < 0) return std::unexpected(io_error(result, label_ + ": read"));
      if (result > 0) return static_cast<std::size_t>(result);
      if (const auto waiting = sp_input_waiting(port_.get()); waiting < 0)
        return std::unexpected(io_error(waiting, label_ + ": read"));
      const auto slice = next_slice(deadline);
      if (!slice) return fail(Kind::timeout, label_ + ": nothing received before the deadline");
      if (const auto code = sp_wait(rx_events_.get(), *slice); code != SP_OK)
        return std::unexpected(io_error(code, label_ + ": wait to read"));
    }
  }

  // With RTS/CTS flow control the UART drives RTS itself; setting it here would turn the
  // flow control off, so only DTR is ours then.
  std::expected<void, TransportError> set_modem_lines(bool dtr, bool rts) override {
    if (!port_) return not_open();
    if (const auto code = sp_set_dtr(port_.get(), dtr ? SP_DTR_ON : SP_DTR_OFF); code != SP_OK)
      return std::unexpected(io_error(code, label_ + ": set DTR"));
    if (flow_ == ConnectionUri::Flow::rtscts) return {};
    if (const auto code = sp_set_rts(port_.get(), rts ? SP_RTS_ON : SP_RTS_OFF); code != SP_OK)
      return std::unexpected(io_error(code, label_ + ": set RTS"));
    return {};
  }

  // An adapter pulled out hangs the tty up, and FIONREAD then fails with EIO.
  bool peer_closed() override {
    if (!port_) return false;
    if (sp_input_waiting(port_.get()) < 0) return true;
    int fd = -1;
    if (sp_get_port_handle(port_.get(), &fd) != SP_OK || fd < 0) return false;
    pollfd one{fd, POLLIN, 0};
    if (::poll(&one, 1, 0) <= 0) return false;
    return (one.revents & (POLLHUP | POLLERR | POLLNVAL)) != 0;
  }

  void interrupt() override { interrupted_ = true; }
  void clear_interrupt() override { interrupted_ = false; }
  std::string describe() const override { return label_; }

 private:
  std::unexpected<TransportError> not_open() const { return fail(Kind::closed, label_ + ": not open"); }

  // 8 data bits, no parity, 1 stop bit at the URI's baud rate and flow control, with DTR and
  // RTS raised: the PR-650's settings and what its makers' software leaves the lines at.
  std::expected<void, TransportError> configure(sp_port* port) {
    sp_port_config* raw = nullptr;
    if (const auto code = sp_new_config(&raw); code != SP_OK) return std::unexpected(open_error(code, label_));
    ConfigPtr config(raw);
    sp_set_config_baudrate(config.get(), static_cast<int>(baud_));
    sp_set_config_bits(config.get(), 8);
    sp_set_config_parity(config.get(), SP_PARITY_NONE);
    sp_set_config_stopbits(config.get(), 1);
    sp_set_config_flowcontrol(config.get(), flow_control(flow_));
    sp_set_config_dtr(config.get(), SP_DTR_ON);
    if (flow_ != ConnectionUri::Flow::rtscts) sp_set_config_rts(config.get(), SP_RTS_ON);
    if (const auto code = sp_set_config(port, config.get()); code != SP_OK)
      return std::unexpected(open_error(code, fmt::format("{}: cannot set {} baud 8N1", label_, baud_)));
    return {};
  }

  // The event sets the waits use. SP_EVENT_ERROR makes a hang-up end the wait at once.
  std::expected<void, TransportError> watch(sp_port* port) {
    sp_event_set* rx = nullptr;
    sp_event_set* tx = nullptr;
    if (sp_new_event_set(&rx) != SP_OK) return fail(Kind::io, label_ + ": out of memory");
    rx_events_.reset(rx);
    if (sp_new_event_set(&tx) != SP_OK) return fail(Kind::io, label_ + ": out of memory");
    tx_events_.reset(tx);
    const auto rx_mask = static_cast<sp_event>(SP_EVENT_RX_READY | SP_EVENT_ERROR);
    const auto tx_mask = static_cast<sp_event>(SP_EVENT_TX_READY | SP_EVENT_ERROR);
    if (const auto code = sp_add_port_events(rx, port, rx_mask); code != SP_OK)
      return std::unexpected(open_error(code, label_));
    if (const auto code = sp_add_port_events(tx, port, tx_mask); code != SP_OK)
      return std::unexpected(open_error(code, label_));
    return {};
  }

  std::string path_;
  unsigned baud_;
  ConnectionUri::Flow flow_;
  std::string label_;
  PortPtr port_;
  EventSetPtr rx_events_, tx_events_;
  std::atomic<bool> interrupted_{false};
};

}  // namespace

std::unique_ptr<Transport> make_serial_transport(std::string path, const ConnectionUri& settings, std::string label) {
  return std::make_unique<SerialTransport>(std::move(path), settings, std::move(label));
}

}  // namespace skinspec::drivers::detail
