#pragma once
// skinspec-sim as the meter (the example forearm under a lamp, a flat white) and skinspecd
// driving it, both on loopback in a scratch directory; stopped with SIGTERM on destruction.

#include <csignal>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "support/process.hpp"
#include "support/store_samples.hpp"

namespace skinspec::testing {

class DaemonRig {
 public:
  // `time_scale` 0: the simulated meter answers at once; 0.05: a reading takes about 0.35 s.
  DaemonRig(const ScratchDirectory& dir, double time_scale) {
    using namespace std::chrono_literals;
    const std::string white = dir.file("white.csv");
    std::ofstream(white) << "wavelength_nm,white\n380,0.99\n780,0.99\n";
    sim_ = std::make_unique<BackgroundProcess>(
        std::string(SKINSPEC_TEST_BIN_DIR) + "/skinspec-sim",
        std::vector<std::string>{"--listen", "127.0.0.1:0", "--time-scale", std::to_string(time_scale), "--boot-window", "inf",
                                 "--white", white, "--reflectance", std::string(SKINSPEC_TEST_DATA_DIR) + "/examples/forearm.csv"});
    const auto sim_line = sim_->wait_for_stdout_line("listening on ", 20s);
    if (!sim_line) return;
    daemon_ = std::make_unique<BackgroundProcess>(
        std::string(SKINSPEC_TEST_BIN_DIR) + "/skinspecd",
        std::vector<std::string>{"--listen", "127.0.0.1:0", "--db", dir.file("lab.db"), "--device",
                                 "tcp:127.0.0.1:" + sim_line->substr(sim_line->rfind(':') + 1)});
    if (auto line = daemon_->wait_for_stdout_line("skinspecd listening on http://127.0.0.1:", 30s))
      port_ = static_cast<unsigned short>(std::stoi(line->substr(line->rfind(':') + 1)));
  }
  ~DaemonRig() {
    for (auto* process : {daemon_.get(), sim_.get()}) {
      if (process == nullptr) continue;
      process->send_signal(SIGTERM);
      (void)process->wait(std::chrono::seconds(20));
    }
  }
  DaemonRig(const DaemonRig&) = delete;
  DaemonRig& operator=(const DaemonRig&) = delete;

  // Stops skinspecd (SIGTERM) and waits for it to end.
  ProcessResult stop_daemon() {
    daemon_->send_signal(SIGTERM);
    return daemon_->wait(std::chrono::seconds(20));
  }
  // 0 when the daemon did not come up.
  unsigned short port() const { return port_; }
  std::string url() const { return "http://127.0.0.1:" + std::to_string(port_); }
  // What the programs wrote, for assertion messages.
  std::string logs() const {
    return (daemon_ ? "skinspecd: " + daemon_->err() : std::string()) + (sim_ ? "\nskinspec-sim: " + sim_->err() : std::string());
  }

 private:
  std::unique_ptr<BackgroundProcess> sim_, daemon_;
  unsigned short port_ = 0;
};

}  // namespace skinspec::testing
