#pragma once
// What a Store runs on: an engine hands out connections, one to write with and pooled ones to
// read with, and does what differs between engines beyond the SQL (sqlite/engine.hpp).

#include <string>
#include <utility>

#include "db.hpp"

namespace skinspec::store::detail {

// A connection borrowed from an engine, given back when the lease ends.
class ConnectionLease {
 public:
  class Owner {
   public:
    virtual void give_back(Connection& connection) noexcept = 0;

   protected:
    ~Owner() = default;
  };

  ConnectionLease(Owner& owner, Connection& connection) : owner_(&owner), connection_(&connection) {}
  ~ConnectionLease() {
    if (owner_) owner_->give_back(*connection_);
  }
  ConnectionLease(ConnectionLease&& other) noexcept
      : owner_(std::exchange(other.owner_, nullptr)), connection_(other.connection_) {}
  ConnectionLease(const ConnectionLease&) = delete;
  ConnectionLease& operator=(const ConnectionLease&) = delete;
  ConnectionLease& operator=(ConnectionLease&&) = delete;

  Connection& operator*() const { return *connection_; }
  Connection* operator->() const { return connection_; }

 private:
  Owner* owner_;
  Connection* connection_;
};

class Engine {
 public:
  virtual ~Engine() = default;
  virtual Dialect dialect() const = 0;
  // The connection writes go through, for as long as the lease lasts (SQLite: the one writer,
  // its lock held). Throws read_only when the Store was opened to read.
  virtual ConnectionLease writer() = 0;
  virtual ConnectionLease reader() = 0;
  // Called after each read, and when a read failed: throws when what was read cannot be trusted
  // (SQLite: a file read as immutable that changed meanwhile).
  virtual void after_read() const {}
  // Inside a write transaction on `writer`: whether no other program writes for `bench`, which
  // stays so until the transaction ends (PostgreSQL: its writer lock taken for the transaction).
  // A SQLite file has one writer, this one.
  virtual bool take_bench_for_transaction(Connection& writer, const std::string& bench) {
    (void)writer, (void)bench;
    return true;
  }
};

}  // namespace skinspec::store::detail
