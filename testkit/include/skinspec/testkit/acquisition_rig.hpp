#pragma once
// Acquisition with real processes on loopback: skinspec-sim as the meter and skinspecd driving
// it, each restartable (the daemon on the same database, the simulator on the same port), and
// the few HTTP calls every acquisition test makes.

#include <csignal>
#include <chrono>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "skinspec/testkit/process.hpp"

namespace skinspec::testing {

struct RigOptions {
  std::string bin_dir;   // where skinspecd and skinspec-sim are
  std::string data_dir;  // the source tree's data/ (for the example forearm spectrum)
  std::string work_dir;  // the database and the white standard's file go here
  std::string db;        // the store skinspecd is given (--db); empty: work_dir/lab.db
  // Added to the simulator's: time scale 0 (unless given here), a power-on window that never closes, a flat 0.99
  // white standard measured first, then the forearm example's subjects.
  std::vector<std::string> sim_args;
  bool default_scenes = true;                   // false: sim_args name the readings' source
  std::vector<std::string> daemon_args;         // added to the daemon's (log level debug unless given)
  std::vector<std::string> daemon_environment;  // "NAME=VALUE" for the daemon alone
};

#ifdef SKINSPEC_TEST_BIN_DIR
// A test program's rig: the programs of the build tree, the data of the source tree.
inline RigOptions rig_options(const std::string& work_dir, std::vector<std::string> sim_args,
                              std::vector<std::string> daemon_args = {}) {
  RigOptions options;
  options.bin_dir = SKINSPEC_TEST_BIN_DIR;
  options.data_dir = SKINSPEC_TEST_DATA_DIR;
  options.work_dir = work_dir;
  options.sim_args = std::move(sim_args);
  options.daemon_args = std::move(daemon_args);
  return options;
}
// The same with the simulator at `time_scale` (0: it answers at once; 0.05: a reading takes
// about 0.35 s).
inline RigOptions rig_options(const std::string& work_dir, double time_scale) {
  return rig_options(work_dir, {"--time-scale", std::to_string(time_scale)});
}
#endif

class AcquisitionRig {
 public:
  explicit AcquisitionRig(RigOptions options);
  ~AcquisitionRig();
  AcquisitionRig(const AcquisitionRig&) = delete;
  AcquisitionRig& operator=(const AcquisitionRig&) = delete;

  // Whether both came up (the ports are 0 otherwise); what they wrote, for failure messages.
  bool ready() const { return port != 0 && sim_port != 0; }
  std::string logs() const;

  std::string url() const { return "http://127.0.0.1:" + std::to_string(port); }
  // Stops skinspecd with `signal` and waits for it to end; how it ended.
  ProcessResult stop_daemon(int signal = SIGTERM);
  // Starts skinspecd again on the same database (after the test stopped or killed it).
  void restart_daemon(std::vector<std::string> extra_args = {});
  // Starts skinspec-sim again on the port the daemon knows.
  void restart_sim();

  std::string db_path() const { return options_.db.empty() ? options_.work_dir + "/lab.db" : options_.db; }

  std::unique_ptr<BackgroundProcess> sim, daemon;
  unsigned short sim_port = 0, port = 0;

 private:
  void start_sim(const std::string& listen);
  void start_daemon(const std::vector<std::string>& extra_args);
  RigOptions options_;
};

// The first subject of a spectra CSV file (the simulator's --reflectance) as the simulator puts
// it on a meter's grid: linearly interpolated onto first_nm..last_nm by step_nm, the ends held.
std::vector<double> first_subject_on_grid(const std::string& csv_path, int first_nm, int last_nm, int step_nm);

using Headers = std::vector<std::pair<std::string, std::string>>;

// "/api/v1/sessions/{id}".
inline std::string session_path(long long session) { return "/api/v1/sessions/" + std::to_string(session); }
// A new session on the forearm; its id (0 when refused).
long long new_session(unsigned short port, const std::string& subject);
// POST /api/v1/sessions/{id}/measurements; the accepted job (202, or 200 for a repeated key).
nlohmann::json submit(unsigned short port, long long session, const nlohmann::json& body, const Headers& headers = {});
// Polls GET /api/v1/jobs/{id} until it leaves queued and running (or `limit` passes).
nlohmann::json wait_for_job(unsigned short port, const nlohmann::json& accepted,
                            std::chrono::milliseconds limit = std::chrono::seconds(60));
nlohmann::json get_json(unsigned short port, const std::string& target);

}  // namespace skinspec::testing
