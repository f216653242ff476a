// The synthetic PR-650: its setup, its measurement buffer and what each command does to them.

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <random>

#include "responder.hpp"

namespace skinspec::simulator::detail {

namespace {

namespace pp = drivers::pr650;

constexpr int kMinIntegrationMs = 10, kMaxIntegrationMs = 6000;

bool all_digits(std::string_view text) {
  return !text.empty() && std::ranges::all_of(text, [](unsigned char c) { return std::isdigit(c) != 0; });
}

std::optional<int> to_int(std::string_view text) {
  if (!all_digits(text) || text.size() > 6) return std::nullopt;
  int value = 0;
  std::from_chars(text.data(), text.data() + text.size(), value);
  return value;
}

std::optional<double> to_number(std::string_view text) {
  double value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (text.empty() || error != std::errc() || end != text.data() + text.size() || !std::isfinite(value))
    return std::nullopt;
  return value;
}

std::vector<std::string_view> split_fields(std::string_view text) {
  std::vector<std::string_view> fields;
  while (true) {
    const auto comma = text.find(',');
    fields.push_back(text.substr(0, comma));
    if (comma == std::string_view::npos) return fields;
    text.remove_prefix(comma + 1);
  }
}

// The S command: the first invalid field's number (50 for field 1 naming no primary
// accessory), or 0 and the new setup. Empty fields leave a setting as it was, except the sync
// field, where empty means no sync.
int apply_setup(std::string_view parameters, pp::Setup& setup) {
  const auto fields = split_fields(parameters);
  if (fields.size() > 8) return 9;
  pp::Setup next = setup;
  const auto field = [&](std::size_t i) { return i < fields.size() ? fields[i] : std::string_view(); };
  if (const auto f = field(0); !f.empty()) {
    const auto code = to_int(f);
    if (!code) return 1;
    if (*code < 1 || *code > 12) return 50;
    next.primary_accessory = *code;
  }
  for (std::size_t i = 1; i <= 3; ++i) {
    const auto f = field(i);
    if (f.empty()) continue;
    const auto code = to_int(f);
    if (!code || *code < 2 || *code > 12) return static_cast<int>(i) + 1;
    next.addons[i - 1] = *code;
  }
  if (const auto f = field(4); f.empty()) {
    next.sync = pp::Setup::Sync::none;
  } else if (f == "1") {
    next.sync = pp::Setup::Sync::last_measured;
  } else {
    const auto hz = to_number(f);
    if (!hz || *hz < 40 || *hz > 250) return 5;
    next.sync = pp::Setup::Sync::frequency;
    next.sync_hz = *hz;
  }
  if (const auto f = field(5); !f.empty()) {
    const auto ms = to_int(f);
    if (!ms || (*ms != 0 && (*ms < kMinIntegrationMs || *ms > kMaxIntegrationMs))) return 6;
    next.integration_ms = *ms;
  }
  if (const auto f = field(6); !f.empty()) {
    const auto n = to_int(f);
    if (!n || *n < 1 || *n > 99) return 7;
    next.averages = *n;
  }
  if (const auto f = field(7); !f.empty()) {
    if (f != "0" && f != "1") return 8;
    next.si_units = f == "1";
  }
  setup = next;
  return 0;
}

pp::Setup power_on_setup() {
  pp::Setup setup;
  setup.si_units = false;  // field 8 defaults to English units
  return setup;
}

// What a measurement leaves in the meter.
struct LastMeasurement {
  int quality = 0;
  std::vector<double> values = std::vector<double>(pp::kSpectralPoints, 0.0);
  bool si_units = false;
};

class Instrument final : public Responder {
 public:
  Instrument(Synthesis synthesis, const MeterOptions& options)
      : observer_(std::move(synthesis.observer)),
        scenes_(std::move(synthesis.scenes)),
        options_(options),
        rng_(options.seed) {
    if (scenes_.empty()) scenes_.push_back({"darkness", std::vector<double>(pp::kSpectralPoints, 0.0), 0});
    power_cycle();
  }

