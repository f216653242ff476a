#pragma once
// Building a simulated meter from what a user names: the one header a program needs.
//
//   SimulatorConfig config;
//   config.reflectance_files = {"skin.csv"};
//   config.white_file = "white.csv";
//   config.illuminant = "A";
//   auto meter = make_simulated_meter(config);          // or an error to print
//   std::atomic<bool> stop{false};
//   (*meter)->serve(link, stop);                         // link: any drivers::Transport

#include <cstdint>
#include <expected>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "skinspec/simulator/meter.hpp"

namespace skinspec::simulator {

struct SimulatorConfig {
  // At most one of replay_file, radiance_file and reflectance_files; none: a white standard
  // (reflectance 0.99) under the illuminant.
  std::string replay_file;                     // a recording (docs/recording-format.md)
  std::string radiance_file;                   // spectra CSV, W/(sr m2 nm), one scene per column
  std::vector<std::string> reflectance_files;  // spectra CSV, one scene per column, in order
  std::string white_file;                      // reflectance of a white standard: measured first
  std::string illuminant = "D65";              // "D65", "A", or a spectra CSV file of relative power
  double white_luminance = 100;                // cd/m2 of a perfect white under the illuminant
  double flicker_hz = 60.02;                   // what F reports; 0: steady light
  std::vector<std::string> faults;             // fault specs (faults.hpp)
  double fault_rate = 0;                       // random faults: probability per command
  int fault_gap = 0;                           // commands spared after a random fault
  std::uint64_t seed = 1;                      // random faults and noise
  // The model simulated; none: a replay's recorded model, else the PR-650.
  std::optional<drivers::Model> model;
  MeterOptions meter;  // its `model`, `faults` and `seed` are set from the above
};

// Reads the files (and the colour tables of the data directory for synthesis); an error
// names the file or spec at fault.
std::expected<std::unique_ptr<SimulatedMeter>, std::string> make_simulated_meter(const SimulatorConfig& config);

}  // namespace skinspec::simulator
