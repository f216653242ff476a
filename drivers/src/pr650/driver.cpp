#include "skinspec/drivers/pr650.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <thread>

namespace skinspec::drivers {

namespace pp = pr650;
using namespace std::chrono_literals;

std::string_view to_string(InstrumentError::Kind kind) {
  switch (kind) {
    case InstrumentError::Kind::no_contact: return "no_contact";
    case InstrumentError::Kind::lost: return "lost";
    case InstrumentError::Kind::protocol: return "protocol";
    case InstrumentError::Kind::bad_reading: return "bad_reading";
    case InstrumentError::Kind::rejected: return "rejected";
    case InstrumentError::Kind::cancelled: return "cancelled";
    case InstrumentError::Kind::transport: return "transport";
  }
  return "unknown";
}

namespace {

constexpr int kMaxIntegrationMs = 6000, kMinIntegrationMs = 10;
constexpr int kMaxAttempts = 5;
// The longest reply: the spectral report with a two-line header.
constexpr std::size_t kSpectralReplyBytes = 1734;

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
    case 0: return "W/(sr m2 nm)";
    case 1: return "W/(m2 nm)";
    default: return "uncalibrated";
  }
}

std::string photometric_units(int code, bool si) {
  switch (code) {
    case 0: return si ? "cd/m2" : "fL";
    case 1: return si ? "lx" : "fc";
    default: return "uncalibrated";
  }
}

}  // namespace

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

std::chrono::milliseconds Pr650::transfer_time(std::size_t bytes) const {
  return std::chrono::milliseconds(static_cast<long>(1000.0 * static_cast<double>(bytes) / options_.line_bytes_per_second));
}

// A fixed integration time is spent twice per average (the dark reading comes on top);
// adaptive integration gets the allowance the meter's makers' software gives it.
std::chrono::milliseconds Pr650::measurement_timeout(int integration_ms, int averages) const {
  const auto per_average = integration_ms > 0 ? std::chrono::milliseconds(2L * integration_ms) : options_.adaptive_allowance;
  return per_average * averages + options_.measurement_overhead;
}

InstrumentError Pr650::link_error(const TransportError& error, const std::string& command) const {
  using K = TransportError::Kind;
  if (error.kind == K::interrupted || cancelled_) return {InstrumentError::Kind::cancelled, "cancelled", -1, {}};
  if (error.kind == K::timeout && !connected_)
    return {InstrumentError::Kind::no_contact,
            fmt::format("no answer from a PR-650 on {} to '{}'", transport_->describe(), printable(command)), -1, {}};
  if (error.kind == K::timeout)
    return {InstrumentError::Kind::lost,
            fmt::format("the PR-650 on {} did not answer '{}' in time; is it still on and connected?",
                        transport_->describe(), printable(command)), -1, {}};
  return {InstrumentError::Kind::lost,
          fmt::format("lost the PR-650 on {} during '{}': {}", transport_->describe(), printable(command), error.message),
          -1, {}};
}

// One command and its whole reply. Stale bytes are flushed first: a late reply to an earlier
// command would otherwise be taken for this one's.
std::expected<std::string, InstrumentError> Pr650::exchange(const std::string& command, pp::ReplyShape shape,
                                                            Deadline deadline) {
  if (cancelled_) return fail(InstrumentError::Kind::cancelled, "cancelled");
  if (auto flushed = transport_->flush_input(); !flushed) return std::unexpected(link_error(flushed.error(), command));
  if (auto written = transport_->write(command, deadline); !written)
    return std::unexpected(link_error(written.error(), command));
  std::string received;
  char buffer[512];
  while (!pp::reply_complete(shape, pp::strip_echo(received, command))) {
    auto n = transport_->read(buffer, sizeof buffer, deadline);
    if (!n) {
      if (n.error().kind == TransportError::Kind::timeout && !received.empty())
        return fail(InstrumentError::Kind::protocol,
                    fmt::format("the reply to '{}' stopped after {} bytes", printable(command), received.size()), -1,
                    received);
      return std::unexpected(link_error(n.error(), command));
    }
    received.append(buffer, *n);
  }
  return std::string(pp::strip_echo(received, command));
}

std::expected<void, InstrumentError> Pr650::connect() {
  std::lock_guard lock(call_mutex_);
  connected_ = false;
  cancelled_ = false;
  transport_->clear_interrupt();
  if (!transport_->is_open())
    if (auto opened = transport_->open(); !opened)
      return fail(InstrumentError::Kind::transport, fmt::format("cannot open {}: {}", transport_->describe(), opened.error().message));
  // Drop and raise DTR/RTS, then let the meter settle, as its makers' software does.
  (void)transport_->set_modem_lines(false, false);
  std::this_thread::sleep_for(std::min<std::chrono::milliseconds>(options_.modem_settle, 100ms));
  (void)transport_->set_modem_lines(true, true);
  std::this_thread::sleep_for(options_.modem_settle);

  const std::string ping = pp::format_backlight(3, options_.style);
  for (int attempt = 1; attempt <= options_.contact_attempts; ++attempt) {
    auto reply = exchange(ping, pp::ReplyShape::line, deadline_in(options_.contact_timeout));
    if (reply) {
      if (auto status = pp::parse_status(*reply); status && *status == 0) {
        connected_ = true;
        return {};
      }
      continue;  // garbage on the line at power-on: ask again
    }
    // Silence is the meter outside its power-on window: ask again. Anything else (cancel, a
    // failed link) ends the attempt.
    if (reply.error().kind != InstrumentError::Kind::no_contact) return std::unexpected(reply.error());
  }
  return fail(InstrumentError::Kind::no_contact,
              fmt::format("no answer from a PR-650 on {} after {} attempts. The meter accepts remote control only "
                          "within about 5 s of being switched on: switch it off, switch it on, and connect at once "
                          "(and check that the cable's switch is at 'ctrlr')",
                          transport_->describe(), options_.contact_attempts));
}

