#include "options.hpp"

#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cctype>
#include <charconv>
#include <limits>

#include "skinspec/version.hpp"

namespace skinspec::sim_app {

namespace {

// Seconds, or "inf" / "never" for a window that never closes.
std::expected<double, std::string> parse_boot_window(const std::string& text) {
  if (text == "never") return std::numeric_limits<double>::infinity();
  double seconds = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), seconds);
  if (text.empty() || ec != std::errc() || end != text.data() + text.size() || !(seconds >= 0))
    return std::unexpected(fmt::format("--boot-window '{}': expected seconds >= 0, or 'inf'", text));
  return seconds;
}

bool valid_serial(const std::string& serial) {
  return !serial.empty() && serial.size() <= 32 &&
         std::ranges::all_of(serial, [](char c) { return std::isalnum(static_cast<unsigned char>(c)) != 0; });
}

struct RawOptions {
  std::string listen;
  std::string boot_window = "5";
  std::string header;
  std::string exponent;
  std::string replay_order = "in-order";
  bool fresh_on_low_light = false;
  std::string model;
  std::string banner;
  std::string error_style;
  std::string d120;
};

std::string model_ids() {
  std::string out;
  for (const auto& row : drivers::all_profiles()) out += (out.empty() ? "" : "|") + std::string(row.id);
  return out;
}

// --model and the newer models' wire overrides.
std::expected<void, std::string> finish_model(const RawOptions& raw, simulator::SimulatorConfig& config) {
  auto& wire = config.meter.wire;
  if (!raw.model.empty()) {
    config.model = drivers::model_from_id(raw.model);
    if (!config.model) return std::unexpected(fmt::format("--model '{}': expected one of {}", raw.model, model_ids()));
  }
  const bool newer = config.model && drivers::profile(*config.model).caps.remote_keyword;
  const bool overridden = !raw.banner.empty() || !raw.error_style.empty() || !raw.d120.empty() || !wire.d111.empty() ||
                          wire.status_digits || wire.exponent_digits || !config.meter.firmware.empty();
  if (overridden && !newer)
    return std::unexpected(
        "--banner, --error-style, --status-digits, --exponent-digits, --d111, --d120 and --firmware need a newer "
        "--model (pr655 or later)");
  if (!config.meter.firmware.empty()) {
    const drivers::MeterProfile& row = drivers::profile(*config.model);
    if (!drivers::find_firmware(row, config.meter.firmware)) {
      std::string known;
      for (const auto& firmware : row.firmware) known += (known.empty() ? "" : ", ") + std::string(firmware.id);
      return std::unexpected(fmt::format("--firmware '{}': the {} has {}", config.meter.firmware, row.name, known));
    }
  }
  if (!raw.banner.empty()) wire.banner = raw.banner == "crlf" ? drivers::BannerEnd::crlf : drivers::BannerEnd::none;
  if (!raw.error_style.empty()) wire.padded_errors = raw.error_style == "padded";
  wire.d120_manual = raw.d120 == "manual";
  if (!wire.d111.empty() && !std::ranges::all_of(wire.d111, [](char c) { return c >= 0x20 && c < 0x7f && c != ','; }))
    return std::unexpected(fmt::format("--d111 '{}': printable characters without commas", wire.d111));
  return {};
}

