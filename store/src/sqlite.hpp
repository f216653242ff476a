#pragma once
// A thin layer over the SQLite C API for the store: connections with a cache of prepared
// statements, statements bound by position, transactions that roll back unless committed.
// Inside the library a failure is thrown as Failure; the public methods return it.

#include <sqlite3.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>

#include "skinspec/store/types.hpp"

namespace skinspec::store::detail {

struct Failure {
  StoreError error;
};

[[noreturn]] void fail(StoreError::Kind kind, std::string message, int sqlite_code = 0);
StoreError::Kind kind_of_sqlite_code(int extended_code);

// Raw bytes to bind as a BLOB (text binds as TEXT).
struct Blob {
  std::string_view bytes;
};
struct Null {};

class Connection;

// One use of a cached prepared statement: bind, step, read columns. Resets the statement and
// clears its bindings when it goes out of scope, so the next use starts clean.
class Statement {
 public:
  Statement(Connection& connection, sqlite3_stmt* stmt) : connection_(&connection), stmt_(stmt) {}
  ~Statement();
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  // Binds ?1, ?2, ... in order.
  template <typename... Args>
  Statement& bind(const Args&... args) {
    int index = 0;
    (bind_one(++index, args), ...);
    return *this;
  }

  bool step();  // true: a row is ready; false: done
  void run();   // steps a statement that returns no rows

  bool is_null(int column) const;
  std::int64_t integer(int column) const;
  std::optional<std::int64_t> optional_integer(int column) const;
  double real(int column) const;  // NULL reads as NaN
  std::string text(int column) const;
  std::string blob(int column) const;

 private:
  void bind_one(int index, std::int64_t value);
  void bind_one(int index, int value) { bind_one(index, static_cast<std::int64_t>(value)); }
  void bind_one(int index, bool value) { bind_one(index, static_cast<std::int64_t>(value ? 1 : 0)); }
  void bind_one(int index, double value);
  void bind_one(int index, std::string_view value);
  void bind_one(int index, const std::string& value) { bind_one(index, std::string_view(value)); }
  void bind_one(int index, const char* value) { bind_one(index, std::string_view(value)); }
  void bind_one(int index, Blob value);
  void bind_one(int index, Null);
  template <typename T>
  void bind_one(int index, const std::optional<T>& value) {
    if (value) {
      bind_one(index, *value);
    } else {
      bind_one(index, Null{});
    }
  }
  void check_bind(int rc);

  Connection* connection_;
  sqlite3_stmt* stmt_;
};

class Connection {
 public:
  // `flags` as for sqlite3_open_v2; always adds SQLITE_OPEN_NOMUTEX (one thread at a time).
  Connection(const std::string& path, int flags);
  ~Connection();
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;

  sqlite3* handle() const { return db_; }

  // The statement for `sql`, prepared once per connection.
  Statement prepare(std::string_view sql);
  // Runs every statement of `sql` in turn (schema scripts, pragmas, transaction control).
  void execute(std::string_view sql);
  // The first column of the first row of a one-value query such as "PRAGMA user_version".
  std::int64_t query_integer(std::string_view sql);
  std::string query_text(std::string_view sql);

  // Throws the connection's current error for `rc`.
  [[noreturn]] void fail(int rc) const;

 private:
  // Looked up by the SQL text without copying it.
  struct TextHash {
    using is_transparent = void;
    std::size_t operator()(std::string_view text) const { return std::hash<std::string_view>{}(text); }
  };
  sqlite3* db_ = nullptr;
  std::unordered_map<std::string, sqlite3_stmt*, TextHash, std::equal_to<>> cache_;
};

// BEGIN IMMEDIATE (a writer) or BEGIN (a reader's snapshot); rolls back on scope exit unless
// committed. SQLite may already have rolled back after some errors (SQLITE_FULL): then the
// rollback is skipped.
class Transaction {
 public:
  enum class Kind { read, write };
  Transaction(Connection& connection, Kind kind);
  ~Transaction();
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;
  void commit();

 private:
  Connection& connection_;
  bool open_ = true;
};

}  // namespace skinspec::store::detail