std::expected<Identity, InstrumentError> Pr650::identify() {
  std::lock_guard lock(call_mutex_);
  cancelled_ = false;
  transport_->clear_interrupt();
  Identity identity;
  auto serial = exchange(pp::format_report(110, options_.style), pp::ReplyShape::line, deadline_in(options_.reply_timeout));
  if (!serial) return std::unexpected(serial.error());
  auto parsed_serial = pp::parse_serial_number(*serial);
  if (!parsed_serial) return fail(InstrumentError::Kind::protocol, "serial number: " + parsed_serial.error().message, -1, *serial);
  identity.serial_number = serial_number_ = *parsed_serial;
  auto config = exchange(pp::format_report(120, options_.style), pp::ReplyShape::line, deadline_in(options_.reply_timeout));
  if (!config) return std::unexpected(config.error());
  auto parsed_config = pp::parse_spectral_configuration(*config);
  if (!parsed_config)
    return fail(InstrumentError::Kind::protocol, "spectral configuration: " + parsed_config.error().message, -1, *config);
  identity.configuration = *parsed_config;
  return identity;
}

std::expected<void, InstrumentError> Pr650::send_setup(const pp::Setup& setup) {
  auto reply = exchange(pp::format_setup(setup, options_.style), pp::ReplyShape::line, deadline_in(options_.reply_timeout));
  if (!reply) return std::unexpected(reply.error());
  auto code = pp::parse_setup_reply(*reply);
  if (!code) return fail(InstrumentError::Kind::protocol, "setup reply: " + code.error().message, -1, *reply);
  if (*code != 0) return fail(InstrumentError::Kind::rejected, "the PR-650 refused the setup: " + pp::setup_reply_message(*code));
  return {};
}

// Automatic sync measures the light's flicker; a light it cannot lock to is measured unsynced.
std::expected<pp::Setup::Sync, InstrumentError> Pr650::choose_sync(const MeasureOptions& options, double& hz) {
  if (options.sync == MeasureOptions::Sync::off) return pp::Setup::Sync::none;
  auto reply = exchange(pp::format_flicker(options_.style), pp::ReplyShape::line,
                        deadline_in(options_.reply_timeout + options_.measurement_overhead));
  if (!reply) return std::unexpected(reply.error());
  auto flicker = pp::parse_flicker(*reply);
  if (!flicker || flicker->quality != 0) return pp::Setup::Sync::none;
  hz = flicker->frequency_hz;
  return pp::Setup::Sync::last_measured;
}

// A measurement cancelled while the meter worked still ends with a status line; read it (or
// wait out the measurement) before the next command, or it would be taken for that reply.
std::expected<void, InstrumentError> Pr650::drain_pending_measurement() {
  if (!measurement_pending_) return {};
  char buffer[64];
  const Deadline deadline = deadline_in(measurement_timeout(0, 1));
  std::string received;
  while (!pp::reply_complete(pp::ReplyShape::line, received)) {
    auto n = transport_->read(buffer, sizeof buffer, deadline);
    if (!n) {
      if (n.error().kind == TransportError::Kind::timeout) break;
      return std::unexpected(link_error(n.error(), "m0"));
    }
    received.append(buffer, *n);
  }
  measurement_pending_ = false;
  return {};
}

std::expected<pp::SpectralReport, InstrumentError> Pr650::read_spectrum(std::string& raw) {
  // The meter keeps the last measurement, so a garbled report can simply be asked for again.
  InstrumentError last{InstrumentError::Kind::protocol, "", -1, {}};
  for (int attempt = 0; attempt < 2; ++attempt) {
    auto reply = exchange(pp::format_report(5, options_.style), pp::ReplyShape::spectral,
                          deadline_in(options_.reply_timeout + 2 * transfer_time(kSpectralReplyBytes)));
    if (!reply) {
      if (reply.error().kind != InstrumentError::Kind::protocol) return std::unexpected(reply.error());
      last = reply.error();
      continue;
    }
    auto report = pp::parse_spectral(*reply);
    if (report) {
      raw += *reply;
      return *report;
    }
    last = {InstrumentError::Kind::protocol, "spectral report: " + report.error().message, -1, *reply};
  }
  return std::unexpected(last);
}

