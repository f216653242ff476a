#pragma once
// Jobs that fit spectra already in hand instead of measuring them: a file of spectra imported
// into a session (records::import_file), stored measurements fitted again (records::refit) and
// every pixel of a spectral image mapped (map_jobs.*).
// They run one at a time, in the order posted, on a thread of their own; each spreads its fits
// over every core, so two of them at once would only share the cores. Their records are the
// store's jobs (kinds import and refit); their live place and progress are the JobBoard's.

#include <expected>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <variant>

#include "skinspec/api/errors.hpp"
#include "skinspec/api/job_board.hpp"
#include "map_jobs.hpp"
#include "skinspec/fit/fitter.hpp"
#include "skinspec/records/import.hpp"
#include "skinspec/records/refit.hpp"
#include "skinspec/store/store.hpp"

namespace skinspec::api {

// A file sent to be imported.
struct ImportUpload {
  store::Id session_id = 0;
  std::string bytes;   // the file as sent
  std::string source;  // its name, kept with each spectrum as provenance
  records::ImportFormat format = records::ImportFormat::csv;
  ScaleRequest scale = ScaleRequest::automatic;  // how a CSV file writes its values
};

// The executor of imports and refits on the board's fitting lane: it writes their records and
// runs them; their places, progress and cancel requests are the board's.
//
// Locking: mutex_ guards the queued and running jobs' work (an import's file) and the bytes it
// holds, nothing else; the board may be called with it held (the board's lock is the last).
class FitJobs final {
 public:
  FitJobs(store::Store& store, const Fitter& fitter, JobBoard& board);
  // Stops: the running job at its next step and the queued ones end cancelled (`stopped`).
  ~FitJobs();
  FitJobs(const FitJobs&) = delete;
  FitJobs& operator=(const FitJobs&) = delete;

  // Queues an import into an open session; an idempotency key seen before returns that job.
  std::expected<store::CreatedJob, ApiError> submit_import(ImportUpload upload, const std::string& idempotency_key);
  // Queues a refit of every session's measurements, or one session's.
  std::expected<store::CreatedJob, ApiError> submit_refit(const records::RefitRequest& request,
                                                          const std::string& idempotency_key);
  // Queues a checked map (prepare_map); its scratch directory goes with the job.
  std::expected<store::CreatedJob, ApiError> submit_map(MapRequest request, const std::string& idempotency_key);
  // Cancels a queued job, or asks the running one to stop at its next step; the job as it is
  // afterwards. A job of another program is refused (409): that program runs it.
  std::expected<store::Job, ApiError> cancel(store::Id job_id);

  // What knows the live progress of the jobs run here.
  const JobWatch& jobs() const { return board_; }

 private:
  using Work = std::variant<ImportUpload, records::RefitRequest, MapRequest>;

  std::expected<store::CreatedJob, ApiError> enqueue(JobKind kind, store::Job job, Work work);
  // Counts a job's file against kMaxHeldBytes; the refusal when there is no room.
  std::optional<ApiError> hold(std::size_t bytes);
  // The job's work, no longer held here.
  std::optional<Work> take_work(store::Id id);
  void work();
  void run(store::Id id, Work& work);
  void run_import(store::Id id, const ImportUpload& upload);
  void run_refit(store::Id id, const records::RefitRequest& request);
  // map_jobs.cpp: the cube mapped in its scratch directory, then stored with the job's end.
  void run_map(store::Id id, MapRequest& request);
  // The job's record ended, then its live progress dropped.
  void end(store::Id id, const store::JobUpdate& update);
  // A map's end: its scratch directory removed first, so that a job seen ended has left no file.
  void end_map(store::Id id, MapRequest& request, const store::JobUpdate& update);
  // Its live progress dropped (kept as a failure when its end could not be recorded).
  void release(store::Id id, std::optional<store::JobError> unrecorded = std::nullopt);
  // The bytes a queued job holds: an import's file in memory, a map's upload on disk.
  static std::size_t held_bytes(const Work& work);

  // Files queued or being imported or mapped, at most (they wait in memory or on disk).
  static constexpr std::size_t kMaxHeldBytes = std::size_t{1} << 30;

  store::Store& store_;
  const Fitter& fitter_;
  JobBoard& board_;
  std::mutex mutex_;
  std::map<store::Id, Work> work_;  // of the queued and running jobs
  std::size_t held_bytes_ = 0;      // of the queued and running jobs' files
  std::thread worker_;              // last: started once everything above exists
};

}  // namespace skinspec::api
