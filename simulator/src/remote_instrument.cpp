// The synthetic PR-655/670/680 and PR-7xx: its setup, its measurement buffer and what each
// command does to them. Every difference between models is read from the model's MeterProfile
// (grid, exposure range, capabilities, how replies look), none is a branch on the model.

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <optional>
#include <random>

#include "remote_setup.hpp"
#include "responder.hpp"
#include "skinspec/drivers/pr6xx_protocol.hpp"
#include "skinspec/drivers/pr7xx_protocol.hpp"

namespace skinspec::simulator::detail {

namespace {

namespace p6 = drivers::pr6xx;
namespace p7 = drivers::pr7xx;
using drivers::Clock;
using drivers::MeterProfile;

constexpr std::string_view kFirmware = "2.22D";  // D114 of every newer model in the manuals
constexpr int kNoData = -2000;
constexpr int kWeakLight = -8, kOverload = -2, kCannotSync = -3, kCannotAutoSync = -10;
constexpr int kBusy = 1;
constexpr int kDataStatusDigits = 5;
// D120's fields after the grid in every manual's example: bandwidth, pixels, first and last pixel.
constexpr double kBandwidthNm = 0;
constexpr int kPixels = 256, kFirstPixel = 7, kLastPixel = 247;
constexpr drivers::Grid kManualD120Grid{380, 780, 2, 201};
constexpr double kPlanckTimesLight = 1.98644586e-25;  // h c, J m

// The generation asked for, or the model's newest (the options were checked when parsed).
const drivers::Firmware& firmware_of(const MeterProfile& profile, const std::string& id) {
  const drivers::Firmware* found = drivers::find_firmware(profile, id);
  return found ? *found : profile.firmware.front();
}

p6::ReplyStyle style_of(const MeterProfile& profile, const WireOverrides& wire) {
  p6::ReplyStyle style = p6::reply_style(profile.wire);
  if (wire.banner) style.banner = *wire.banner;
  if (wire.status_digits) style.data_status_digits = *wire.status_digits;
  if (wire.padded_errors) style.padded_errors = *wire.padded_errors;
  if (wire.exponent_digits) style.data_exponent_digits = *wire.exponent_digits;
  return style;
}

// What a measurement leaves in the meter.
struct MeasurementBuffer {
  bool measured = false;
  int status = 0;  // 0, or the meter's negative code: then there are no data
  std::vector<double> values;
  bool si_units = false;
  int exposure_ms = 0;  // as used: the adaptive exposure chosen, for D13
};

// D13's label before the exposure: the manuals' example prints "Fast" (the speed SG sets,
// which skinspec never changes).
constexpr std::string_view kGainLabel = "Fast";

// An error fault's code, taken off the faults: a setup or a report refused with it, as a
// firmware that lacks the command would.
std::optional<int> take_refusal(std::vector<Fault>& faults) {
  const auto refusal = std::ranges::find(faults, FaultKind::error, &Fault::kind);
  std::optional<int> code;
  if (refusal != faults.end()) code = static_cast<int>(refusal->amount);
  std::erase_if(faults, [](const Fault& f) { return f.kind == FaultKind::error; });
  return code;
}

// A measurement and how long it takes, before it lands in the buffer.
struct Measurement {
  MeasurementBuffer result;
  double duration_ms = 0;  // at time scale 1
  std::string note;
};

class RemoteInstrument final : public Responder {
 public:
  RemoteInstrument(Synthesis synthesis, const MeterOptions& options)
      : profile_(drivers::profile(options.model)),
        grid_(*profile_.simulator_grid),
        nm_(wavelengths(grid_)),
        observer_(std::move(synthesis.observer)),
        scenes_(std::move(synthesis.scenes)),
        options_(options),
        firmware_(firmware_of(profile_, options.firmware)),
        style_(style_of(profile_, options.wire)),
        rng_(options.seed) {
    if (scenes_.empty()) scenes_.push_back({"darkness", std::vector<double>(nm_.size(), 0.0), 0});
    power_cycle();
  }

  Outcome respond(const Command& command, std::vector<Fault>& faults) override;
  void power_cycle() override {
    setup_ = RemoteSetup{};
    buffer_ = MeasurementBuffer{};
    pending_.reset();
    echo_ = false;
  }
  std::size_t measurements() const override { return measurements_; }