// The options that need more than CLI11's checks, into `options`.
std::expected<void, std::string> finish(const RawOptions& raw, AppOptions& options) {
  auto& config = options.config;
  auto& meter = config.meter;
  if (raw.listen.empty() && !options.pty) return std::unexpected("give --listen HOST:PORT, --pty, or both");
  if (!raw.listen.empty()) {
    auto address = parse_listen_address(raw.listen);
    if (!address) return std::unexpected(address.error());
    options.listen = *address;
  }
  auto window = parse_boot_window(raw.boot_window);
  if (!window) return std::unexpected(window.error());
  meter.boot_window_s = *window;
  if (!raw.header.empty())
    meter.style.header = raw.header == "h1" || raw.header == "H1" ? drivers::pr650::HeaderVariant::h1_bare_cr
                                                                  : drivers::pr650::HeaderVariant::h2_two_lines;
  if (!raw.exponent.empty()) meter.style.exponent = raw.exponent.front();
  meter.replay_order = raw.replay_order == "by-command" ? simulator::MeterOptions::ReplayOrder::by_command
                                                        : simulator::MeterOptions::ReplayOrder::in_order;
  meter.stale_on_low_light = !raw.fresh_on_low_light;
  if (auto model = finish_model(raw, config); !model) return std::unexpected(model.error());
  if (!meter.serial_number.empty() && !valid_serial(meter.serial_number))
    return std::unexpected(fmt::format("--serial '{}': expected 1-32 letters and digits", meter.serial_number));
  if (!(meter.noise >= 0)) return std::unexpected(fmt::format("--noise {}: must not be negative", meter.noise));
  return {};
}

}  // namespace

