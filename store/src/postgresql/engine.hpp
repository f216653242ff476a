#pragma once
// The PostgreSQL engine: one writer connection behind a mutex, holding its bench's writer lock
// (a session advisory lock: one skinspecd writes for a bench at a time, as one writes a SQLite
// file), and a pool of read connections. A connection the server dropped is replaced
// when next asked for, so a restarted server is reached again on the next request.

#include <memory>
#include <mutex>
#include <string>

#include "../connection_pool.hpp"
#include "../engine.hpp"
#include "postgresql/connection.hpp"

namespace skinspec::store::postgresql {

using detail::ConnectionLease;

// The first key of a bench's writer lock, pg_try_advisory_lock(key, hashtext(bench)); the
// schema lock is 0x534B5350.
inline constexpr std::int64_t kWriterLockKey = 0x534B5351;

class PgEngine final : public detail::Engine, private ConnectionLease::Owner {
 public:
  // `writes`: this Store may write (it connects its writer in connect_writer()).
  PgEngine(const Target& target, bool writes, int max_readers, std::string bench);
  ~PgEngine() override;
  PgEngine(const PgEngine&) = delete;
  PgEngine& operator=(const PgEngine&) = delete;

  Dialect dialect() const override { return Dialect::postgresql; }
  ConnectionLease writer() override;
  ConnectionLease reader() override { return readers_.acquire(); }
  bool take_bench_for_transaction(detail::Connection& writer, const std::string& bench) override;

  // Connects the writer and takes the bench's writer lock (throws busy when another program
  // holds it).
  Connection& connect_writer();

 private:
  void give_back(detail::Connection& connection) noexcept override;

  Target target_;
  bool writes_;
  std::string bench_;
  std::mutex writer_mutex_;
  std::unique_ptr<Connection> writer_;
  // The backend of the last writer connection found broken, until the writer lock is taken
  // again: through an outage of several failed connects it may still hold the lock.
  int lost_backend_ = 0;
  detail::ConnectionPool readers_;
};

}  // namespace skinspec::store::postgresql
