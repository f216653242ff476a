#include "postgresql/engine.hpp"

namespace skinspec::store::postgresql {

using Kind = StoreError::Kind;

namespace {

// pg_try_advisory_lock's key for the database's one writer; the schema lock is 0x534B5350.
constexpr std::int64_t kWriterLockKey = 0x534B5351;

bool try_writer_lock(Connection& writer) {
  auto lock = writer.prepare("SELECT pg_try_advisory_lock(?1)");
  lock.bind(kWriterLockKey);
  return lock.step() && lock.boolean(0);
}

// The writer lock, on a new writer connection. When this Store's previous writer connection
// broke, its backend may still be alive on the server, holding the lock (the server notices a
// vanished client only when it next reads from it, or by its keepalive): that backend, and only
// that one, is ended (waiting up to 5 s for it to go) and the lock taken again.
void take_writer_lock(Connection& writer, int previous_backend) {
  if (try_writer_lock(writer)) return;
  if (previous_backend != 0) {
    auto holder = writer.prepare(
        "SELECT count(*) FROM pg_catalog.pg_locks WHERE locktype = 'advisory' AND granted AND pid = ?1 AND "
        "objid::bigint = ?2 AND classid::bigint = ?3");
    holder.bind(previous_backend, kWriterLockKey & 0xffffffff, kWriterLockKey >> 32);
    const bool ours = holder.step() && holder.integer(0) > 0;
    holder.run();
    if (ours) {
      writer.prepare("SELECT pg_terminate_backend(?1, 5000)").bind(previous_backend).run();
      if (try_writer_lock(writer)) return;
    }
  }
  detail::fail(Kind::busy, "another program has it open for writing");
}

}  // namespace

// ---- PgEngine ----

PgEngine::PgEngine(const Target& target, bool writes, int max_readers) : target_(target), writes_(writes) {
  const ConnectSettings settings{.read_only = !writes};
  readers_.configure([target, settings] { return std::make_unique<Connection>(target, settings); }, max_readers,
                     [](const detail::Connection& c) { return static_cast<const Connection&>(c).broken(); });
}

PgEngine::~PgEngine() = default;

Connection& PgEngine::connect_writer() {
  const int previous_backend = writer_ ? writer_->backend_pid() : 0;
  writer_.reset();
  auto connection = std::make_unique<Connection>(target_, ConnectSettings{});
  take_writer_lock(*connection, previous_backend);
  writer_ = std::move(connection);
  return *writer_;
}

ConnectionLease PgEngine::writer() {
  if (!writes_) detail::fail(Kind::read_only, "the database was opened read-only");
  std::unique_lock lock(writer_mutex_);
  if (!writer_ || writer_->broken()) connect_writer();
  lock.release();  // give_back unlocks it
  return ConnectionLease(*this, *writer_);
}

void PgEngine::give_back(detail::Connection&) noexcept { writer_mutex_.unlock(); }

}  // namespace skinspec::store::postgresql
