#pragma once
// The PostgreSQL engine: one writer connection behind a mutex, holding the database's writer
// lock (a session advisory lock: one skinspecd writes a database at a time, as with SQLite's
// lock file), and a pool of read connections. A connection the server dropped is replaced
// when next asked for, so a restarted server is reached again on the next request.

#include <memory>
#include <mutex>

#include "../connection_pool.hpp"
#include "../engine.hpp"
#include "postgresql/connection.hpp"

namespace skinspec::store::postgresql {

using detail::ConnectionLease;

class PgEngine final : public detail::Engine, private ConnectionLease::Owner {
 public:
  // `writes`: this Store may write (it connects its writer in connect_writer()).
  PgEngine(const Target& target, bool writes, int max_readers);
  ~PgEngine() override;
  PgEngine(const PgEngine&) = delete;
  PgEngine& operator=(const PgEngine&) = delete;

  Dialect dialect() const override { return Dialect::postgresql; }
  ConnectionLease writer() override;
  ConnectionLease reader() override { return readers_.acquire(); }

  // Connects the writer and takes the writer lock (throws busy when another program holds it).
  Connection& connect_writer();

 private:
  void give_back(detail::Connection& connection) noexcept override;

  Target target_;
  bool writes_;
  std::mutex writer_mutex_;
  std::unique_ptr<Connection> writer_;
  detail::ConnectionPool readers_;
};

}  // namespace skinspec::store::postgresql
