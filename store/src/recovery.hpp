#pragma once
// What opening a database read-write does about the work its last writer left unfinished.

#include "db.hpp"
#include "skinspec/store/store.hpp"

namespace skinspec::store::detail {

// Marks the sessions that were running when the last writer died as interrupted and fails the
// jobs it left queued or running, in one transaction.
RecoveryReport recover(Connection& writer, RecoveryPolicy policy, Time now);

}  // namespace skinspec::store::detail
