#pragma once
// The audit trail (docs/store.md, "Audit trail"): who asked for each change of the database,
// recorded in the change's own transaction, so a change rolled back leaves no trace and a change
// committed always has one.

#include <string>

#include "skinspec/store/types.hpp"

namespace skinspec::store {

// Whom a change is made for.
struct Actor {
  std::string token;    // the name of the token the request came with; empty: none was asked for
  std::string address;  // the client's address
  std::string request;  // what it asked: "POST /api/v1/sessions/3/measurements"
};

// While one lives, every write transaction this thread commits records one audit row with its
// actor and the change (the store's own words for it: "creating a job", "updating job 7").
// Work done later on other threads for the same request (a job's readings and fits) is the
// service's own, and is not recorded; the job it runs was recorded when it was made. Scopes do
// not nest.
class AuditScope {
 public:
  explicit AuditScope(Actor actor);
  ~AuditScope();
  AuditScope(const AuditScope&) = delete;
  AuditScope& operator=(const AuditScope&) = delete;

 private:
  Actor actor_;
};

// One recorded change, as GET /api/v1/audit shows it.
struct AuditEntry {
  Id id = 0;
  Time at{};
  std::string token, address, request, change;
};

}  // namespace skinspec::store
