// skinspec measure --device URI: readings from a Photo Research meter (the model --model names,
// or whichever answers), one JSON line each with --json.

#include <fmt/format.h>

#include <pthread.h>

#include <algorithm>
#include <atomic>
#include <charconv>
#include <chrono>
#include <csignal>
#include <iostream>
#include <limits>
#include <memory>
#include <thread>
#include <nlohmann/json.hpp>

#include "common.hpp"
#include "identity_json.hpp"
#include "skinspec/drivers/emergency_quit.hpp"
#include "skinspec/drivers/open_instrument.hpp"

namespace skinspec::cli {

namespace {

using drivers::InstrumentError;

struct MeasureArgs {
  std::string device;
  std::string model = "auto";
  int count = 1;
  std::string integration = "adaptive";
  std::string sync = "off";
  int averages = 1;
  bool extended_sensitivity = false;
  std::string aperture;
  bool adjust = false;
  bool json = false;
};

drivers::ModelChoice parse_model(const std::string& text) {
  auto choice = drivers::ModelChoice::parse(text);
  if (!choice) throw Failure{kBadInput, "--model: " + choice.error()};
  return *choice;
}

// With extended sensitivity (SH1) the longer range of the models that have it.
int parse_integration(const std::string& text, const drivers::ModelChoice& choice, bool extended) {
  if (text == "adaptive") return 0;
  const drivers::ExposureRange range = drivers::exposure_range(choice);
  const int longest = extended && range.max_extended_ms > 0 ? range.max_extended_ms : range.max_ms;
  int ms = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), ms);
  if (ec != std::errc() || end != text.data() + text.size() || ms < range.min_ms || ms > longest)
    throw Failure{
        kBadInput,
        fmt::format("--integration-ms {}: expected {}-{} ({}) or 'adaptive'", quote(text), range.min_ms, longest,
                    choice.forced ? "the " + std::string(drivers::profile(*choice.forced).name) + "'s range"
                                  : "what any model takes")};
  return ms;
}

// "off", "auto" (the meter measures the flicker), or a frequency in hertz to sync to; the
// driver holds a frequency to the model's range.
void parse_sync(const std::string& text, drivers::MeasureOptions& options) {
  if (text == "off") return;
  if (text == "auto") {
    options.sync = drivers::MeasureOptions::Sync::automatic;
    return;
  }
  double hz = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), hz);
  if (ec != std::errc() || end != text.data() + text.size() || !(hz > 0 && hz <= 1000))
    throw Failure{kBadInput, fmt::format("--sync {}: expected off, auto or a frequency in Hz", quote(text))};
  options.sync = drivers::MeasureOptions::Sync::frequency;
  options.sync_hz = hz;
}

double unix_seconds(std::chrono::system_clock::time_point t) {
  return std::chrono::duration<double>(t.time_since_epoch()).count();
}

nlohmann::json reading_json(const drivers::Reading& r) {
  return {{"quality_code", r.quality_code},
          {"quality", r.quality},
          {"units", r.units},
          {"wavelength_nm", r.wavelength_nm},
          {"radiance", r.radiance},
          {"integrated", r.integrated},
          {"luminance", r.luminance},
          {"luminance_units", r.luminance_units},
          {"x", r.x},
          {"y", r.y},
          {"XYZ", r.xyz},
          {"serial", r.serial_number},
          {"integration_ms", r.integration_ms},
          {"averages", r.averages},
          {"sync", r.sync},
          {"attempts", r.attempts},
          {"warnings", r.warnings},
          {"started", unix_seconds(r.started)},
          {"finished", unix_seconds(r.finished)}};
}

Failure instrument_failure(const InstrumentError& e) {
  return Failure{kInstrumentError, fmt::format("instrument error ({}): {}", drivers::to_string(e.kind), e.message)};
}

// SIGINT and SIGTERM cancel the call on the wire, so that the meter is let go of in order (a
// PR-655 or later is sent Q and leaves remote mode) rather than left with its keys locked. The
// signals stay blocked until the program ends: a second one must not cut that short.
class CancelOnSignal {
 public:
  explicit CancelOnSignal(drivers::Instrument& meter) {
    sigemptyset(&signals_);
    sigaddset(&signals_, SIGINT);
    sigaddset(&signals_, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &signals_, nullptr);
    waiter_ = std::thread([this, &meter] {
      int signal = 0;
      sigwait(&signals_, &signal);
      if (done_) return;
      received_ = signal;
      meter.cancel();
    });
  }
  ~CancelOnSignal() {
    done_ = true;
    pthread_kill(waiter_.native_handle(), SIGTERM);  // ends its wait if no signal did
    waiter_.join();
  }
  CancelOnSignal(const CancelOnSignal&) = delete;
  CancelOnSignal& operator=(const CancelOnSignal&) = delete;

  // Throws if a signal came: nothing more is asked of the meter.
  void check() const {
    if (const int signal = received_)
      throw Failure{kInstrumentError, fmt::format("instrument error (cancelled): stopped by {}",
                                                  signal == SIGINT ? "SIGINT" : "SIGTERM")};
  }

