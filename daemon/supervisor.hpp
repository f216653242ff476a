#pragma once
// The instrument supervisor: the acquisition the router sees (api::Acquisition), made of three
// parts with one job each: the ConnectionKeeper owns the one meter named by --device and keeps
// it connected (docs/architecture.md, "The instrument connection"); the MeasurementExecutor
// runs measurement jobs one at a time on the job board's instrument lane; BenchRoutes sends the
// jobs of other benches' sessions to them and takes in theirs for this one.
//
// Locking: none of its own. Each part holds its own rule (in its header); the job board is
// shared with the imports and refits and its lock is always the last taken.

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "skinspec/api/acquisition.hpp"
#include "skinspec/api/job_board.hpp"
#include "skinspec/drivers/open_instrument.hpp"
#include "skinspec/fit/fitter.hpp"
#include "skinspec/store/store.hpp"
#include "bench_routes.hpp"
#include "connection_keeper.hpp"
#include "measure_policy.hpp"
#include "measurement_executor.hpp"

namespace skinspec::daemon {

class Supervisor final : public api::Acquisition {
 public:
  using ConnectionSettings = ConnectionKeeper::Settings;

  // `model`: the meter --model names, or auto (found out when connecting). `board`: where the
  // jobs live, shared with the router's imports and refits; a board of its own when null.
  Supervisor(std::string device, store::Store& db, const Fitter& fitter, drivers::ModelChoice model = {},
             std::shared_ptr<api::JobBoard> board = nullptr);
  ~Supervisor() override;
  Supervisor(const Supervisor&) = delete;
  Supervisor& operator=(const Supervisor&) = delete;

  // What jobs do with rejected readings and old or changed whites; before start().
  void set_policy(const MeasurePolicy& policy) { executor_.set_policy(policy); }
  // Starts keeping the instrument connected in the background: call once, before start().
  // Without it, the supervisor connects only when a job needs the meter.
  void start_connection(ConnectionSettings settings) { keeper_.start(std::move(settings)); }
  // Starts the worker thread; stop() cancels the running job, marks queued ones cancelled, joins
  // it and the connector, and disconnects the meter (which leaves remote mode: Q).
  void start() { executor_.start(); }
  void stop();
  // A USB adapter came or went: a reconnect attempt at once, or the instrument marked lost.
  void on_usb_event(const drivers::UsbDeviceEvent& event) { keeper_.on_usb_event(event); }

  // ---- Benches (bench_routes.hpp; docs/store.md, "Benches") ----

  // This bench's name, and whether sessions of other benches are theirs to measure in. Before
  // start().
  void set_bench(std::string name, bool routes) { routes_.set_bench(std::move(name), routes); }
  // A job another program queued for this bench: queued here, in id order, unless known already.
  void adopt(const store::Job& job) { routes_.adopt(job); }
  // Another bench's job as its owner published it: its progress, or nullopt once it ended.
  void note_remote(store::Id job_id, std::optional<api::JobProgress> progress) {
    board_->note_remote(job_id, std::move(progress));
  }
  // This bench's queued and running jobs with their positions and progress, and those that
  // ended since the last call, to publish.
  using LocalJobs = api::JobBoard::LaneJobs;
  LocalJobs local_jobs() { return board_->take_lane_jobs(api::JobLane::instrument); }
  // Jobs of this program whose end the database refused, ended in their records as interrupted
  // now that it takes writes again.
  void record_unrecorded_ends();
  // Other benches' jobs shown live here.
  std::vector<store::Id> remote_jobs() const { return board_->remote_jobs(); }
  // A cancel asked for through another program, of a job this one may be running.
  void cancel_here(store::Id job_id);

  // ---- api::Acquisition ----

  const api::JobWatch& jobs() const override { return *board_; }
  nlohmann::json instrument_status() const override;
  nlohmann::json ports() const override;
  std::expected<store::CreatedJob, api::ApiError> submit(store::Id session_id, const api::MeasureRequest& request,
                                                         const std::string& idempotency_key) override;
  std::expected<store::Job, api::ApiError> cancel(store::Id job_id) override;

 private:
  store::Store& db_;
  const std::shared_ptr<api::JobBoard> board_;
  ConnectionKeeper keeper_;
  MeasurementExecutor executor_;
  BenchRoutes routes_;
};

}  // namespace skinspec::daemon
