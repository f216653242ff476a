#include "skinspec/drivers/pr650.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <optional>
#include <thread>
#include <utility>

#include "common/text.hpp"
#include "skinspec/drivers/identification.hpp"
#include "skinspec/drivers/measure_settings.hpp"

namespace skinspec::drivers {

namespace pp = pr650;
using namespace std::chrono_literals;

namespace {

constexpr int kMaxIntegrationMs = 6000, kMinIntegrationMs = 10;
constexpr int kMaxAttempts = 5;

std::unexpected<InstrumentError> fail(InstrumentError::Kind kind, std::string message, int quality = -1,
                                      std::string raw = {}) {
  return std::unexpected(InstrumentError{kind, std::move(message), quality, std::move(raw)});
}

std::string printable(std::string_view command) {
  std::string out(command);
  while (!out.empty() && (out.back() == '\n' || out.back() == '\r')) out.pop_back();
  return out;
}

std::string spectral_units(int code) {
  switch (code) {
    case 0:
      return "W/(sr m2 nm)";
    case 1:
      return "W/(m2 nm)";
    default:
      return "uncalibrated";
  }
}

std::string photometric_units(int code, bool si) {
  switch (code) {
    case 0:
      return si ? "cd/m2" : "fL";
    case 1:
      return si ? "lx" : "fc";
    default:
      return "uncalibrated";
  }
}

std::string describe_sync(pp::Setup::Sync sync, double hz) {
  switch (sync) {
    case pp::Setup::Sync::none:
      return "off";
    case pp::Setup::Sync::last_measured:
      return fmt::format("last measured frequency ({:.2f} Hz)", hz);
    case pp::Setup::Sync::frequency:
      return fmt::format("{:g} Hz (user)", hz);
  }
  return "off";
}

std::string seconds(std::chrono::milliseconds t) {
  return fmt::format("{:.3g} s", static_cast<double>(t.count()) / 1000);
}

// A report's values and its bytes as received, kept for the record.
template <typename T>
struct Parsed {
  T value;
  std::string raw;
};

// A parser's complaint about a reply, as the driver reports it.
InstrumentError garbled(std::string_view what, const pp::ProtocolError& error, std::string raw) {
  return {InstrumentError::Kind::protocol, fmt::format("{}: {}", what, error.message), -1, std::move(raw)};
}

}  // namespace

DriverOptions driver_options_for(const ConnectionUri& uri) {
  DriverOptions options;
  if (uri.terminator) options.style.terminator = *uri.terminator;
  if (uri.scheme != ConnectionUri::Scheme::tcp && uri.baud > 0) options.timing.line_bytes_per_second = uri.baud / 10.0;
  return options;
}

Pr650::Pr650(std::unique_ptr<Transport> transport, DriverOptions options)
    : transport_(std::move(transport)), options_(options) {}

Pr650::~Pr650() { disconnect(); }

void Pr650::cancel() {
  cancelled_ = true;
  transport_->interrupt();
}

void Pr650::disconnect() {
  if (transport_->is_open()) transport_->close();
  connected_ = false;
}

bool Pr650::link_closed() {
  std::unique_lock lock(call_mutex_, std::try_to_lock);
  if (!lock) return false;  // a call is on the wire: it will find out itself
  return !transport_->is_open() || transport_->peer_closed();
}

InstrumentError Pr650::link_error(const TransportError& error, const std::string& command) const {
  using K = TransportError::Kind;
  if (error.kind == K::interrupted || cancelled_) return {InstrumentError::Kind::cancelled, "cancelled", -1, {}};
  if (error.kind == K::timeout && !connected_)
    return {InstrumentError::Kind::no_contact,
            fmt::format("no answer from a PR-650 on {} to '{}'", transport_->describe(), printable(command)),
            -1,
            {}};
  if (error.kind == K::timeout)
    return {InstrumentError::Kind::lost,
            fmt::format("the PR-650 on {} did not take '{}' in time; is it still on and connected?",
                        transport_->describe(), printable(command)),
            -1,
            {}};
  return {
      InstrumentError::Kind::lost,
      fmt::format("lost the PR-650 on {} during '{}': {}", transport_->describe(), printable(command), error.message),
      -1,
      {}};
}

// One command and the wait for its reply, by the rule's two deadlines: the first byte of the
// reply (an echo of the command does not count), then no pause longer than `idle` until it is
// whole. Stale bytes are flushed first: a late reply to an earlier command would otherwise be
// taken for this one's. Silence and a reply that stopped are results, not errors: the caller's
// rule says what follows; errors are a failed link and cancel().
std::expected<Pr650::Reply, InstrumentError> Pr650::transact(const std::string& command, const pp::ExchangeRule& rule) {
  if (cancelled_ || !stray_.drop(*transport_, rule.idle)) return fail(InstrumentError::Kind::cancelled, "cancelled");
  if (auto flushed = transport_->flush_input(); !flushed) return std::unexpected(link_error(flushed.error(), command));
  if (auto written = transport_->write(command, deadline_in(rule.first_byte)); !written)
    return std::unexpected(link_error(written.error(), command));
  std::string received;
  Deadline next = deadline_in(rule.first_byte);
  std::optional<Deadline> whole;  // from the reply's first byte
  char buffer[512];
  for (;;) {
    const std::string_view reply = pp::strip_echo(received, command);
    if (const std::size_t size = pp::reply_size(rule.shape, reply); size > 0)
      return Reply{ReplyEnd::complete, std::string(reply.substr(0, size)), std::string(reply.substr(size))};
    auto n = transport_->read(buffer, sizeof buffer, whole ? std::min(next, *whole) : next);
    if (!n) {
      // Cancelled while the reply was due or coming: the meter sends the rest all the same.
      if (n.error().kind == TransportError::Kind::interrupted) stray_.expect_rest(whole, next, rule.whole);
      if (n.error().kind != TransportError::Kind::timeout) return std::unexpected(link_error(n.error(), command));
      if (reply.empty()) return Reply{ReplyEnd::silent, received, {}};
      return Reply{ReplyEnd::cut, std::string(reply), {}};
    }
    received.append(buffer, *n);
    if (pp::strip_echo(received, command).empty()) continue;
    if (!whole) {
      whole = deadline_in(rule.whole);
      ++replies_;
    }
    next = deadline_in(rule.idle);
  }
}

InstrumentError Pr650::unanswered(const std::string& command, const Reply& reply, const pp::ExchangeRule& rule) const {
  if (reply.end == ReplyEnd::cut)
    return {InstrumentError::Kind::protocol,
            fmt::format("the reply to '{}' stopped after {} bytes", printable(command), reply.bytes.size()), -1,
            reply.bytes};
  if (!connected_)
    return {InstrumentError::Kind::no_contact,
            fmt::format("no answer from a PR-650 on {} to '{}'", transport_->describe(), printable(command)),
            -1,
            {}};
  return {InstrumentError::Kind::lost,
          fmt::format("the PR-650 on {} did not answer '{}' within {}; is it still on and connected?",
                      transport_->describe(), printable(command), seconds(rule.first_byte)),
          -1,
          {}};
}

// After asking again for a reply that was missing or cut short, the first request may have
// been answered late, and then the meter answers the second one too: that reply is let pass
// (it starts within the meter's reply time, if at all) before the next command.
void Pr650::settle(const pp::ExchangeRule& rule) {
  char buffer[512];
  Deadline next = deadline_in(rule.first_byte);
  const Deadline limit = deadline_in(rule.first_byte + rule.whole);
  while (transport_->read(buffer, sizeof buffer, std::min(next, limit))) next = deadline_in(rule.idle);
}

// A command whose reply `parse` turns into a value or an error, with the rule's second try:
// a reply that is lost, cut short, garbled or refused is asked for once more, waiting longer.
template <typename Parse>
auto Pr650::ask(const std::string& command, const pp::ExchangeRule& rule, Parse parse)
    -> decltype(parse(std::string())) {
  InstrumentError failure{InstrumentError::Kind::protocol, "", -1, {}};
  bool maybe_late = false;  // a reply that did not come may still come, after the second request
  const int tries = rule.on_lost == pp::LostReply::ask_again ? 2 : 1;
  for (int attempt = 1; attempt <= tries; ++attempt) {
    auto reply = transact(command, attempt == 1 ? rule : pp::second_try(rule));
    if (!reply) return std::unexpected(reply.error());
    if (reply->end == ReplyEnd::complete) {
      // Bytes after the reply are damage, unless the meter may be answering twice.
      auto parsed = parse(maybe_late ? reply->bytes : reply->bytes + reply->surplus);
      if (parsed) {
        if (maybe_late) settle(rule);
        return parsed;
      }
      failure = parsed.error();
    } else {
      failure = unanswered(command, *reply, rule);
      maybe_late = true;
    }
  }
  if (tries > 1) failure.message += " (asked twice)";
  return std::unexpected(failure);
}

std::expected<void, InstrumentError> Pr650::connect() {
  std::lock_guard lock(call_mutex_);
  connected_ = false;
  cancelled_ = false;
  transport_->clear_interrupt();
  if (!transport_->is_open())
    if (auto opened = transport_->open(); !opened)
      return fail(InstrumentError::Kind::transport,
                  fmt::format("cannot open {}: {}", transport_->describe(), opened.error().message));
  // Drop and raise DTR/RTS, then let the meter settle, as its makers' software does.
  (void)transport_->set_modem_lines(false, false);
  std::this_thread::sleep_for(std::min<std::chrono::milliseconds>(options_.modem_settle, 100ms));
  (void)transport_->set_modem_lines(true, true);
  std::this_thread::sleep_for(options_.modem_settle);
  return make_contact(options_.contact_attempts, false);
}

std::expected<void, InstrumentError> Pr650::contact(int attempts, bool end_stray_line) {
  std::lock_guard lock(call_mutex_);
  connected_ = false;
  if (!transport_->is_open()) return fail(InstrumentError::Kind::transport, "the port is not open");
  return make_contact(attempts, end_stray_line);
}

std::expected<void, InstrumentError> Pr650::make_contact(int attempts, bool end_stray_line) {
  const std::string ping = pp::format_backlight(3, options_.style);
  const pp::ExchangeRule contact = rule({pp::CommandKind::contact});
  std::string noise;  // the last answer that was no PR-650's, for the caller to judge
  for (int attempt = 1; attempt <= attempts; ++attempt) {
    if (end_stray_line)
      if (auto ended = transport_->write(std::string(1, options_.style.terminator), deadline_in(contact.first_byte));
          !ended)
        return std::unexpected(link_error(ended.error(), ping));
    // Silence is the meter outside its power-on window, garbage the line at power-on: ask
    // again. Anything else (cancel, a failed link) ends the attempt.
    auto reply = transact(ping, contact);
    if (!reply) return std::unexpected(reply.error());
    if (reply->end == ReplyEnd::silent) continue;
    using identification::ContactAnswer;
    switch (reply->end == ReplyEnd::complete ? identification::classify_contact(reply->bytes) : ContactAnswer::other) {
      case ContactAnswer::pr650:
        connected_ = true;
        return {};
      case ContactAnswer::newer_meter:
        return fail(InstrumentError::Kind::identification,
                    fmt::format("a PR-6xx/7xx answered on {} ({} to '{}'), not a PR-650: use --model auto",
                                transport_->describe(), detail::quoted(reply->bytes), printable(ping)),
                    -1, reply->bytes);
      case ContactAnswer::other:
        noise = reply->bytes;
        break;
    }
  }
  return fail(InstrumentError::Kind::no_contact,
              fmt::format("no answer from a PR-650 on {} after {} attempts. The meter accepts remote control only "
                          "within about 5 s of being switched on: switch it off, switch it on, and connect at once "
                          "(and check that the cable's switch is at 'ctrlr')",
                          transport_->describe(), attempts),
              -1, noise);
}

std::expected<Identity, InstrumentError> Pr650::identify() {
  std::lock_guard lock(call_mutex_);
  cancelled_ = false;
  transport_->clear_interrupt();
  Identity identity;
  auto serial = ask(pp::format_report(110, options_.style), rule({pp::CommandKind::report, 110}),
                    [](const std::string& reply) -> std::expected<std::string, InstrumentError> {
                      auto parsed = pp::parse_serial_number(reply);
                      if (!parsed) return std::unexpected(garbled("serial number", parsed.error(), reply));
                      return *parsed;
                    });
  if (!serial) return std::unexpected(serial.error());
  identity.serial_number = serial_number_ = *serial;
  auto config = ask(pp::format_report(120, options_.style), rule({pp::CommandKind::report, 120}),
                    [](const std::string& reply) -> std::expected<pp::SpectralConfiguration, InstrumentError> {
                      auto parsed = pp::parse_spectral_configuration(reply);
                      if (!parsed) return std::unexpected(garbled("spectral configuration", parsed.error(), reply));
                      return *parsed;
                    });
  if (!config) return std::unexpected(config.error());
  identity.configuration = *config;
  identity.family = Family::pr650;
  identity.model = Model::pr650;
  identity.reported_model = "PR-650";
  identity.grid = Grid{static_cast<int>(config->first_nm), static_cast<int>(config->last_nm),
                       static_cast<int>(config->step_nm), config->points};
  return identity;
}

std::expected<void, InstrumentError> Pr650::check() {
  const std::string before = serial_number_;
  auto identity = identify();
  if (!identity) return std::unexpected(identity.error());
  if (!before.empty() && identity->serial_number != before)
    return std::unexpected(another_meter_answers(identity->serial_number, before));
  return {};
}

// A refusal is asked about again too: our setups are within the meter's ranges, so a refusal
// may be a damaged "00"; one given twice is the meter's.
std::expected<void, InstrumentError> Pr650::send_setup(const pp::Setup& setup) {
  auto accepted = ask(pp::format_setup(setup, options_.style), rule({pp::CommandKind::setup}),
                      [](const std::string& reply) -> std::expected<void, InstrumentError> {
                        auto code = pp::parse_setup_reply(reply);
                        if (!code) return std::unexpected(garbled("setup reply", code.error(), reply));
                        if (*code != 0)
                          return std::unexpected(InstrumentError{
                              InstrumentError::Kind::rejected,
                              "the PR-650 refused the setup: " + pp::setup_reply_message(*code), -1, reply});
                        return {};
                      });
  if (!accepted) return std::unexpected(accepted.error());
  return {};
}

// Automatic sync measures the light's flicker; a light it cannot lock to, or a reply that
// cannot be read even when asked again, is measured unsynced.
std::expected<pp::Setup::Sync, InstrumentError> Pr650::choose_sync(const MeasureOptions& options, double& hz) {
  if (options.sync == MeasureOptions::Sync::off) return pp::Setup::Sync::none;
  if (options.sync == MeasureOptions::Sync::frequency) {
    hz = options.sync_hz;
    return pp::Setup::Sync::frequency;
  }
  auto flicker = ask(pp::format_flicker(options_.style), rule({pp::CommandKind::flicker}),
                     [](const std::string& reply) -> std::expected<pp::FlickerReply, InstrumentError> {
                       auto parsed = pp::parse_flicker(reply);
                       if (!parsed) return std::unexpected(garbled("flicker reply", parsed.error(), reply));
                       return *parsed;
                     });
  if (!flicker) {
    if (flicker.error().kind == InstrumentError::Kind::protocol) return pp::Setup::Sync::none;
    return std::unexpected(flicker.error());
  }
  if (flicker->quality != 0) return pp::Setup::Sync::none;
  hz = flicker->frequency_hz;
  return pp::Setup::Sync::last_measured;
}

// M0 and the wait for the measurement to end. Any reply, even a damaged one, says the meter
// measured: the spectral report that follows carries the measurement and its quality code,
// which decides (the M0 status is "000" whatever the outcome on most meters). Silence may mean
// the command never arrived, and a report would then show the previous measurement as if it
// were new: so the meter measures once more, and the reading says so.
std::expected<void, InstrumentError> Pr650::start_measurement(const MeasureOptions& options, int integration_ms,
                                                              Reading& reading) {
  const std::string command = pp::format_measure(0, options_.style);
  const pp::ExchangeRule m0 = rule({pp::CommandKind::measure, 0, integration_ms, options.averages});
  for (int attempt = 1;; ++attempt) {
    reading.started = std::chrono::system_clock::now();
    auto status = transact(command, m0);
    if (!status) {
      // Cancelled, perhaps as M0 went out: the measurement may run on and end with a status line.
      if (status.error().kind == InstrumentError::Kind::cancelled)
        stray_.expect(deadline_in(m0.first_byte), deadline_in(m0.first_byte + m0.whole));
      return std::unexpected(status.error());
    }
    if (status->end != ReplyEnd::silent) break;
    auto silent = unanswered(command, *status, m0);
    if (attempt == 2) {
      silent.message += " (measured twice)";
      return std::unexpected(silent);
    }
    reading.warnings.push_back(
        fmt::format("remeasured: the PR-650 did not answer 'm0' within {}; it was told to "
                    "measure again, and this reading is of that measurement",
                    seconds(m0.first_byte)));
    ++reading.attempts;
  }
  reading.finished = std::chrono::system_clock::now();
  return {};
}

// Reports 1 and 2 of the measurement just made: luminance and x, y; X, Y, Z.
std::expected<void, InstrumentError> Pr650::read_colorimetry(const MeasureOptions& options, Reading& reading) {
  for (const int report : {1, 2}) {
    auto parsed =
        ask(pp::format_report(report, options_.style), rule({pp::CommandKind::report, report}),
            [report](const std::string& reply) -> std::expected<Parsed<pp::ColorimetricReport>, InstrumentError> {
              auto values = pp::parse_colorimetric(report, reply);
              if (!values) return std::unexpected(garbled(fmt::format("report {}", report), values.error(), reply));
              return Parsed<pp::ColorimetricReport>{std::move(*values), reply};
            });
    if (!parsed) return std::unexpected(parsed.error());
    const auto& values = parsed->value.values;
    reading.raw_reply += parsed->raw;
    if (report == 1) {
      reading.luminance = values[0];
      reading.x = values[1];
      reading.y = values[2];
      reading.luminance_units = photometric_units(parsed->value.units, options.si_units);
    } else {
      std::copy_n(values.begin(), 3, reading.xyz.begin());
    }
  }
  return {};
}

std::expected<Reading, InstrumentError> Pr650::measure_once(const MeasureOptions& options, int integration_ms) {
  double sync_hz = 0;
  auto sync = choose_sync(options, sync_hz);
  if (!sync) return std::unexpected(sync.error());
  pp::Setup setup;
  setup.sync = *sync;
  setup.sync_hz = sync_hz;
  setup.integration_ms = integration_ms;
  setup.averages = options.averages;
  setup.si_units = options.si_units;
  if (auto sent = send_setup(setup); !sent) return std::unexpected(sent.error());

  Reading reading;
  if (auto measured = start_measurement(options, integration_ms, reading); !measured)
    return std::unexpected(measured.error());

  // The meter keeps the last measurement, so a damaged report can simply be asked for again.
  auto spectrum = ask(pp::format_report(5, options_.style), rule({pp::CommandKind::report, 5}),
                      [](const std::string& reply) -> std::expected<Parsed<pp::SpectralReport>, InstrumentError> {
                        auto parsed = pp::parse_spectral(reply);
                        if (!parsed) return std::unexpected(garbled("spectral report", parsed.error(), reply));
                        return Parsed<pp::SpectralReport>{std::move(*parsed), reply};
                      });
  if (!spectrum) return std::unexpected(spectrum.error());
  pp::SpectralReport& report = spectrum->value;
  reading.raw_reply = spectrum->raw;
  // Past this point a non-zero code means the report's data lines may be those of an earlier
  // measurement (the meter does not update its buffer in low light): never hand them out.
  if (report.quality != 0)
    return fail(InstrumentError::Kind::bad_reading,
                fmt::format("quality {:02d}: {}", report.quality, pp::quality_message(report.quality)), report.quality,
                reading.raw_reply);
  if (auto colorimetry = read_colorimetry(options, reading); !colorimetry) return std::unexpected(colorimetry.error());

  reading.quality_code = report.quality;
  reading.quality = pp::quality_message(report.quality);
  reading.units_code = report.units;
  reading.units = spectral_units(report.units);
  reading.integration_ms = integration_ms;
  reading.averages = options.averages;
  reading.sync = describe_sync(*sync, sync_hz);
  reading.wavelength_nm = std::move(report.wavelength_nm);
  reading.radiance = std::move(report.values);
  reading.integrated = report.integrated;
  reading.serial_number = serial_number_;
  return reading;
}

std::expected<Reading, InstrumentError> Pr650::measure(const MeasureOptions& options) {
  std::lock_guard lock(call_mutex_);
  cancelled_ = false;
  transport_->clear_interrupt();
  // What only the newer meters offer, and values outside the PR-650's ranges, refused before a
  // byte is sent.
  const SettingLimits limits = setting_limits(Model::pr650);
  if (const auto setting = refused_setting(limits, options))
    return fail(InstrumentError::Kind::rejected, refusal_message(limits, options, *setting));
  if (!connected_) return fail(InstrumentError::Kind::lost, "not connected to the PR-650");

  MeasureOptions current = options;
  int integration = options.integration_ms;
  for (int attempt = 1;; ++attempt) {
    auto reading = measure_once(current, integration);
    if (reading) {
      reading->attempts += attempt - 1;  // the readings rejected before this one
      return reading;
    }
    const InstrumentError& error = reading.error();
    if (error.kind != InstrumentError::Kind::bad_reading || attempt >= kMaxAttempts) return reading;
    const int q = error.quality_code;
    if (pp::is_sync_failure(q) && current.sync != MeasureOptions::Sync::off) {
      current.sync = MeasureOptions::Sync::off;  // the light cannot be locked to: measure unsynced
    } else if (pp::is_low_light(q) && options.adjust_integration && integration > 0 &&
               integration < kMaxIntegrationMs) {
      integration = std::min(2 * integration, kMaxIntegrationMs);
    } else if (pp::is_overload(q) && options.adjust_integration && integration > kMinIntegrationMs) {
      integration = std::max(integration / 2, kMinIntegrationMs);
    } else {
      return reading;
    }
  }
}

// A setup, the flicker when syncing automatically, M0 and the three reports, each at its rule's
// longest: the first byte's wait and the whole reply.
std::chrono::milliseconds Pr650::reading_time(const MeasureOptions& options) const {
  using pr650::CommandKind;
  const auto longest = [this](const pr650::Command& command) {
    const pr650::ExchangeRule r = rule(command);
    return r.first_byte + r.whole;
  };
  auto total = longest({CommandKind::setup}) +
               longest({CommandKind::measure, 0, options.integration_ms, options.averages}) +
               longest({CommandKind::report, 5}) + 2 * longest({CommandKind::report, 1});
  if (options.sync == MeasureOptions::Sync::automatic) total += longest({CommandKind::flicker});
  return total;
}

}  // namespace skinspec::drivers
