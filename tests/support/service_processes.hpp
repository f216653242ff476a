#pragma once
// Test helpers: skinspec-sim and skinspecd as background processes on loopback, each with the
// port it listens on (0 when it did not come up).

#include <chrono>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "skinspec/testkit/process.hpp"
#include "skinspec/testkit/store_samples.hpp"

namespace skinspec::testing {

struct ListeningProcess {
  std::unique_ptr<BackgroundProcess> process;
  unsigned short port = 0;
};

inline unsigned short port_after_colon(const std::string& line) {
  return static_cast<unsigned short>(std::stoi(line.substr(line.rfind(':') + 1)));
}

// The simulator as a meter measuring the forearm example under a white lamp, replying at once
// (or at `time_scale`), its power-on window never closing; `listen` is HOST:PORT (port 0: any
// free one), `extra` more options (faults).
inline ListeningProcess start_simulator(const ScratchDirectory& dir, const std::string& listen,
                                        const std::vector<std::string>& extra = {},
                                        const std::string& time_scale = "0") {
  const std::string white = dir.file("sim-white.csv");
  std::ofstream(white) << "wavelength_nm,white\n380,0.99\n780,0.99\n";
  std::vector<std::string> args{"--listen",      listen,
                                "--time-scale",  time_scale,
                                "--boot-window", "inf",
                                "--white",       white,
                                "--reflectance", std::string(SKINSPEC_TEST_DATA_DIR) + "/examples/forearm.csv"};
  args.insert(args.end(), extra.begin(), extra.end());
  ListeningProcess sim;
  sim.process = std::make_unique<BackgroundProcess>(std::string(SKINSPEC_TEST_BIN_DIR) + "/skinspec-sim", args);
  if (auto line = sim.process->wait_for_stdout_line("listening on ", std::chrono::seconds(20)))
    sim.port = port_after_colon(*line);
  return sim;
}

// skinspecd on any free loopback port with a database in `dir` and `args` added.
inline ListeningProcess start_daemon(const ScratchDirectory& dir, const std::vector<std::string>& args) {
  std::vector<std::string> all = {"--listen", "127.0.0.1:0", "--db", dir.file("lab.db"), "--log-level", "debug"};
  all.insert(all.end(), args.begin(), args.end());
  ListeningProcess daemon;
  daemon.process = std::make_unique<BackgroundProcess>(std::string(SKINSPEC_TEST_BIN_DIR) + "/skinspecd", all);
  if (auto line =
          daemon.process->wait_for_stdout_line("skinspecd listening on http://127.0.0.1:", std::chrono::seconds(30)))
    daemon.port = port_after_colon(*line);
  return daemon;
}

}  // namespace skinspec::testing
