#include "postgresql/engine.hpp"

namespace skinspec::store::postgresql {

using Kind = StoreError::Kind;

namespace {

// pg_try_advisory_lock's key for the database's one writer; the schema lock is 0x534B5350.
constexpr std::int64_t kWriterLockKey = 0x534B5351;

void take_writer_lock(Connection& writer) {
  auto lock = writer.prepare("SELECT pg_try_advisory_lock(?1)");
  lock.bind(kWriterLockKey);
  if (!lock.step() || !lock.boolean(0)) detail::fail(Kind::busy, "another program has it open for writing");
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
  writer_.reset();
  auto connection = std::make_unique<Connection>(target_, ConnectSettings{});
  take_writer_lock(*connection);
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
