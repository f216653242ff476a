#pragma once
// What opening a database read-write does about the work its last writer left unfinished, and
// what another bench's program does about the work of one that is gone.

#include <optional>
#include <string>

#include "db.hpp"
#include "skinspec/store/store.hpp"

namespace skinspec::store::detail {

// Whose unfinished work a recovery covers: every bench's (a SQLite file, which one program
// writes), or one bench's together with the jobs and sessions from before benches.
struct Owner {
  std::optional<std::string> bench;  // empty: every bench
  bool with_unowned = true;          // with a bench: also what was written before benches (bench '')
};

// Marks the sessions that were running when the owner's writer died as interrupted and fails
// the jobs it left queued or running (code `interrupted`), inside the caller's transaction.
RecoveryReport mark_interrupted(Connection& writer, RecoveryPolicy policy, const Owner& owner, Time now);

// What opening does: the owner's unpublished imports removed (staged_imports.hpp), `import_batch`
// measurements to a transaction, then the same as mark_interrupted in a transaction of its own
// (an import's job, still running, is failed as any other).
RecoveryReport recover(Connection& writer, RecoveryPolicy policy, const Owner& owner, Time now, int import_batch);

}  // namespace skinspec::store::detail