 private:
  Outcome measure(int code, std::vector<Fault>& faults);
  Outcome trigger(std::vector<Fault>& faults);
  std::string poll(std::vector<Fault>& faults);
  std::string abort();
  Measurement take_measurement(std::vector<Fault>& faults);
  int light_status(const Scene& scene, double level) const;
  std::optional<std::string> report(int code) const;
  std::string spectral_report() const;
  std::string colorimetric_report(int code) const;
  std::string flicker() const;
  bool measuring() const { return pending_.has_value(); }
  Reply quick(std::string bytes) const {
    Reply reply;
    reply.bytes = std::move(bytes);
    reply.delay_ms = options_.sensor.reply_ms;
    return reply;
  }
  Outcome answer(std::string bytes) const { return {quick(std::move(bytes)), {}, {}}; }

  const MeterProfile& profile_;
  drivers::Grid grid_;
  std::vector<double> nm_;
  Observer observer_;
  std::vector<Scene> scenes_;
  std::size_t scene_ = 0;  // the scene under the meter: advances after a measurement that succeeds
  const MeterOptions& options_;
  const drivers::Firmware& firmware_;
  p6::ReplyStyle style_;
  std::mt19937_64 rng_;
  RemoteSetup setup_;
  MeasurementBuffer buffer_;
  struct Pending {  // a PR-7xx measurement started by T
    Measurement measurement;
    Clock::time_point done_at;
    int busy_polls = 0;  // "0001" answers still owed by a busy fault
    bool busy_added = false;
  };
  std::optional<Pending> pending_;
  bool echo_ = false;
  std::size_t measurements_ = 0;
};

Outcome RemoteInstrument::respond(const Command& command, std::vector<Fault>& faults) {
  // Quality codes are the PR-650's; the newer meters fail with `error` instead.
  std::erase_if(faults, [](const Fault& f) { return f.kind == FaultKind::quality || f.kind == FaultKind::stale; });
  const std::string_view parameters = command.parameters();
  if (command.key == "photo") return answer(p6::format_banner(style_));
  if (command.key == "q") return {};
  const bool pr7xx = firmware_.trigger_poll_abort;
  switch (command.letter) {
    case 'D':
      if (const auto refusal = take_refusal(faults)) {
        Outcome out = answer(p6::format_error(*refusal, style_));
        out.notes.push_back(fmt::format("report '{}' refused: {}", command.text, p6::error_message(*refusal)));
        return out;
      }
      if (const auto code = whole_number(parameters, 4)) {
        if (auto bytes = report(*code)) return answer(std::move(*bytes));
      }
      return answer(p6::format_error(kNoData, style_));
    case 'M':
      if (const auto code = whole_number(parameters, 4); code && *code <= 6) return measure(*code, faults);
      break;
    case 'S': {
      if (measuring()) return answer(p6::format_setup_status(kBusy, style_));
      const auto refusal = take_refusal(faults);
      const int status = refusal ? *refusal : apply_remote_setup(command.text, profile_, firmware_, setup_);
      Outcome out = answer(p6::format_setup_status(status, style_));
      if (status != 0)
        out.notes.push_back(fmt::format("setup '{}' refused: {}", command.text, p6::error_message(status)));
      return out;
    }
    case 'F':
      if (parameters.empty()) {
        Outcome out = answer(flicker());
        out.reply->delay_ms = options_.sensor.flicker_ms;
        return out;
      }
      break;
    case 'I':
      return answer(p6::format_setup_status(0, style_));
    case 'B':
      if (const auto level = whole_number(parameters, 4); level && *level <= 100)
        return answer(fmt::format("Backlight set to {} %\r\n", *level));
      break;
    case 'E':
      if (parameters.empty()) {
        echo_ = !echo_;
        Reply reply;
        reply.echo = echo_;
        return {reply, {echo_ ? "echo on" : "echo off"}, {}};
      }
      break;
    case 'T':
      if (pr7xx && parameters.empty()) return trigger(faults);
      break;
    case 'P':
      if (pr7xx && parameters.empty()) return answer(poll(faults));
      break;
    case 'A':
      if (pr7xx && parameters.empty()) return answer(abort());
      break;
    case 'V':
      if (pr7xx && parameters.empty()) return answer(p6::format_error(buffer_.measured ? buffer_.status : 0, style_));
      break;
    default:
      break;
  }
  Outcome out = answer(p6::format_error(kIllegalCommand, style_));
  out.problems.push_back(fmt::format("unknown command '{}': illegal command", command.text));
  return out;
}

// The status the light gives: sync needs a flickering source, the detector a signal between
// its weak-light floor and overload.
int RemoteInstrument::light_status(const Scene& scene, double level) const {
  if (setup_.sync != RemoteSetup::Sync::none && scene.flicker_hz <= 0)
    return setup_.sync == RemoteSetup::Sync::automatic ? kCannotAutoSync : kCannotSync;
  if (level < options_.sensor.weak_light) return kWeakLight;
  if (level > 1) return kOverload;
  return 0;
}

// One measurement of the scene under the meter. Adaptive exposure fills the detector to its
// target level within the model's range; each cycle takes a dark and a light exposure.
Measurement RemoteInstrument::take_measurement(std::vector<Fault>& faults) {
  const Scene& scene = scenes_[scene_];
  const SensorModel& sensor = options_.sensor;
  const double peak = std::ranges::max(scene.radiance);
  const double longest = max_exposure_ms(setup_, profile_);
  double exposure = setup_.exposure_ms;
  if (exposure == 0)
    exposure = peak > 0 ? std::clamp(sensor.adaptive_target * sensor.full_scale / peak,
                                     static_cast<double>(profile_.exposure.min_ms), longest)
                        : longest;
  Measurement m;
  m.result.status = light_status(scene, peak * exposure / sensor.full_scale);
  std::erase_if(faults, [&](const Fault& fault) {
    if (fault.kind != FaultKind::error) return false;
    m.result.status = static_cast<int>(fault.amount);
    return true;
  });
  m.result.measured = true;
  m.result.si_units = setup_.si_units;
  m.result.exposure_ms = static_cast<int>(std::lround(exposure));
  if (m.result.status == 0) {
    const double sigma = options_.noise / std::sqrt(static_cast<double>(setup_.cycles));
    std::normal_distribution<double> gauss(0, 1);
    for (const double v : scene.radiance)
      m.result.values.push_back(std::max(0.0, v * (sigma > 0 ? 1 + sigma * gauss(rng_) : 1)));
  }
  m.duration_ms = setup_.cycles * 2 * exposure + sensor.overhead_ms;
  m.note = fmt::format("measured '{}': {:.0f} ms exposure, status {}", scene.name, exposure, m.result.status);
  ++measurements_;
  if (m.result.status == 0 && scene_ + 1 < scenes_.size()) ++scene_;
  return m;
}

Outcome RemoteInstrument::measure(int code, std::vector<Fault>& faults) {
  Measurement m = take_measurement(faults);
  buffer_ = std::move(m.result);
  Outcome out;
  out.notes.push_back(std::move(m.note));
  Reply reply;
  reply.delay_ms = m.duration_ms;
  // M0 on the 655/670 writes to disk; its reply is undocumented: the status alone.
  reply.bytes = code == 0 ? p6::format_error(buffer_.status, style_) : *report(code);
  out.reply = std::move(reply);
  return out;
}

Outcome RemoteInstrument::trigger(std::vector<Fault>& faults) {
  if (measuring()) return answer(p6::format_setup_status(kBusy, style_));
  Pending pending;
  pending.measurement = take_measurement(faults);
  const double real_ms = pending.measurement.duration_ms * options_.time_scale;
  pending.done_at =
      Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double, std::milli>(real_ms));
  Outcome out = answer(p6::format_setup_status(0, style_));
  out.notes.push_back(pending.measurement.note + " (triggered)");
  pending_ = std::move(pending);
  return out;
}

std::string RemoteInstrument::poll(std::vector<Fault>& faults) {
  if (!pending_) return p7::format_poll_reply({p7::PollReply::State::done, buffer_.status, {}}, style_);
  // A busy fault adds its polls once per measurement, on the first poll it meets.
  for (const Fault& fault : faults)
    if (fault.kind == FaultKind::busy && !pending_->busy_added) {
      pending_->busy_polls += fault.amount < 0 ? 1 : static_cast<int>(fault.amount);
      pending_->busy_added = true;
    }
  std::erase_if(faults, [](const Fault& f) { return f.kind == FaultKind::busy; });
  if (pending_->busy_polls > 0 || Clock::now() < pending_->done_at) {
    if (pending_->busy_polls > 0) --pending_->busy_polls;
    return p7::format_poll_reply({p7::PollReply::State::measuring, {}, {}}, style_);
  }
  buffer_ = std::move(pending_->measurement.result);
  pending_.reset();
  return p7::format_poll_reply({p7::PollReply::State::done, buffer_.status, {}}, style_);
}

std::string RemoteInstrument::abort() {
  if (!pending_) return p7::format_abort_reply({p7::AbortReply::Result::nothing_running, 0}, style_);
  pending_.reset();  // the buffer keeps the measurement before
  return p7::format_abort_reply({p7::AbortReply::Result::aborted, 0}, style_);
}

std::string RemoteInstrument::flicker() const {
  const double hz = scenes_[scene_].flicker_hz;
  if (hz <= 0) return p6::format_flicker_reply({{kCannotSync, 1}, std::nullopt}, style_);
  return p6::format_flicker_reply({{0, style_.setup_status_digits}, hz}, style_);
}

// Report `code`, or nothing for a code the meter does not know.
std::optional<std::string> RemoteInstrument::report(int code) const {
  switch (code) {
    case 110:
      return p6::format_text_report(options_.serial_number.empty() ? profile_.serial : options_.serial_number, style_);
    case 111:
      return p6::format_text_report(options_.wire.d111.empty() ? profile_.d111 : options_.wire.d111, style_);
    case 114:
      return p6::format_text_report(kFirmware, style_);
    case 117: {
      if (!profile_.caps.aperture) return p6::format_error(kNotThisModel, style_);
      std::vector<p6::Aperture> apertures;
      for (int i = 0; i < static_cast<int>(std::size(kApertureNames)); ++i)
        apertures.push_back({i, std::string(kApertureNames[i]), kBandwidthNm});
      return p6::format_apertures_reply(apertures, style_);
    }
    case 120: {
      p6::HardwareConfiguration configuration{{0, kDataStatusDigits},
                                              options_.wire.d120_manual ? kManualD120Grid : grid_,
                                              kBandwidthNm,
                                              kPixels,
                                              kFirstPixel,
                                              kLastPixel};
      return p6::format_hardware_configuration(configuration, style_);
    }
    case 13:
      if (!buffer_.measured) return p6::format_error(kNoData, style_);
      return p6::format_exposure_report(
          {{buffer_.status, kDataStatusDigits}, std::string(kGainLabel), buffer_.exposure_ms}, style_);
    case 5:
      return spectral_report();
    case 1:
    case 2:
    case 3:
    case 4:
    case 6:
      return colorimetric_report(code);
    default:
      return std::nullopt;
  }
}

std::string RemoteInstrument::spectral_report() const {
  if (!buffer_.measured) return p6::format_error(kNoData, style_);
  p6::SpectralReport report;
  report.status.code = buffer_.status;
  if (buffer_.status != 0) return p6::format_spectral_reply(report, style_);
  report.units = buffer_.si_units ? 1 : 0;
  report.values = buffer_.values;
  double sum = 0, photons = 0, peak = 0;
  for (std::size_t i = 0; i < nm_.size(); ++i) {
    report.wavelength_nm.push_back(static_cast<int>(nm_[i]));
    sum += buffer_.values[i];
    photons += buffer_.values[i] * nm_[i] * 1e-9 / kPlanckTimesLight;
    if (buffer_.values[i] > peak) {
      peak = buffer_.values[i];
      report.peak_nm = nm_[i];
    }
  }
  report.integrated = sum * grid_.step_nm;
  report.integrated_photon = photons * grid_.step_nm;
  return p6::format_spectral_reply(report, style_);
}

std::string RemoteInstrument::colorimetric_report(int code) const {
  if (!buffer_.measured) return p6::format_error(kNoData, style_);
  p6::ColorimetricReport report;
  report.report = code;
  report.status.code = buffer_.status;
  if (buffer_.status != 0) return p6::format_colorimetric_reply(report, style_);
  report.units = buffer_.si_units ? 1 : 0;
  report.values = colour_report_values(photometry(buffer_.values, observer_), code, buffer_.si_units);
  return p6::format_colorimetric_reply(report, style_);
}

}  // namespace

Command parse_remote_command(std::string_view frame) {
  Command command = parse_command(frame);
  if (command.text == p6::kRemoteKeyword) {
    command.key = "photo";
  } else if (command.letter == 'S' && command.text.size() > 1 &&
             std::isalpha(static_cast<unsigned char>(command.text[1]))) {
    command.key += static_cast<char>(std::tolower(static_cast<unsigned char>(command.text[1])));
  }
  return command;
}

std::unique_ptr<Responder> make_remote_instrument(Synthesis synthesis, const MeterOptions& options) {
  return std::make_unique<RemoteInstrument>(std::move(synthesis), options);
}

}  // namespace skinspec::simulator::detail
