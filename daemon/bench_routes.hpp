#pragma once
// The measurement jobs among the benches of one database (docs/store.md, "Benches"): a job for
// another bench's session is queued for that bench, a job queued here by another program is
// taken onto this program's board, and a queued job of another bench is cancelled through its
// record or a notice to its program.
//
// Locking: none. The bench's name and whether it routes are set once, before the supervisor
// starts, and only read afterwards; the live jobs are the board's.

#include <expected>
#include <string>

#include "skinspec/api/errors.hpp"
#include "skinspec/api/job_board.hpp"
#include "skinspec/store/store.hpp"

namespace skinspec::daemon {

class BenchRoutes {
 public:
  BenchRoutes(store::Store& db, api::JobBoard& board) : db_(db), board_(board) {}

  // This bench's name, and whether sessions of other benches are theirs to measure in (several
  // programs on one PostgreSQL database) rather than this one's (a SQLite file).
  void set_bench(std::string name, bool routes);
  const std::string& bench() const { return bench_; }

  // Whether the session's measurements are another bench's to make.
  bool owned_elsewhere(const store::Session& session) const;
  // Whether the job is another bench's to run, or queued and not yet taken in here.
  bool runs_elsewhere(const store::Job& job) const;
  // Queued for the owner while it runs, so that it measures with its own meter; refused while it
  // does not, so that a job never waits for a bench that may not come back.
  std::expected<store::CreatedJob, api::ApiError> submit_elsewhere(const store::Session& session, store::Job job);
  std::expected<store::Job, api::ApiError> cancel_elsewhere(const store::Job& job);
  // A job another program queued for this bench: queued on the board, in id order, unless known.
  void adopt(const store::Job& job);

 private:
  store::Store& db_;
  api::JobBoard& board_;
  std::string bench_;
  bool routes_ = false;
};

}  // namespace skinspec::daemon