  Outcome respond(const Command& command, std::vector<Fault>& faults) override;

  void power_cycle() override {
    setup_ = power_on_setup();
    setup_status_ = 0;
    buffer_ = LastMeasurement{};
    flicker_hz_.reset();
  }

  std::size_t measurements() const override { return measurements_; }

 private:
  Outcome measure(int report, std::vector<Fault>& faults);
  Outcome flicker();
  std::optional<std::string> report(int code) const;
  Reply quick(std::string bytes) const {
    Reply reply;
    reply.bytes = std::move(bytes);
    reply.delay_ms = options_.sensor.reply_ms;
    return reply;
  }

  Observer observer_;
  std::vector<Scene> scenes_;
  std::size_t scene_ = 0;  // the scene under the meter: advances after a measurement that succeeds
  const MeterOptions& options_;
  std::mt19937_64 rng_;
  pp::Setup setup_;
  int setup_status_ = 0;
  LastMeasurement buffer_;
  std::optional<double> flicker_hz_;  // the last F result
  std::size_t measurements_ = 0;
};

Outcome Instrument::respond(const Command& command, std::vector<Fault>& faults) {
  const std::string_view parameters = command.parameters();
  const auto code = to_int(parameters);
  switch (command.letter) {
    case 'B':
      if (code && *code <= 3) return {quick(pp::format_status_reply(0)), {}, {}};
      break;
    case 'S': {
      setup_status_ = apply_setup(parameters, setup_);
      Outcome out{quick(pp::format_setup_reply(setup_status_)), {}, {}};
      if (setup_status_ != 0)
        out.notes.push_back(fmt::format("setup refused: {}", pp::setup_reply_message(setup_status_)));
      return out;
    }
    case 'F':
      if (parameters.empty()) return flicker();
      break;
    case 'M':
      if (code && *code <= 6) return measure(*code, faults);
      break;
    case 'D':
      if (code) {
        if (auto bytes = report(*code)) return {quick(std::move(*bytes)), {}, {}};
      }
      break;
    case 'E':
      if (parameters.empty()) {
        Reply reply;
        reply.echo = true;
        return {reply, {"echo on"}, {}};
      }
      break;
    default:
      break;
  }
  return {std::nullopt, {}, {fmt::format("unknown command '{}': no answer", command.text)}};
}

Outcome Instrument::flicker() {
  const Scene& scene = scenes_[scene_];
  Reply reply;
  reply.delay_ms = options_.sensor.flicker_ms;
  if (scene.flicker_hz > 0) {
    flicker_hz_ = scene.flicker_hz;
    reply.bytes = pp::format_flicker_reply({0, scene.flicker_hz});
  } else {
    flicker_hz_.reset();
    reply.bytes = pp::format_flicker_reply({7, 0});
  }
  return {std::move(reply), {}, {}};
}

// One measurement of the scene under the meter. Adaptive integration fills the detector to its
// target level within 10-6000 ms; dim light runs into the 6 s limit and reads low, bright light
// overloads even at 10 ms. Each average takes a dark and a light integration.
Outcome Instrument::measure(int report_code, std::vector<Fault>& faults) {
  const Scene& scene = scenes_[scene_];
  const SensorModel& sensor = options_.sensor;
  const double peak = std::ranges::max(scene.radiance);
  double integration = setup_.integration_ms;
  if (integration == 0)
    integration = peak > 0 ? std::clamp(sensor.adaptive_target * sensor.full_scale / peak, double{kMinIntegrationMs},
                                        double{kMaxIntegrationMs})
                           : kMaxIntegrationMs;
  const double level = peak * integration / sensor.full_scale;

  int quality = 0;
  const bool sync_wanted = setup_.sync != pp::Setup::Sync::none;
  if (sync_wanted && (scene.flicker_hz <= 0 || (setup_.sync == pp::Setup::Sync::last_measured && !flicker_hz_))) {
    quality = 7;
  } else if (level < sensor.weak_light) {
    quality = 10;
  } else if (level < sensor.low_light) {
    quality = 18;
  } else if (level > 1) {
    quality = 19;
  }
  bool forced_stale = false;
  std::erase_if(faults, [&](const Fault& fault) {
    if (fault.kind == FaultKind::quality) {
      quality = static_cast<int>(fault.amount);
    } else if (fault.kind == FaultKind::stale) {
      quality = fault.amount < 0 ? 18 : static_cast<int>(fault.amount);
      forced_stale = true;
    } else {
      return false;
    }
    return true;
  });

  // In low light the meter does not update its spectral buffer: the data lines stay old.
  const bool stale = forced_stale || (options_.stale_on_low_light && (quality == 10 || quality == 18));
  if (!stale) {
    const double sigma = options_.noise / std::sqrt(static_cast<double>(setup_.averages));
    std::normal_distribution<double> gauss(0, 1);
    for (std::size_t i = 0; i < buffer_.values.size(); ++i)
      buffer_.values[i] = std::max(0.0, scene.radiance[i] * (sigma > 0 ? 1 + sigma * gauss(rng_) : 1));
  }
  buffer_.quality = quality;
  buffer_.si_units = setup_.si_units;
  ++measurements_;

  Outcome out;
  out.notes.push_back(fmt::format("measured '{}': {:.0f} ms integration, quality {:02}{}", scene.name, integration,
                                  quality, stale ? " (data lines unchanged)" : ""));
  if (quality == 0 && scene_ + 1 < scenes_.size()) ++scene_;

  Reply reply;
  reply.delay_ms = setup_.averages * 2 * integration + sensor.overhead_ms;
  if (report_code == 0) {
    reply.bytes = pp::format_status_reply(options_.m0_reports_quality ? quality : 0);
  } else {
    reply.bytes = *report(report_code);
  }
  out.reply = std::move(reply);
  return out;
}

// Report `code` of the buffer, or nothing for a code the meter does not know.
std::optional<std::string> Instrument::report(int code) const {
  switch (code) {
    case 110:
      return pp::format_serial_number_reply(
          options_.serial_number.empty() ? drivers::profile(drivers::Model::pr650).serial : options_.serial_number);
    case 120:
      return pp::format_spectral_configuration_reply({pp::kSpectralPoints, 8.0, 380, 780, 4});
    case 201:
      return pp::format_setup_reply(setup_status_);
    case 5: {
      pp::SpectralReport report;
      report.quality = buffer_.quality;
      report.wavelength_nm = native_grid();
      report.values = buffer_.values;
      double sum = 0;
      for (const double v : buffer_.values) sum += v;
      report.integrated = sum * pp::kStepNm;
      return pp::format_spectral_reply(report, options_.style);
    }
    case 1:
    case 2:
    case 3:
    case 4:
    case 6: {
      pp::ColorimetricReport report;
      report.report = code;
      report.quality = buffer_.quality;
      report.values = colour_report_values(photometry(buffer_.values, observer_), code, buffer_.si_units);
      return pp::format_colorimetric_reply(report, options_.style);
    }
    default:
      return std::nullopt;
  }
}

}  // namespace

Command parse_command(std::string_view line) {
  while (!line.empty() && (line.back() == ' ' || line.back() == '\t')) line.remove_suffix(1);
  Command command;
  for (const char c : line) command.text += static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  if (command.text.empty()) return command;
  command.letter = command.text.front();
  command.key = static_cast<char>(std::tolower(static_cast<unsigned char>(command.letter)));
  if (command.letter == 'B' || command.letter == 'M' || command.letter == 'D') {
    for (const char c : command.parameters()) {
      if (!std::isdigit(static_cast<unsigned char>(c))) break;
      command.key += c;
    }
  }
  return command;
}

std::unique_ptr<Responder> make_instrument(Synthesis synthesis, const MeterOptions& options) {
  return std::make_unique<Instrument>(std::move(synthesis), options);
}

}  // namespace skinspec::simulator::detail