 private:
  sigset_t signals_{};
  std::atomic<bool> done_{false};
  std::atomic<int> received_{0};
  std::thread waiter_;
};

std::unique_ptr<drivers::Instrument> open_meter(const MeasureArgs& args, drivers::ModelChoice choice) {
  auto uri = drivers::parse_connection_uri(args.device);
  if (!uri) throw Failure{kBadInput, "--device " + quote(args.device) + ": " + uri.error()};
  auto transport = drivers::make_transport(*uri);
  if (!transport) throw Failure{kInstrumentError, transport.error()};
  return drivers::make_instrument(std::move(*transport), choice, drivers::instrument_options_for(*uri));
}

void print_reading(const MeasureArgs& args, int number, const drivers::Reading& reading,
                   const nlohmann::json& instrument) {
  for (const auto& warning : reading.warnings) std::cerr << fmt::format("reading {}: {}\n", number, warning);
  if (args.json) {
    nlohmann::json line = reading_json(reading);
    line["instrument"] = instrument;
    std::cout << line.dump() << '\n';
  } else {
    std::cout << fmt::format(
        "reading {}: quality {:02d} ({}), luminance {:.4g} {}, x {:.4f} y {:.4f}, {} points {}-{} nm\n", number,
        reading.quality_code, reading.quality, reading.luminance, reading.luminance_units, reading.x, reading.y,
        reading.radiance.size(), reading.wavelength_nm.front(), reading.wavelength_nm.back());
  }
  std::cout.flush();
}

void run_measure(const MeasureArgs& args) {
  drivers::install_emergency_quit();  // a meter in remote mode is sent Q even after a crash
  const drivers::ModelChoice choice = parse_model(args.model);
  drivers::MeasureOptions measure;
  measure.integration_ms = parse_integration(args.integration, choice, args.extended_sensitivity);
  parse_sync(args.sync, measure);
  measure.averages = args.averages;
  measure.extended_sensitivity = args.extended_sensitivity;
  measure.aperture = args.aperture;
  measure.adjust_integration = args.adjust;
  const auto meter = open_meter(args, choice);
  const CancelOnSignal signals(*meter);  // ends before the meter, whose disconnect sends Q
  auto connected = meter->connect();
  signals.check();
  if (!connected) throw instrument_failure(connected.error());
  const auto identity = meter->identify();
  signals.check();
  if (!identity) throw instrument_failure(identity.error());
  for (const auto& warning : identity->warnings) std::cerr << fmt::format("instrument: {}\n", warning);
  const nlohmann::json instrument = drivers::identity_json(*identity);
  if (!args.json)
    std::cout << fmt::format("instrument: {}, serial number {}, {}-{} nm by {} nm\n", identity->reported_model,
                             identity->serial_number, identity->grid.first_nm, identity->grid.last_nm,
                             identity->grid.step_nm);
  for (int i = 0; i < args.count; ++i) {
    signals.check();
    auto reading = meter->measure(measure);
    signals.check();
    if (!reading) throw instrument_failure(reading.error());
    print_reading(args, i + 1, *reading, instrument);
  }
}

}  // namespace

void add_measure_command(CLI::App& app) {
  auto args = std::make_shared<MeasureArgs>();
  auto* measure = app.add_subcommand("measure", "measure with a Photo Research meter and print each reading");
  measure
      ->add_option("--device", args->device,
                   "serial:/dev/ttyUSB0[?baud=9600&terminator=lf|cr], tcp:HOST:PORT or usb:VID:PID[:SERIAL]")
      ->required();
  measure
      ->add_option("--model", args->model,
                   "the meter's model: auto (asked when connecting) or a model id such as pr650, pr670 or pr730")
      ->capture_default_str();
  measure->add_option("--count", args->count, "number of readings")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  measure->add_option("--integration-ms", args->integration, "exposure in ms within the model's range, or adaptive")
      ->capture_default_str();
  measure
      ->add_option("--sync", args->sync,
                   "off; auto: measure the light's flicker and sync to it; or a frequency in Hz to sync to (the PR-650 "
                   "40-250, the newer meters 20-400)")
      ->capture_default_str();
  measure->add_option("--averages", args->averages, "measurements the meter averages into each reading")
      ->check(CLI::Range(1, 99))
      ->capture_default_str();
  measure->add_flag("--extended-sensitivity", args->extended_sensitivity,
                    "the longer exposure range (SH1) of the models that have it (PR-670, PR-680, PR-7xx)");
  measure->add_option("--aperture", args->aperture,
                      "an aperture by the name the meter lists, such as '1/2 deg' (PR-670, PR-680, PR-7xx)");
  measure->add_flag("--adjust-integration", args->adjust, "double the time on low light, halve it on overload");
  measure->add_flag("--json", args->json, "one JSON object per reading per line");
  measure->callback([args] { run_measure(*args); });
}

}  // namespace skinspec::cli
