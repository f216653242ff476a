#include "skinspec/drivers/remote_meter.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <stdexcept>
#include <variant>

#include "common/remote_failures.hpp"
#include "common/remote_session.hpp"

namespace skinspec::drivers {

namespace p6 = pr6xx;
using namespace std::chrono_literals;
using remote::Rule;

namespace {

constexpr int kMaxAttempts = 5;  // measurements per reading, as for the PR-650

std::unexpected<InstrumentError> fail(InstrumentError::Kind kind, std::string message, int code = -1,
                                      std::string raw = {}) {
  return std::unexpected(InstrumentError{kind, std::move(message), code, std::move(raw)});
}

// The manuals disagree on the units field of the reports (0-3 by quantity, or 11-14/111-114;
// the simulator prints 1 for SI), so the units are those the driver set up: radiance, since
// skinspec measures through the telescope, in SI or in the meter's English units.
std::string photometric_units(bool si) { return si ? "cd/m2" : "fL"; }
constexpr std::string_view kSpectralUnits = "W/(sr m2 nm)";

}  // namespace

RemoteMeter::RemoteMeter(Family family, Model model, std::unique_ptr<Transport> transport, RemoteOptions options)
    : transport_(std::move(transport)), profile_(drivers::profile(model)), options_(options) {
  if (profile_.family != family)
    throw std::invalid_argument(fmt::format("{} is a meter of family {}, not {}", profile_.name,
                                            to_string(profile_.family), to_string(family)));
  session_ = std::make_unique<remote::Session>(*transport_, profile_.name, options_.pacing.value_or(profile_.pacing),
                                               options_.timing, options_.style);
}

RemoteMeter::~RemoteMeter() { disconnect(); }

void RemoteMeter::cancel() { session_->cancel(); }

std::uint64_t RemoteMeter::replies_received() const { return session_->replies(); }

void RemoteMeter::disconnect() {
  std::lock_guard lock(call_mutex_);
  session_->quit();
  if (transport_->is_open()) transport_->close();
  connected_ = false;
}

bool RemoteMeter::link_closed() {
  std::unique_lock lock(call_mutex_, std::try_to_lock);
  if (!lock) return false;
  return !transport_->is_open() || transport_->peer_closed();
}

void RemoteMeter::forget_connection() {
  connected_ = false;
  identified_ = false;
  units_.reset(), exposure_.reset(), averages_.reset(), sync_mode_.reset(), sync_frequency_.reset();
  sensitivity_.reset(), aperture_.reset(), apertures_.reset();
  session_->reset_cancel();
  connect_warnings_.clear();
  dialect_ = {};
  std::lock_guard lock(warnings_mutex_);
  firmware_warnings_.clear();
}

std::vector<std::string> RemoteMeter::firmware_warnings() const {
  std::lock_guard lock(warnings_mutex_);
  return firmware_warnings_;
}

void RemoteMeter::note_firmware(std::string warning) {
  std::lock_guard lock(warnings_mutex_);
  if (std::ranges::find(firmware_warnings_, warning) == firmware_warnings_.end())
    firmware_warnings_.push_back(std::move(warning));
}

void RemoteMeter::stop_triggering(std::string_view command) {
  dialect_.trigger = false;
  note_firmware(fmt::format(
      "m5-fallback: the {} does not know '{}' ({}), as the firmware of the 2009 PR-730/735 manual does not: it "
      "measures with M5 on this connection, and a cancelled measurement runs on in the meter (its reading is "
      "discarded)",
      profile_.name, remote::printable(command), p6::error_message(p6::kIllegalCommand)));
}

void RemoteMeter::without_last_error() {
  dialect_.last_error = false;
  note_firmware(
      fmt::format("no-last-error: the {} does not know 'V' ({}); a measurement's outcome is read from "
                  "its spectral report's status",
                  profile_.name, p6::error_message(p6::kIllegalCommand)));
}

// Each reply at its deadline, a command of up to eight bytes paced before each: the setups (at
// most seven), T and V or nothing, the measurement with its spectral report, D1, D2 and D13.
std::chrono::milliseconds RemoteMeter::reading_time(const MeasureOptions& options) const {
  const auto pacing = options_.pacing.value_or(profile_.pacing);
  const int points = identity_.grid.points > 0 ? identity_.grid.points : profile_.simulator_grid->points;
  const auto exchange = 8 * pacing + options_.timing.reply + whole_reply(0);
  auto total = 12 * exchange + measurement_time(options.integration_ms, options.averages) + options_.timing.reply +
               whole_reply(points);
  if (options.sync == MeasureOptions::Sync::automatic) total += options_.timing.flicker;
  return total;
}

std::expected<void, InstrumentError> RemoteMeter::connect() {
  std::lock_guard lock(call_mutex_);
  forget_connection();
  if (auto opened = session_->open(options_.modem_settle); !opened) return opened;
  auto glued = session_->enter_remote();
  if (!glued) return std::unexpected(glued.error());
  if (auto reported = ask_model(); !reported) {
    session_->quit();  // the meter's screen would stay locked
    return std::unexpected(reported.error());
  }
  note_entry(*glued);
  return {};
}

void RemoteMeter::adopt_remote_mode(bool banner_glued) {
  std::lock_guard lock(call_mutex_);
  forget_connection();
  session_->assume_remote();
  note_entry(banner_glued);
}

void RemoteMeter::note_entry(bool banner_glued) {
  if (banner_glued)
    connect_warnings_.push_back("banner-glued: the meter sent ' REMOTE MODE' only in front of its next reply");
  connected_ = true;
}

// D111 against the profile: another model skinspec knows is an identification error; a model
// it does not know, or no answer, is measured as the profile says, with a warning.
std::expected<RemoteMeter::ReportedModel, InstrumentError> RemoteMeter::ask_model() {
  const Rule rule{p6::ReplyShape::line, 0, options_.timing.reply, options_.timing.idle, whole_reply(0), true};
  auto report = session_->ask(p6::format_report(111, options_.style), rule, "model name", p6::parse_text_report);
  if (!report && report.error().kind != InstrumentError::Kind::protocol &&
      report.error().kind != InstrumentError::Kind::lost)
    return std::unexpected(report.error());
  if (!report || report->status.code != 0)
    return ReportedModel{
        {},
        profile_.model,
        fmt::format("no-model: the meter did not report its model ({}); measured as a {} because --model says so",
                    report ? p6::error_message(report->status.code) : report.error().message, profile_.name)};
  const ModelMatch match = match_reported_model(report->text);
  if (match.candidates.empty())
    return ReportedModel{report->text, std::nullopt,
                         fmt::format("unknown-model: the meter reports '{}', which skinspec does not know; measured "
                                     "as a {} because --model says so",
                                     report->text, profile_.name)};
  if (std::ranges::find(match.candidates, profile_.model) == match.candidates.end())
    return fail(InstrumentError::Kind::identification,
                fmt::format("--model {} asks for a {}, but the meter says it is a '{}'; use --model auto or the "
                            "model it reports",
                            profile_.id, profile_.name, report->text));
  return ReportedModel{report->text, profile_.model, {}};
}

std::chrono::milliseconds RemoteMeter::whole_reply(int points) const {
  return remote::whole_reply(options_.timing, points);
}

std::chrono::milliseconds RemoteMeter::measurement_time(int exposure_ms, int cycles) const {
  const int longest =
      profile_.exposure.max_extended_ms > 0 ? profile_.exposure.max_extended_ms : profile_.exposure.max_ms;
  const int per_exposure = exposure_ms > 0 ? exposure_ms : longest;
  return std::chrono::milliseconds(static_cast<long>(cycles) * 2 * per_exposure) + options_.timing.measurement_overhead;
}

std::expected<Identity, InstrumentError> RemoteMeter::identify() {
  std::lock_guard lock(call_mutex_);
  session_->reset_cancel();
  return query_identity();
}

std::expected<void, InstrumentError> RemoteMeter::check() {
  std::lock_guard lock(call_mutex_);
  session_->reset_cancel();
  if (!identified_) {
    if (auto identity = query_identity(); !identity) return std::unexpected(identity.error());
    return {};
  }
  const Rule rule{p6::ReplyShape::line, 0, options_.timing.reply, options_.timing.idle, whole_reply(0), true};
  auto report = session_->ask(p6::format_report(110, options_.style), rule, "serial number", p6::parse_text_report);
  if (!report) return std::unexpected(report.error());
  if (report->status.code != 0)
    return fail(InstrumentError::Kind::protocol, fmt::format("serial number: the {} answered {}", profile_.name,
                                                             p6::error_message(report->status.code)));
  if (report->text != identity_.serial_number)
    return std::unexpected(another_meter_answers(report->text, identity_.serial_number));
  return {};
}

// D111, D110, D114, D120. D120's grid is the one every spectrum must lie on; the profile's grid
// only says which answers are documented.
std::expected<Identity, InstrumentError> RemoteMeter::query_identity() {
  const Rule rule{p6::ReplyShape::line, 0, options_.timing.reply, options_.timing.idle, whole_reply(0), true};
  Identity identity;
  identity.warnings = connect_warnings_;
  identity.family = profile_.family;
  auto text = [&](int code, std::string_view what) -> std::expected<std::string, InstrumentError> {
    auto report = session_->ask(p6::format_report(code, options_.style), rule, what, p6::parse_text_report);
    if (!report) return std::unexpected(report.error());
    if (report->status.code != 0)
      return fail(InstrumentError::Kind::protocol,
                  fmt::format("{}: the {} answered {}", what, profile_.name, p6::error_message(report->status.code)));
    return report->text;
  };
  auto reported = ask_model();
  if (!reported) return std::unexpected(reported.error());
  identity.reported_model = reported->text;
  identity.model = reported->model;
  if (reported->warning) identity.warnings.push_back(*reported->warning);
  auto serial = text(110, "serial number");
  if (!serial) return std::unexpected(serial.error());
  identity.serial_number = *serial;
  auto firmware = text(114, "firmware version");
  if (!firmware) return std::unexpected(firmware.error());
  identity.firmware = *firmware;
  auto configuration = session_->ask(p6::format_report(120, options_.style), rule, "hardware configuration",
                                     p6::parse_hardware_configuration);
  if (!configuration) return std::unexpected(configuration.error());
  if (configuration->status.code != 0 && !profile_.grid)
    return fail(InstrumentError::Kind::protocol,
                fmt::format("hardware configuration: the {} answered {}", profile_.name,
                            p6::error_message(configuration->status.code)));
  if (configuration->status.code != 0) {
    // A firmware without D120 measures on the model's documented grid, which every spectrum
    // is still checked against.
    configuration->grid = *profile_.grid;
    note_firmware(
        fmt::format("d120: the {} answered D120 with {}; its spectra are taken on the {}'s documented "
                    "grid, {}-{} nm by {} nm",
                    profile_.name, p6::error_message(configuration->status.code), profile_.name,
                    profile_.grid->first_nm, profile_.grid->last_nm, profile_.grid->step_nm));
  }
  identity.grid = configuration->grid;
  identity.configuration = {
      configuration->grid.points, configuration->bandwidth_nm, static_cast<double>(configuration->grid.first_nm),
      static_cast<double>(configuration->grid.last_nm), static_cast<double>(configuration->grid.step_nm)};
  const auto learned = firmware_warnings();
  identity.warnings.insert(identity.warnings.end(), learned.begin(), learned.end());
  identity_ = identity;
  identified_ = true;
  return identity;
}

// M5 measures and answers with the spectrum. A measurement that never answered is made once
// more; one whose reply came damaged did measure, so D5 reads the same measurement again.
std::expected<RemoteMeter::Spectrum, InstrumentError> RemoteMeter::measure_with_m5(int exposure_ms, int cycles) {
  const auto limit = measurement_time(exposure_ms, cycles);
  const std::string command = p6::format_measure(5, options_.style);
  bool remeasured = false;
  for (int attempt = 1; attempt <= 2; ++attempt) {
    const Rule rule{p6::ReplyShape::spectral,   grid().points, limit, options_.timing.idle,
                    whole_reply(grid().points), false};
    auto reply = session_->transact(command, rule);
    // There is no abort: a cancelled measurement runs on, and the session drops its reply.
    if (!reply) return std::unexpected(reply.error());
    if (reply->end == remote::ReplyEnd::silent) {
      remeasured = true;
      continue;
    }
    if (reply->end == remote::ReplyEnd::complete)
      if (auto report = p6::parse_spectral(reply->bytes, grid()); report)
        return Spectrum{std::move(*report), reply->bytes, remeasured};
    auto again = read_spectrum(p6::format_report(5, options_.style), options_.timing.reply, true);
    if (again) again->remeasured = remeasured;
    return again;
  }
  return std::unexpected(session_->unanswered(command, {}));
}

void RemoteMeter::measurement_pending(std::chrono::milliseconds limit) {
  session_->expect_stray_reply(
      {p6::ReplyShape::spectral, grid().points, limit, options_.timing.idle, whole_reply(grid().points), false});
}

std::expected<RemoteMeter::Spectrum, InstrumentError> RemoteMeter::read_spectrum(std::string_view command,
                                                                                 std::chrono::milliseconds first_byte,
                                                                                 bool ask_again) {
  const Rule rule{p6::ReplyShape::spectral,   grid().points, first_byte, options_.timing.idle,
                  whole_reply(grid().points), ask_again};
  Spectrum spectrum;
  const Grid expected = grid();
  auto report = session_->ask(command, rule, "spectral report", [&](std::string_view bytes) {
    spectrum.raw = std::string(bytes);
    return p6::parse_spectral(bytes, expected);
  });
  if (!report) return std::unexpected(report.error());
  spectrum.report = std::move(*report);
  return spectrum;
}

std::expected<void, InstrumentError> RemoteMeter::read_colorimetry(Reading& reading, bool si_units) {
  const Rule rule{p6::ReplyShape::line, 0, options_.timing.reply, options_.timing.idle, whole_reply(0), true};
  for (const int code : {1, 2}) {
    std::string raw;
    auto report = session_->ask(p6::format_report(code, options_.style), rule, fmt::format("report {}", code),
                                [&](std::string_view bytes) {
                                  raw = std::string(bytes);
                                  return p6::parse_colorimetric(code, bytes);
                                });
    if (!report) return std::unexpected(report.error());
    if (report->status.code != 0 || report->values.size() < 3)
      return fail(InstrumentError::Kind::protocol,
                  fmt::format("report {} after a good measurement: {}", code, p6::error_message(report->status.code)),
                  -1, raw);
    reading.raw_reply += raw;
    if (code == 1) {
      reading.luminance = report->values[0], reading.x = report->values[1], reading.y = report->values[2];
      reading.luminance_units = photometric_units(si_units);
    } else {
      reading.xyz = {report->values[0], report->values[1], report->values[2]};
    }
  }
  return {};
}

// A meter that does not know D13 (illegal command) is not asked again on this connection, and
// says so once; any other refusal leaves this reading's exposure unknown.
std::expected<std::optional<int>, InstrumentError> RemoteMeter::exposure_used() {
  if (!dialect_.exposure_report) return std::nullopt;
  const Rule rule{p6::ReplyShape::line, 0, options_.timing.reply, options_.timing.idle, whole_reply(0), true};
  const std::string command = p6::format_report(13, options_.style);
  auto report = session_->ask(command, rule, "exposure report", p6::parse_exposure_report);
  if (!report) return std::unexpected(report.error());
  if (report->status.code == 0) return report->exposure_ms;
  if (report->status.code == p6::kIllegalCommand) {
    dialect_.exposure_report = false;
    note_firmware(fmt::format(
        "no-exposure-report: the {} does not know '{}' ({}); the exposure an adaptive measurement chose is not known",
        profile_.name, remote::printable(command), p6::error_message(p6::kIllegalCommand)));
  }
  return std::nullopt;
}

// Measures until the meter gives a good spectrum or the error policy (remote_failures.hpp)
// gives up. A failed measurement's spectrum is never used: the next attempt or the error.
std::expected<Reading, InstrumentError> RemoteMeter::measure(const MeasureOptions& options) {
  std::lock_guard lock(call_mutex_);
  session_->reset_cancel();
  if (!connected_) return fail(InstrumentError::Kind::lost, fmt::format("the {} is not connected", profile_.name));
  if (auto ok = check(options); !ok) return std::unexpected(ok.error());
  if (!identified_)
    if (auto identity = query_identity(); !identity) return std::unexpected(identity.error());
  const std::size_t warned = firmware_warnings().size();
  Reading reading;
  reading.started = std::chrono::system_clock::now();
  reading.integration_ms = options.integration_ms;
  reading.averages = options.averages;
  reading.serial_number = identity_.serial_number;
  remote::AttemptState state{options.integration_ms, options.sync != MeasureOptions::Sync::off,
                             options.adjust_integration, longest_exposure_ms(options)};
  int measurements = 0;
  for (int attempt = 1; attempt <= kMaxAttempts; ++attempt) {
    auto sync = configure(options, state.exposure_ms, state.sync_on);
    if (!sync) return std::unexpected(sync.error());
    auto spectrum = take_spectrum(state.exposure_ms, options.averages);
    if (!spectrum) return std::unexpected(spectrum.error());
    measurements += spectrum->remeasured ? 2 : 1;
    reading.attempts = measurements;
    if (spectrum->remeasured) reading.warnings.push_back("remeasured: a measurement never answered and was made again");
    const p6::SpectralReport& report = spectrum->report;
    if (report.status.code != 0) {
      auto next = remote::after_failure(report.status.code, state, profile_, spectrum->raw);
      if (auto* error = std::get_if<InstrumentError>(&next)) return std::unexpected(std::move(*error));
      reading.warnings.push_back(std::get<remote::MeasureAgain>(next).warning);
      continue;
    }
    if (std::ranges::all_of(report.values, [](double v) { return v == 0; }))
      return fail(InstrumentError::Kind::bad_reading, "the meter returned a spectrum of zeros", 0, spectrum->raw);
    reading.quality = "OK";
    reading.sync = *sync;
    reading.integration_ms = state.exposure_ms;
    reading.units_code = report.units;
    reading.units = kSpectralUnits;
    reading.wavelength_nm.assign(report.wavelength_nm.begin(), report.wavelength_nm.end());
    reading.radiance = report.values;
    reading.integrated = report.integrated;
    reading.raw_reply = spectrum->raw;
    if (auto ok = read_colorimetry(reading, options.si_units); !ok) return std::unexpected(ok.error());
    if (!dialect_.units) reading.luminance_units = "as set on the meter";
    if (state.exposure_ms == 0) {
      auto used = exposure_used();
      if (!used) return std::unexpected(used.error());
      reading.exposure_used_ms = *used;
    }
    // What this reading found the firmware to lack goes with it, once.
    const auto learned = firmware_warnings();
    reading.warnings.insert(reading.warnings.end(), learned.begin() + static_cast<std::ptrdiff_t>(warned),
                            learned.end());
    reading.finished = std::chrono::system_clock::now();
    return reading;
  }
  return fail(InstrumentError::Kind::bad_reading,
              fmt::format("no good measurement in {} attempts: {}", kMaxAttempts, fmt::join(reading.warnings, "; ")));
}

}  // namespace skinspec::drivers
