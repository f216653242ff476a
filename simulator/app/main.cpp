// skinspec-sim: a simulated PR-650 on a TCP port or a pseudo-terminal (docs/simulator.md).

#include <fmt/format.h>

#include <cstdio>
#include <optional>

#include "console.hpp"
#include "endpoints.hpp"
#include "options.hpp"
#include "server.hpp"
#include "signals.hpp"

int main(int argc, char** argv) {
  using namespace skinspec::sim_app;
  // Before any thread exists, so that signals reach only the server's loop.
  auto signals = Signals::install();
  if (!signals) {
    fmt::print(stderr, "skinspec-sim: {}\n", signals.error());
    return kExitFailure;
  }
  auto options = parse_options(argc, argv);
  if (!options) {
    if (!options.error().message.empty()) fmt::print(stderr, "skinspec-sim: {}\n", options.error().message);
    return options.error().status;
  }

  Console console(options->quiet);
  options->config.meter.log = [&console](std::string_view line) { console.note(line); };
  auto meter = skinspec::simulator::make_simulated_meter(options->config);
  if (!meter) {
    console.error(meter.error());
    return kExitBadInput;
  }

  std::optional<Listener> listener;
  if (options->listen) {
    auto opened = Listener::open(*options->listen);
    if (!opened) {
      console.error(opened.error());
      return kExitFailure;
    }
    listener = std::move(*opened);
  }
  std::optional<Pty> pty;
  if (options->pty) {
    auto opened = Pty::open();
    if (!opened) {
      console.error(opened.error());
      return kExitFailure;
    }
    pty = std::move(*opened);
  }
  if (listener) console.announce("listening on " + listener->address());
  if (pty) console.announce("pty " + pty->path());

  Server server(**meter, *signals, console, std::move(listener), std::move(pty));
  server.run();
  return kExitOk;
}
