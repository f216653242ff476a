// The benches writing one database: their heartbeats, the jobs queued for each, the recovery of
// one found gone, and the notifications between them (docs/store.md, "Benches").

#include <fmt/format.h>

#include "audit_record.hpp"
#include "codec.hpp"
#include "postgresql/subscription.hpp"
#include "postgresql/target.hpp"
#include "recovery.hpp"
#include "rows.hpp"
#include "store_impl.hpp"

namespace skinspec::store {

using detail::Connection;

const std::string& Store::bench() const { return impl_->options.bench; }

Result<void> Store::beat(const Bench& b) {
  return impl_->write("recording the bench's heartbeat", [&](Connection& c) {
    detail::check_json_object(b.instrument, "the bench's instrument state");
    if (b.lease <= std::chrono::milliseconds::zero())
      detail::fail(StoreError::Kind::invalid_argument, "a bench's lease must be positive");
    c.prepare(
         "INSERT INTO benches (name, host, pid, started_at, heartbeat_at, lease_ms, instrument, stopped_at) "
         "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, NULL) ON CONFLICT (name) DO UPDATE SET host = excluded.host, "
         "pid = excluded.pid, started_at = excluded.started_at, heartbeat_at = excluded.heartbeat_at, "
         "lease_ms = excluded.lease_ms, instrument = excluded.instrument, stopped_at = NULL")
        .bind(impl_->options.bench, b.host, b.pid, b.started_at, impl_->database_now(c),
              static_cast<std::int64_t>(b.lease.count()), b.instrument)
        .run();
  });
}

Result<void> Store::leave_bench() {
  return impl_->write("recording that the bench stopped", [&](Connection& c) {
    c.prepare("UPDATE benches SET stopped_at = ?2 WHERE name = ?1").bind(impl_->options.bench, impl_->now()).run();
  });
}

Result<std::vector<Bench>> Store::benches() const {
  return impl_->read_one("listing benches", [&](Connection& c) {
    static const std::string sql = fmt::format("SELECT {} FROM benches ORDER BY name", detail::kBenchColumns);
    return detail::all(c, sql, detail::read_bench);
  });
}

Result<Time> Store::database_time() const {
  return impl_->read_one("reading the database's clock", [&](Connection& c) { return impl_->database_now(c); });
}

Result<std::vector<Job>> Store::queued_jobs() const {
  return impl_->read_one("listing the bench's queued jobs", [&](Connection& c) {
    static const std::string sql =
        fmt::format("SELECT {} FROM jobs WHERE bench = ?1 AND state = 'queued' ORDER BY id", detail::kJobColumns);
    return detail::all(c, sql, detail::read_job, impl_->options.bench);
  });
}

Result<RecoveryReport> Store::recover_bench(const std::string& name) {
  return impl_->write(fmt::format("recovering the jobs of bench {}", name), [&](Connection& c) {
    if (name == impl_->options.bench || !impl_->engine->take_bench_for_transaction(c, name)) return RecoveryReport{};
    static const std::string sql = fmt::format("SELECT {} FROM benches WHERE name = ?1", detail::kBenchColumns);
    auto row = c.prepare(sql);
    row.bind(name);
    if (!row.step()) return RecoveryReport{};
    const Bench bench = detail::read_bench(row);
    row.run();
    const auto now = impl_->database_now(c);
    if (bench_running(bench, now)) return RecoveryReport{};
    return detail::mark_interrupted(c, RecoveryPolicy::sessions_with_active_jobs, {name, false}, now);
  });
}

Result<void> Store::notify(const std::string& channel, const std::string& payload) {
  if (impl_->backend == Backend::sqlite) {
    impl_->hub->publish({channel, payload});
    return {};
  }
  const detail::NotAudited between_programs;
  return impl_->write(fmt::format("notifying {}", channel), [&](Connection& c) {
    // Nothing durable is written: the commit need not wait for the disk.
    c.prepare("SET LOCAL synchronous_commit TO off").run();
    c.prepare("SELECT pg_notify(?1, ?2)").bind(channel, payload).run();
  });
}

Result<std::unique_ptr<Subscription>> Store::subscribe(const std::vector<std::string>& channels) const {
  return detail::guarded("listening for notifications", [&] {
    if (impl_->backend == Backend::sqlite) return impl_->hub->subscribe(channels);
    return postgresql::subscribe(postgresql::parse_target(impl_->path), channels);
  });
}

}  // namespace skinspec::store
