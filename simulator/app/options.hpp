#pragma once
// skinspec-sim's command line (docs/simulator.md, "The skinspec-sim program").

#include <expected>
#include <optional>
#include <string>

#include "endpoints.hpp"
#include "skinspec/simulator/simulator.hpp"

namespace skinspec::sim_app {

inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;   // the listener or the pseudo-terminal could not be set up
inline constexpr int kExitBadInput = 2;  // bad options, unreadable or invalid files

struct AppOptions {
  simulator::SimulatorConfig config;
  std::optional<ListenAddress> listen;
  bool pty = false;
  bool quiet = false;
};

// How to end instead: after --help or --version (status 0, already printed), or after a
// mistake (status 2, with the message to print).
struct EarlyExit {
  int status = kExitOk;
  std::string message;
};

std::expected<AppOptions, EarlyExit> parse_options(int argc, char** argv);

}  // namespace skinspec::sim_app
