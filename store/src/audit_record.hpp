#pragma once
// The audit trail's side inside the store: the row a write transaction records for its actor.

#include <string_view>

#include "db.hpp"

namespace skinspec::store::detail {

// Whether this thread's writes are recorded now: an AuditScope lives and recording is not paused.
// Asked first, so that a write nobody asked for takes no time from the store's clock.
bool recording_changes();
// Records `change` for this thread's actor, on `c` in its open write transaction.
void record_change(Connection& c, std::string_view change, Time at);

// Writes made while one lives are no change of the records (a notification between programs):
// not recorded.
class NotAudited {
 public:
  NotAudited();
  ~NotAudited();
  NotAudited(const NotAudited&) = delete;
  NotAudited& operator=(const NotAudited&) = delete;

 private:
  bool was_;
};

}  // namespace skinspec::store::detail
