#pragma once
// The store's Connection over the SQLite C API: one sqlite3 handle, its statements prepared
// once and cached by their text, times bound and read as integer microseconds since 1970.

#include <sqlite3.h>

#include <memory>
#include <string>
#include <string_view>
#include <unordered_map>

#include "db.hpp"

namespace skinspec::store::sqlite {

using detail::Cursor;
using detail::Dialect;
using detail::Param;
using detail::RowLock;
using detail::TransactionKind;

StoreError::Kind kind_of_code(int extended_code);
// Throws a Failure of the kind SQLite's `extended_code` means, the code kept with it.
[[noreturn]] void fail(int extended_code, std::string message);

class Connection;

class SqliteCursor final : public Cursor {
 public:
  SqliteCursor(Connection& connection, sqlite3_stmt* stmt) : connection_(&connection), stmt_(stmt) {}
  ~SqliteCursor() override;
  SqliteCursor(const SqliteCursor&) = delete;
  SqliteCursor& operator=(const SqliteCursor&) = delete;

  void bind(int index, const Param& value) override;
  bool step() override;
  bool is_null(int column) const override;
  std::int64_t integer(int column) const override;
  double real(int column) const override;
  bool boolean(int column) const override;
  std::string text(int column) const override;
  std::string blob(int column) const override;
  Time time(int column) const override;
  void reset() noexcept override;

 private:
  Connection* connection_;
  sqlite3_stmt* stmt_;
};

class Connection final : public detail::Connection {
 public:
  // `flags` as for sqlite3_open_v2; always adds SQLITE_OPEN_NOMUTEX (one thread at a time).
  Connection(const std::string& filename, int flags);
  ~Connection() override;
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;

  sqlite3* handle() const { return db_; }
  Dialect dialect() const override { return Dialect::sqlite; }

  void execute(std::string_view script) override;
  // BEGIN IMMEDIATE (a writer) or BEGIN (a reader's snapshot).
  void begin(TransactionKind kind) override;
  void commit() override;
  // SQLite may already have rolled back after some errors (SQLITE_FULL): then nothing is done.
  void rollback() noexcept override;
  bool in_transaction() const override { return sqlite3_get_autocommit(db_) == 0; }

  // Throws the connection's current error for `rc`.
  [[noreturn]] void fail(int rc) const;

 protected:
  Cursor& cursor(std::string_view sql, RowLock lock) override;

 private:
  sqlite3* db_ = nullptr;
  std::unordered_map<std::string, std::unique_ptr<SqliteCursor>, detail::TextHash, std::equal_to<>> cache_;
};

}  // namespace skinspec::store::sqlite
