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

#include "skinspec/drivers/pr650_exchange.hpp"
#include "skinspec/drivers/pr650_protocol.hpp"
#include "skinspec/drivers/transport.hpp"

namespace skinspec::drivers {

struct InstrumentError {
  enum class Kind {
    no_contact,   // never answered: outside its power-on window, off, or wrong port
    lost,         // answered before, now silent or the link failed
    protocol,     // a reply that cannot be what the meter sends, even after asking again
    bad_reading,  // the meter measured but its quality code makes the reading unusable
    rejected,     // the meter refused a setup
    cancelled,
    transport,  // the port or host could not be opened
  };
  Kind kind;
  std::string message;
  int quality_code = -1;  // for bad_reading
  std::string raw_reply;  // the meter's bytes, when there were any (for the record)
};

std::string_view to_string(InstrumentError::Kind kind);

struct Identity {
  std::string serial_number;
  pr650::SpectralConfiguration configuration;
};

struct DriverOptions {
  pr650::CommandStyle style;  // terminator from the URI
  int contact_attempts = 5;
  std::chrono::milliseconds modem_settle{500};  // after raising DTR/RTS
  pr650::ReplyTiming timing;                    // how long each reply may take
};

// The options for a connection: the URI's terminator, and for a serial port its line rate. A
// TCP serial server relays the meter's own 9600 baud line.
DriverOptions driver_options_for(const ConnectionUri& uri);

struct MeasureOptions {
  int integration_ms = 0;                               // 10-6000, or 0 = adaptive
  int averages = 1;                                     // 1-99
  enum class Sync { off, automatic } sync = Sync::off;  // automatic: measure the flicker first
  bool adjust_integration = false;                      // double on low light, halve on overload (fixed time only)
  bool si_units = true;
};

struct Reading {
  int quality_code = 0;
  std::string quality;          // the code's message
  int units_code = 0;           // D5 units: 0 radiance, 1 irradiance, 2 uncalibrated
  std::string units;            // "W/(sr m2 nm)" ...
  std::string luminance_units;  // "cd/m2" or "fL" ...
  int integration_ms = 0;       // as asked (0 = adaptive)
  int averages = 1;
  std::string sync;                   // "off" or "last measured frequency (60.02 Hz)"
  std::vector<double> wavelength_nm;  // native grid, 380-780 by 4
  std::vector<double> radiance;       // per nm, as the meter prints it
  double integrated = 0;
  double luminance = 0, x = 0, y = 0;  // from report 1
  std::array<double, 3> xyz{};         // from report 2
  std::string serial_number;
  std::chrono::system_clock::time_point started, finished;
  std::string raw_reply;  // the D5, D1 and D2 replies as received
  int attempts = 1;       // measurements made for this reading
  // What whoever keeps the reading should know about how it was taken, each starting with a
  // code: "remeasured:" when a measurement never answered and was made again.
  std::vector<std::string> warnings;
};

class Pr650 {
 public:
  Pr650(std::unique_ptr<Transport> transport, DriverOptions options = {});
  ~Pr650();
  Pr650(const Pr650&) = delete;
  Pr650& operator=(const Pr650&) = delete;

  // Opens the port, wiggles DTR/RTS as the meter's own software does, and makes first
  // contact (backlight command) with bounded retries.
  std::expected<void, InstrumentError> connect();
  void disconnect();
  bool connected() const { return connected_; }
  // Whether the link is known to be dead without a word on it (transport.hpp, peer_closed()):
  // for noticing, while idle, a meter or serial server that went away. Not during a call.
  bool link_closed();
  // Replies (whole or not) received since this driver was made: a caller compares two counts
  // to tell a failure on its first command from one after the meter had answered.
  std::uint64_t replies_received() const { return replies_; }

  std::expected<Identity, InstrumentError> identify();
  std::expected<Reading, InstrumentError> measure(const MeasureOptions& options);

  // Ends a running call (measure, connect, identify) with `cancelled`. Any thread.
  void cancel();

  std::string describe() const { return transport_->describe(); }
  const std::string& serial_number() const { return serial_number_; }

 private:
  // How the wait for one reply ended: all of it, nothing at all, or a start that stopped.
  enum class ReplyEnd { complete, silent, cut };
  struct Reply {
    ReplyEnd end = ReplyEnd::silent;
    std::string bytes;    // without any echo of the command
    std::string surplus;  // what came after a complete reply in the same read
  };
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
  std::expected<void, InstrumentError> drain_pending_measurement();
  InstrumentError link_error(const TransportError& error, const std::string& command) const;

  std::unique_ptr<Transport> transport_;
  DriverOptions options_;
  std::atomic<bool> cancelled_{false};
  std::atomic<bool> connected_{false};
  std::atomic<std::uint64_t> replies_{0};
  bool measurement_pending_ = false;  // an M command whose reply never came (cancelled)
  std::string serial_number_;
  std::mutex call_mutex_;  // one call on the wire at a time
};

}  // namespace skinspec::drivers
