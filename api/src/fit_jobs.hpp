#pragma once
// Jobs that fit spectra already in hand instead of measuring them: a file of spectra imported
// into a session (records::import_file) and stored measurements fitted again (records::refit).
// They run one at a time, in the order posted, on a thread of their own; each spreads its fits
// over every core, so two of them at once would only share the cores. Their records are the
// store's jobs (kinds import and refit); their live place and progress are kept here.

#include <condition_variable>
#include <deque>
#include <expected>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <variant>

#include "skinspec/api/errors.hpp"
#include "skinspec/api/job_watch.hpp"
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

class FitJobs final : public JobWatch {
 public:
  FitJobs(store::Store& store, const Fitter& fitter);
  // Stops: the running job at its next step and the queued ones end cancelled (`stopped`).
  ~FitJobs() override;
  FitJobs(const FitJobs&) = delete;
  FitJobs& operator=(const FitJobs&) = delete;

  // Queues an import into an open session; an idempotency key seen before returns that job.
  std::expected<store::CreatedJob, ApiError> submit_import(ImportUpload upload, const std::string& idempotency_key);
  // Queues a refit of every session's measurements, or one session's.
  std::expected<store::CreatedJob, ApiError> submit_refit(const records::RefitRequest& request,
                                                          const std::string& idempotency_key);
  // Cancels a queued job, or asks the running one to stop at its next step; the job as it is
  // afterwards. A job of another program is refused (409): that program runs it.
  std::expected<store::Job, ApiError> cancel(store::Id job_id);

  std::optional<JobProgress> progress(store::Id job_id) const override;
  std::uint64_t changes() const override;
  std::uint64_t wait_for_change(std::uint64_t seen, std::chrono::milliseconds timeout,
                                const std::atomic<bool>& abandoned) const override;
  void wake_waiters() const override;

 private:
  struct Queued {
    store::Id id = 0;
    std::variant<ImportUpload, records::RefitRequest> work;
  };
  // What a job's observer tells the worker: go on, or stop (and why).
  enum class Verdict { go_on, cancelled, stopped };

  std::expected<store::CreatedJob, ApiError> enqueue(store::Job job,
                                                     std::variant<ImportUpload, records::RefitRequest> work);
  void work();
  void run(const Queued& job);
  void run_import(store::Id id, const ImportUpload& upload);
  void run_refit(store::Id id, const records::RefitRequest& request);
  // Records the running job's progress; whether it should go on.
  Verdict report(store::Id id, const JobProgress& progress);
  // The job's record ended, then its live progress dropped.
  void end(store::Id id, const store::JobUpdate& update);
  // Its live progress dropped (kept as a failure when its end could not be recorded).
  void release(store::Id id, std::optional<store::JobError> unrecorded = std::nullopt);
  void changed();  // with mutex_ held
  // The bytes a queued job holds in memory: an import's file.
  static std::size_t held_bytes(const std::variant<ImportUpload, records::RefitRequest>& work);

  // Files queued or being imported, at most (they wait in memory).
  static constexpr std::size_t kMaxHeldBytes = std::size_t{1} << 30;

  store::Store& store_;
  const Fitter& fitter_;
  mutable std::mutex mutex_;
  mutable std::condition_variable change_;  // any job's change, for followers
  std::condition_variable wake_;            // work queued, or stopping, for the worker
  std::deque<Queued> queue_;
  std::map<store::Id, JobProgress> live_;  // queued and running jobs
  store::Id running_ = 0;                  // 0: none
  bool cancel_running_ = false;
  bool stopping_ = false;
  std::uint64_t changes_ = 0;
  std::size_t held_bytes_ = 0;  // of the queued and running jobs' files
  std::thread worker_;          // last: started once everything above exists
};

}  // namespace skinspec::api
