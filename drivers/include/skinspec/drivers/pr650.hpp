#pragma once
// The PR-650 driver: first contact, identification, configuration and measurement over any
// Transport. It never returns the spectrum of an earlier measurement after a failed one, tells
// a lost instrument from a bad reading, and can be cancelled from another thread.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <expected>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "skinspec/drivers/instrument.hpp"
#include "skinspec/drivers/pr650_exchange.hpp"
#include "skinspec/drivers/pr650_protocol.hpp"
#include "skinspec/drivers/stray_reply.hpp"
#include "skinspec/drivers/transport.hpp"

namespace skinspec::drivers {

struct DriverOptions {
  pr650::CommandStyle style;  // terminator from the URI
  int contact_attempts = 5;
  std::chrono::milliseconds modem_settle{500};  // after raising DTR/RTS
  pr650::ReplyTiming timing;                    // how long each reply may take
};

// The options for a connection: the URI's terminator, and for a serial port its line rate. A
// TCP serial server relays the meter's own 9600 baud line.
DriverOptions driver_options_for(const ConnectionUri& uri);

class Pr650 final : public Instrument {
 public:
  Pr650(std::unique_ptr<Transport> transport, DriverOptions options = {});
  ~Pr650() override;
  Pr650(const Pr650&) = delete;
  Pr650& operator=(const Pr650&) = delete;

  // Opens the port, wiggles DTR/RTS as the meter's own software does, and makes first
  // contact (backlight command) with bounded retries. A newer meter's answer is an
  // `identification` error; a no_contact error carries the last answer that was not a
  // PR-650's, if any, as its raw reply.
  std::expected<void, InstrumentError> connect() override;
  // First contact as connect() makes it, on a port that is open already (identification's
  // later attempts, open_instrument.hpp). With `end_stray_line` each attempt first sends a lone
  // terminator, which ends whatever another family's commands left in the meter's line buffer.
  std::expected<void, InstrumentError> contact(int attempts, bool end_stray_line);
  void disconnect() override;
  bool connected() const override { return connected_; }
  // Whether the link is known to be dead without a word on it (transport.hpp, peer_closed()):
  // for noticing, while idle, a meter or serial server that went away. Not during a call.
  bool link_closed() override;
  // Replies (whole or not) received since this driver was made: a caller compares two counts
  // to tell a failure on its first command from one after the meter had answered.
  std::uint64_t replies_received() const override { return replies_; }

  std::expected<Identity, InstrumentError> identify() override;
  // Its two reports are short whole-string exchanges: the check is identify() again.
  std::expected<void, InstrumentError> check() override;
  std::expected<Reading, InstrumentError> measure(const MeasureOptions& options) override;

  // Ends a running call (measure, connect, identify) with `cancelled`. Any thread.
  void cancel() override;

  std::string describe() const override { return transport_->describe(); }
  const std::string& serial_number() const override { return serial_number_; }
  std::chrono::milliseconds reading_time(const MeasureOptions& options) const override;

 private:
  // How the wait for one reply ended: all of it, nothing at all, or a start that stopped.
  enum class ReplyEnd { complete, silent, cut };
  struct Reply {
    ReplyEnd end = ReplyEnd::silent;
    std::string bytes;    // without any echo of the command
    std::string surplus;  // what came after a complete reply in the same read
  };
  std::expected<void, InstrumentError> make_contact(int attempts, bool end_stray_line);
  std::expected<Reply, InstrumentError> transact(const std::string& command, const pr650::ExchangeRule& rule);
  template <typename Parse>
  auto ask(const std::string& command, const pr650::ExchangeRule& rule, Parse parse) -> decltype(parse(std::string()));
  void settle(const pr650::ExchangeRule& rule);
  InstrumentError unanswered(const std::string& command, const Reply& reply, const pr650::ExchangeRule& rule) const;
  pr650::ExchangeRule rule(const pr650::Command& command) const {
    return pr650::exchange_rule(command, options_.timing);
  }
  std::expected<void, InstrumentError> send_setup(const pr650::Setup& setup);
  std::expected<pr650::Setup::Sync, InstrumentError> choose_sync(const MeasureOptions& options, double& hz);
  std::expected<void, InstrumentError> start_measurement(const MeasureOptions& options, int integration_ms,
                                                         Reading& reading);
  std::expected<Reading, InstrumentError> measure_once(const MeasureOptions& options, int integration_ms);
  std::expected<void, InstrumentError> read_colorimetry(const MeasureOptions& options, Reading& reading);
  InstrumentError link_error(const TransportError& error, const std::string& command) const;

  std::unique_ptr<Transport> transport_;
  DriverOptions options_;
  std::atomic<bool> cancelled_{false};
  std::atomic<bool> connected_{false};
  std::atomic<std::uint64_t> replies_{0};
  StrayReply stray_;  // the reply of an exchange a cancel cut short, dropped before the next
  std::string serial_number_;
  std::mutex call_mutex_;  // one call on the wire at a time
};

}  // namespace skinspec::drivers