std::expected<AppOptions, EarlyExit> parse_options(int argc, char** argv) {
  AppOptions options;
  RawOptions raw;
  auto& config = options.config;
  auto& meter = config.meter;

  CLI::App app{
      "skinspec-sim: a simulated Photo Research meter (PR-650 by default, --model for the newer ones)\n"
      "on a TCP port or a pseudo-terminal.\n"
      "Prints 'listening on HOST:PORT' and/or 'pty PATH', then serves one client at a time until\n"
      "SIGTERM or SIGINT; SIGHUP power-cycles the meter. Readings come from --replay, --radiance or\n"
      "--reflectance (with --white and --illuminant); with none, from a white standard.",
      "skinspec-sim"};
  app.set_version_flag("--version", "skinspec-sim " + std::string(skinspec::kVersion));

  app.add_option("--listen", raw.listen, "serve TCP clients on HOST:PORT (numeric address; port 0: any free port)")
      ->type_name("HOST:PORT");
  app.add_flag("--pty", options.pty, "serve on a new pseudo-terminal too (or only, without --listen); prints its path");

  auto* replay = app.add_option("--replay", config.replay_file, "replay a recording (docs/recording-format.md)")
                     ->type_name("FILE");
  app.add_option("--replay-order", raw.replay_order, "match commands to the recording in-order or by-command")
      ->type_name("ORDER")
      ->check(CLI::IsMember({"in-order", "by-command"}))
      ->capture_default_str();
  auto* radiance = app.add_option("--radiance", config.radiance_file,
                                  "spectra CSV of radiance in W/(sr m2 nm): one measurement per column")
                       ->type_name("FILE");
  auto* reflectance = app.add_option("--reflectance", config.reflectance_files,
                                     "spectra CSV files of reflectance (0-1.5), comma-separated or repeated: one "
                                     "measurement per column, under --illuminant")
                          ->type_name("FILE[,FILE...]")
                          ->delimiter(',');
  auto* white = app.add_option("--white", config.white_file,
                               "spectra CSV of a white standard's reflectance, measured before the others")
                    ->type_name("FILE");
  auto* illuminant = app.add_option("--illuminant", config.illuminant,
                                    "the lamp: D65, A, or a spectra CSV file of relative power (its first column)")
                         ->type_name("D65|A|FILE")
                         ->capture_default_str();
  auto* white_luminance =
      app.add_option("--white-luminance", config.white_luminance, "cd/m2 of a perfect white diffuser under the lamp")
          ->type_name("CD/M2")
          ->capture_default_str();
  app.add_option("--flicker", config.flicker_hz, "Hz the F command reports; 0: steady light")
      ->type_name("HZ")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  replay->excludes(radiance)->excludes(reflectance)->excludes(white)->excludes(illuminant)->excludes(white_luminance);
  radiance->excludes(reflectance);

  app.add_option("--time-scale", meter.time_scale, "multiplies every delay and the line's pacing; 0: no waiting")
      ->type_name("X")
      ->capture_default_str();
  app.add_option("--boot-window", raw.boot_window,
                 "seconds after power-on (start, SIGHUP) in which a command puts the meter in remote mode; inf: always")
      ->type_name("SECONDS")
      ->capture_default_str();
  app.add_option("--fault", config.faults, "a fault spec, e.g. d5:truncate, m0:no-answer@2, m:quality=18 (repeatable)")
      ->type_name("SPEC");
  app.add_option("--fault-rate", config.fault_rate, "probability of a random fault per command")
      ->type_name("P")
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--fault-gap", config.fault_gap, "commands spared after a random fault (1: only single faults)")
      ->type_name("N")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--seed", config.seed, "seed of random faults, noise and line noise")
      ->type_name("N")
      ->capture_default_str();
  app.add_option("--noise", meter.noise, "relative standard deviation of each spectral value")
      ->type_name("R")
      ->capture_default_str();
  app.add_option("--model", raw.model, "the meter simulated (default pr650; a replay: its recorded model)")
      ->type_name(model_ids());
  app.add_option("--serial", meter.serial_number, "the serial number D110 reports (default: the model's)")
      ->type_name("NUMBER");
  app.add_option("--banner", raw.banner, "newer models: what follows ' REMOTE MODE' (default none)")
      ->type_name("none|crlf")
      ->check(CLI::IsMember({"none", "crlf"}));
  app.add_option("--error-style", raw.error_style, "newer models: errors as -8 (short) or -0008 (padded)")
      ->type_name("short|padded")
      ->check(CLI::IsMember({"short", "padded"}));
  app.add_option("--status-digits", meter.wire.status_digits, "newer models: digits of a data reply's status")
      ->type_name("4|5")
      ->check(CLI::IsMember({4, 5}));
  app.add_option("--exponent-digits", meter.wire.exponent_digits, "newer models: exponent digits of D5 data lines")
      ->type_name("2|3")
      ->check(CLI::IsMember({2, 3}));
  app.add_option("--d111", meter.wire.d111, "newer models: the model name D111 reports (default: the model's)")
      ->type_name("TEXT");
  app.add_option("--d120", raw.d120, "newer models: 'manual' prints the manuals' D120 example (201 points, 2 nm)")
      ->type_name("manual")
      ->check(CLI::IsMember({"manual"}));
  app.add_option("--firmware", meter.firmware,
                 "newer models: the firmware generation, by the manual that describes it (m730: no T/P/A/V and "
                 "sync as SQ; default the model's newest; docs/simulator.md)")
      ->type_name("ID");
  app.add_flag("--trace-bytes", meter.trace_bytes, "log every byte received, with the command so far");
  app.add_option("--header", raw.header, "spectral report header layout: h1 or h2 (default h1)")
      ->type_name("h1|h2")
      ->check(CLI::IsMember({"h1", "h2", "H1", "H2"}));
  app.add_option("--exponent", raw.exponent, "exponent letter of printed values: E or e (default E)")
      ->type_name("E|e")
      ->check(CLI::IsMember({"E", "e"}));
  app.add_flag("--m0-quality", meter.m0_reports_quality, "M0 answers 0qq with the quality code rather than 000");
  app.add_flag("--fresh-on-low-light", raw.fresh_on_low_light,
               "quality 10 and 18 store new data instead of leaving the previous data lines");
  app.add_flag("-q,--quiet", options.quiet, "report only errors on standard error, not events");

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return std::unexpected(EarlyExit{app.exit(e), {}});
  } catch (const CLI::CallForAllHelp& e) {
    return std::unexpected(EarlyExit{app.exit(e), {}});
  } catch (const CLI::CallForVersion& e) {
    return std::unexpected(EarlyExit{app.exit(e), {}});
  } catch (const CLI::ParseError& e) {
    return std::unexpected(EarlyExit{kExitBadInput, fmt::format("{} (see --help)", e.what())});
  }
  if (auto finished = finish(raw, options); !finished)
    return std::unexpected(EarlyExit{kExitBadInput, finished.error()});
  return options;
}

}  // namespace skinspec::sim_app