std::expected<Reading, InstrumentError> Pr650::measure_once(const MeasureOptions& options, int integration_ms) {
  double sync_hz = 0;
  auto sync = choose_sync(options, sync_hz);
  if (!sync) return std::unexpected(sync.error());
  pp::Setup setup;
  setup.sync = *sync;
  setup.integration_ms = integration_ms;
  setup.averages = options.averages;
  setup.si_units = options.si_units;
  if (auto sent = send_setup(setup); !sent) return std::unexpected(sent.error());

  Reading reading;
  reading.started = std::chrono::system_clock::now();
  auto status = exchange(pp::format_measure(0, options_.style), pp::ReplyShape::line,
                         deadline_in(measurement_timeout(integration_ms, options.averages)));
  if (!status) {
    if (status.error().kind == InstrumentError::Kind::cancelled) measurement_pending_ = true;
    return std::unexpected(status.error());
  }
  auto code = pp::parse_status(*status);
  if (!code) return fail(InstrumentError::Kind::protocol, "measurement status: " + code.error().message, -1, *status);
  if (*code != 0)
    return fail(InstrumentError::Kind::bad_reading, fmt::format("measurement failed: {}", pp::quality_message(*code)), *code, *status);
  reading.finished = std::chrono::system_clock::now();

  auto spectrum = read_spectrum(reading.raw_reply);
  if (!spectrum) return std::unexpected(spectrum.error());
  // Past this point a non-zero code means the report's data lines may be those of an earlier
  // measurement (the meter does not update its buffer in low light): never hand them out.
  if (spectrum->quality != 0)
    return fail(InstrumentError::Kind::bad_reading,
                fmt::format("quality {:02d}: {}", spectrum->quality, pp::quality_message(spectrum->quality)),
                spectrum->quality, reading.raw_reply);

  for (const int report : {1, 2}) {
    auto reply = exchange(pp::format_report(report, options_.style), pp::ReplyShape::line, deadline_in(options_.reply_timeout));
    if (!reply) return std::unexpected(reply.error());
    auto parsed = pp::parse_colorimetric(report, *reply);
    if (!parsed) return fail(InstrumentError::Kind::protocol, fmt::format("report {}: {}", report, parsed.error().message), -1, *reply);
    reading.raw_reply += *reply;
    if (report == 1) {
      reading.luminance = parsed->values[0];
      reading.x = parsed->values[1];
      reading.y = parsed->values[2];
      reading.luminance_units = photometric_units(parsed->units, options.si_units);
    } else {
      std::copy_n(parsed->values.begin(), 3, reading.xyz.begin());
    }
  }

  reading.quality_code = spectrum->quality;
  reading.quality = pp::quality_message(spectrum->quality);
  reading.units_code = spectrum->units;
  reading.units = spectral_units(spectrum->units);
  reading.integration_ms = integration_ms;
  reading.averages = options.averages;
  reading.sync = *sync == pp::Setup::Sync::none ? "off" : fmt::format("last measured frequency ({:.2f} Hz)", sync_hz);
  reading.wavelength_nm = std::move(spectrum->wavelength_nm);
  reading.radiance = std::move(spectrum->values);
  reading.integrated = spectrum->integrated;
  reading.serial_number = serial_number_;
  return reading;
}

std::expected<Reading, InstrumentError> Pr650::measure(const MeasureOptions& options) {
  std::lock_guard lock(call_mutex_);
  cancelled_ = false;
  transport_->clear_interrupt();
  if (options.integration_ms != 0 && (options.integration_ms < kMinIntegrationMs || options.integration_ms > kMaxIntegrationMs))
    return fail(InstrumentError::Kind::rejected, fmt::format("integration time {} ms is outside 10-6000 ms", options.integration_ms));
  if (options.averages < 1 || options.averages > 99)
    return fail(InstrumentError::Kind::rejected, fmt::format("{} averages is outside 1-99", options.averages));
  if (!connected_) return fail(InstrumentError::Kind::lost, "not connected to the PR-650");
  if (auto drained = drain_pending_measurement(); !drained) return std::unexpected(drained.error());

  MeasureOptions current = options;
  int integration = options.integration_ms;
  for (int attempt = 1;; ++attempt) {
    auto reading = measure_once(current, integration);
    if (reading) {
      reading->attempts = attempt;
      return reading;
    }
    const InstrumentError& error = reading.error();
    if (error.kind != InstrumentError::Kind::bad_reading || attempt >= kMaxAttempts) return reading;
    const int q = error.quality_code;
    if (pp::is_sync_failure(q) && current.sync != MeasureOptions::Sync::off) {
      current.sync = MeasureOptions::Sync::off;  // the light cannot be locked to: measure unsynced
    } else if (pp::is_low_light(q) && options.adjust_integration && integration > 0 && integration < kMaxIntegrationMs) {
      integration = std::min(2 * integration, kMaxIntegrationMs);
    } else if (pp::is_overload(q) && options.adjust_integration && integration > kMinIntegrationMs) {
      integration = std::max(integration / 2, kMinIntegrationMs);
    } else {
      return reading;
    }
  }
}

}  // namespace skinspec::drivers
