// The audit trail: the actor of this thread's writes, its row written in each write's
// transaction (Store::Impl::write), and the trail read back.

#include "skinspec/store/audit.hpp"

#include <fmt/format.h>

#include <limits>

#include "audit_record.hpp"
#include "rows.hpp"
#include "store_impl.hpp"

namespace skinspec::store {

namespace {

thread_local const Actor* current_actor = nullptr;
thread_local bool recording_paused = false;

}  // namespace

AuditScope::AuditScope(Actor actor) : actor_(std::move(actor)) { current_actor = &actor_; }
AuditScope::~AuditScope() { current_actor = nullptr; }

namespace detail {

NotAudited::NotAudited() : was_(recording_paused) { recording_paused = true; }
NotAudited::~NotAudited() { recording_paused = was_; }

bool recording_changes() { return current_actor != nullptr && !recording_paused; }

void record_change(Connection& c, std::string_view change, Time at) {
  if (!recording_changes()) return;
  c.prepare("INSERT INTO audit (at, token, address, request, change) VALUES (?1, ?2, ?3, ?4, ?5)")
      .bind(at, current_actor->token, current_actor->address, current_actor->request, std::string(change))
      .run();
}

}  // namespace detail

Result<std::vector<AuditEntry>> Store::audit(std::optional<Id> before, int limit) const {
  return impl_->read_one("reading the audit trail", [&](detail::Connection& c) {
    if (limit < 1 || limit > 1000) detail::fail(StoreError::Kind::invalid_argument, "the limit must be 1-1000");
    static const std::string sql =
        fmt::format("SELECT {} FROM audit WHERE id < ?1 ORDER BY id DESC LIMIT ?2", detail::kAuditColumns);
    return detail::all(c, sql, detail::read_audit_entry, before.value_or(std::numeric_limits<Id>::max()),
                       static_cast<std::int64_t>(limit));
  });
}

}  // namespace skinspec::store
