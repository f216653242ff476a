// skinspec measure --device URI: readings from a PR-650, one JSON line each with --json.

#include <fmt/format.h>

#include <charconv>
#include <chrono>
#include <iostream>
#include <nlohmann/json.hpp>

#include "common.hpp"
#include "skinspec/drivers/pr650.hpp"

namespace skinspec::cli {

namespace {

using drivers::InstrumentError;

struct MeasureArgs {
  std::string device;
  int count = 1;
  std::string integration = "adaptive";
  std::string sync = "off";
  bool adjust = false;
  bool json = false;
};

int parse_integration(const std::string& text) {
  if (text == "adaptive") return 0;
  int ms = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), ms);
  if (ec != std::errc() || end != text.data() + text.size() || ms < 10 || ms > 6000)
    throw Failure{kBadInput, "--integration-ms " + quote(text) + ": expected 10-6000 or 'adaptive'"};
  return ms;
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

void run_measure(const MeasureArgs& args) {
  const int integration = parse_integration(args.integration);
  auto uri = drivers::parse_connection_uri(args.device);
  if (!uri) throw Failure{kBadInput, "--device " + quote(args.device) + ": " + uri.error()};
  auto transport = drivers::make_transport(*uri);
  if (!transport) throw Failure{kInstrumentError, transport.error()};
  drivers::DriverOptions options;
  options.style.terminator = uri->terminator.value_or(options.style.terminator);
  drivers::Pr650 meter(std::move(*transport), options);
  if (auto connected = meter.connect(); !connected) throw instrument_failure(connected.error());
  if (auto identity = meter.identify(); !identity) throw instrument_failure(identity.error());

  drivers::MeasureOptions measure;
  measure.integration_ms = integration;
  measure.sync = args.sync == "auto" ? drivers::MeasureOptions::Sync::automatic : drivers::MeasureOptions::Sync::off;
  measure.adjust_integration = args.adjust;
  for (int i = 0; i < args.count; ++i) {
    auto reading = meter.measure(measure);
    if (!reading) throw instrument_failure(reading.error());
    for (const auto& warning : reading->warnings) std::cerr << fmt::format("reading {}: {}\n", i + 1, warning);
    if (args.json) {
      std::cout << reading_json(*reading).dump() << '\n';
    } else {
      std::cout << fmt::format(
          "reading {}: quality {:02d} ({}), luminance {:.4g} {}, x {:.4f} y {:.4f}, {} points {}-{} nm\n", i + 1,
          reading->quality_code, reading->quality, reading->luminance, reading->luminance_units, reading->x, reading->y,
          reading->radiance.size(), reading->wavelength_nm.front(), reading->wavelength_nm.back());
    }
    std::cout.flush();
  }
}

}  // namespace

void add_measure_command(CLI::App& app) {
  auto args = std::make_shared<MeasureArgs>();
  auto* measure = app.add_subcommand("measure", "measure with a PR-650 and print each reading");
  measure
      ->add_option("--device", args->device,
                   "serial:/dev/ttyUSB0[?baud=9600&terminator=lf|cr], tcp:HOST:PORT or usb:VID:PID[:SERIAL]")
      ->required();
  measure->add_option("--count", args->count, "number of readings")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  measure->add_option("--integration-ms", args->integration, "10-6000 ms, or adaptive")->capture_default_str();
  measure->add_option("--sync", args->sync, "off, or auto: measure the light's flicker and sync to it")
      ->check(CLI::IsMember({"off", "auto"}))
      ->capture_default_str();
  measure->add_flag("--adjust-integration", args->adjust, "double the time on low light, halve it on overload");
  measure->add_flag("--json", args->json, "one JSON object per reading per line");
  measure->callback([args] { run_measure(*args); });
}

}  // namespace skinspec::cli
