#include "postgresql/engine.hpp"

#include <fmt/format.h>

#include <chrono>
#include <thread>

namespace skinspec::store::postgresql {

using Kind = StoreError::Kind;

namespace {

bool try_writer_lock(Connection& writer, const std::string& bench) {
  auto lock = writer.prepare("SELECT pg_try_advisory_lock(?1::integer, hashtext(?2))");
  lock.bind(kWriterLockKey, bench);
  return lock.step() && lock.boolean(0);
}

// Whether backend `pid` holds `bench`'s writer lock (pg_locks shows a two-key lock with the
// keys as classid and objid, objsubid 2).
bool holds_writer_lock(Connection& writer, int pid, const std::string& bench) {
  auto holder = writer.prepare(
      "SELECT count(*) FROM pg_catalog.pg_locks WHERE locktype = 'advisory' AND granted AND pid = ?1 AND "
      "classid::bigint = ?2 AND objid::bigint = (hashtext(?3)::bigint & 4294967295) AND objsubid = 2");
  holder.bind(pid, kWriterLockKey, bench);
  const bool ours = holder.step() && holder.integer(0) > 0;
  holder.run();
  return ours;
}

// The writer lock, on a new writer connection. When this Store's previous writer connection
// broke, its backend may still be alive on the server, holding the lock (the server notices a
// vanished client only when it next reads from it, or by its keepalive): that backend, and only
// that one, is ended (waiting up to 5 s for it to go) and the lock taken again. Another
// program may hold the bench's lock for a moment while it recovers a bench it found silent
// (Store::recover_bench): asked again for up to 1 s before giving up.
// Every writer also shares the one-key lock on kWriterLockKey that skinspec before benches
// (schema 5) took alone: so an older skinspecd still writing the database keeps a newer one from
// migrating under it and recovering its jobs, and is kept out in turn.
void share_with_other_benches(Connection& writer, const std::string& bench) {
  auto shared = writer.prepare("SELECT pg_try_advisory_lock_shared(?1)");
  shared.bind(kWriterLockKey);
  if (shared.step() && shared.boolean(0)) return;
  shared.run();
  writer.prepare("SELECT pg_advisory_unlock(?1::integer, hashtext(?2))").bind(kWriterLockKey, bench).run();
  detail::fail(Kind::busy, "an older skinspecd, from before benches, has it open for writing");
}

void take_writer_lock(Connection& writer, int previous_backend, const std::string& bench) {
  for (int attempt = 0; attempt < 5; ++attempt) {
    if (try_writer_lock(writer, bench)) return share_with_other_benches(writer, bench);
    if (previous_backend != 0 && holds_writer_lock(writer, previous_backend, bench)) {
      // Ending that backend frees the lock for a moment before this connection takes it. This
      // program is alive: its heartbeat is made fresh first, so that no other program, seeing the
      // lock free and the heartbeat as old as the outage, takes that moment for its death.
      writer.prepare("UPDATE benches SET heartbeat_at = clock_timestamp() WHERE name = ?1").bind(bench).run();
      writer.prepare("SELECT pg_terminate_backend(?1, 5000)").bind(previous_backend).run();
      continue;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  detail::fail(Kind::busy, bench.empty() ? std::string("another program has it open for writing")
                                         : fmt::format("bench {} is already served by another program on this "
                                                       "database",
                                                       bench));
}

}  // namespace

// ---- PgEngine ----

PgEngine::PgEngine(const Target& target, bool writes, int max_readers, std::string bench)
    : target_(target), writes_(writes), bench_(std::move(bench)) {
  const ConnectSettings settings{.read_only = !writes};
  readers_.configure([target, settings] { return std::make_unique<Connection>(target, settings); }, max_readers,
                     [](const detail::Connection& c) { return static_cast<const Connection&>(c).broken(); });
}

PgEngine::~PgEngine() = default;

Connection& PgEngine::connect_writer() {
  if (writer_) lost_backend_ = writer_->backend_pid();
  writer_.reset();
  auto connection = std::make_unique<Connection>(target_, ConnectSettings{});
  take_writer_lock(*connection, lost_backend_, bench_);
  lost_backend_ = 0;
  writer_ = std::move(connection);
  return *writer_;
}

ConnectionLease PgEngine::writer() {
  if (!writes_) detail::fail(Kind::read_only, "the database was opened read-only");
  std::unique_lock lock(writer_mutex_);
  if (!writer_ || !writer_->still_connected()) connect_writer();
  lock.release();  // give_back unlocks it
  return ConnectionLease(*this, *writer_);
}

bool PgEngine::take_bench_for_transaction(detail::Connection& writer, const std::string& bench) {
  auto lock = writer.prepare("SELECT pg_try_advisory_xact_lock(?1::integer, hashtext(?2))");
  lock.bind(kWriterLockKey, bench);
  return lock.step() && lock.boolean(0);
}

void PgEngine::give_back(detail::Connection&) noexcept { writer_mutex_.unlock(); }

}  // namespace skinspec::store::postgresql
