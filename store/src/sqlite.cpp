#include "sqlite.hpp"

#include <fmt/format.h>

#include <limits>

namespace skinspec::store::detail {

void fail(StoreError::Kind kind, std::string message, int sqlite_code) {
  throw Failure{StoreError{kind, std::move(message), sqlite_code}};
}

StoreError::Kind kind_of_sqlite_code(int extended_code) {
  using Kind = StoreError::Kind;
  switch (extended_code & 0xff) {
    case SQLITE_FULL:
      return Kind::full;
    case SQLITE_READONLY:
      return Kind::read_only;
    case SQLITE_CORRUPT:
    case SQLITE_NOTADB:
      return Kind::corrupt;
    case SQLITE_BUSY:
    case SQLITE_LOCKED:
      return Kind::busy;
    case SQLITE_IOERR:
    case SQLITE_CANTOPEN:
    case SQLITE_PERM:
      return Kind::io;
    case SQLITE_CONSTRAINT:
      return Kind::conflict;
    case SQLITE_TOOBIG:
    case SQLITE_RANGE:
    case SQLITE_MISMATCH:
      return Kind::invalid_argument;
    default:
      return Kind::internal;
  }
}

// ---- Statement ----

Statement::~Statement() {
  sqlite3_reset(stmt_);
  sqlite3_clear_bindings(stmt_);
}

void Statement::check_bind(int rc) {
  if (rc != SQLITE_OK) connection_->fail(rc);
}

void Statement::bind_one(int index, std::int64_t value) { check_bind(sqlite3_bind_int64(stmt_, index, value)); }
void Statement::bind_one(int index, double value) { check_bind(sqlite3_bind_double(stmt_, index, value)); }
void Statement::bind_one(int index, std::string_view value) {
  check_bind(sqlite3_bind_text64(stmt_, index, value.data(), value.size(), SQLITE_TRANSIENT, SQLITE_UTF8));
}
void Statement::bind_one(int index, Blob value) {
  // A zero-length blob still binds as a blob (not NULL): data must be non-null.
  static const char kEmpty = 0;
  const char* data = value.bytes.empty() ? &kEmpty : value.bytes.data();
  check_bind(sqlite3_bind_blob64(stmt_, index, data, value.bytes.size(), SQLITE_TRANSIENT));
}
void Statement::bind_one(int index, Null) { check_bind(sqlite3_bind_null(stmt_, index)); }

bool Statement::step() {
  const int rc = sqlite3_step(stmt_);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  connection_->fail(rc);
}

void Statement::run() {
  while (step()) {
  }
}

bool Statement::is_null(int column) const { return sqlite3_column_type(stmt_, column) == SQLITE_NULL; }
std::int64_t Statement::integer(int column) const { return sqlite3_column_int64(stmt_, column); }
std::optional<std::int64_t> Statement::optional_integer(int column) const {
  if (is_null(column)) return std::nullopt;
  return integer(column);
}
double Statement::real(int column) const {
  if (is_null(column)) return std::numeric_limits<double>::quiet_NaN();
  return sqlite3_column_double(stmt_, column);
}
std::string Statement::text(int column) const {
  const auto* p = sqlite3_column_text(stmt_, column);
  const int n = sqlite3_column_bytes(stmt_, column);
  return p ? std::string(reinterpret_cast<const char*>(p), static_cast<std::size_t>(n)) : std::string();
}
std::string Statement::blob(int column) const {
  const void* p = sqlite3_column_blob(stmt_, column);
  const int n = sqlite3_column_bytes(stmt_, column);
  return p ? std::string(static_cast<const char*>(p), static_cast<std::size_t>(n)) : std::string();
}

// ---- Connection ----

Connection::Connection(const std::string& path, int flags) {
  const int rc = sqlite3_open_v2(path.c_str(), &db_, flags | SQLITE_OPEN_NOMUTEX, nullptr);
  if (rc != SQLITE_OK) {
    const std::string message = db_ ? sqlite3_errmsg(db_) : sqlite3_errstr(rc);
    const int code = db_ ? sqlite3_extended_errcode(db_) : rc;
    sqlite3_close_v2(db_);
    db_ = nullptr;
    detail::fail(kind_of_sqlite_code(code), message, code);
  }
  sqlite3_extended_result_codes(db_, 1);
}

Connection::~Connection() {
  for (auto& [sql, stmt] : cache_) sqlite3_finalize(stmt);
  sqlite3_close_v2(db_);
}

void Connection::fail(int rc) const {
  const int code = sqlite3_extended_errcode(db_);
  // Errors from sqlite3_step carry their own message; bind errors only the code.
  const std::string message = (code & 0xff) == (rc & 0xff) ? sqlite3_errmsg(db_) : sqlite3_errstr(rc);
  const int reported = (code & 0xff) == (rc & 0xff) ? code : rc;
  detail::fail(kind_of_sqlite_code(reported), message, reported);
}

Statement Connection::prepare(std::string_view sql) {
  auto found = cache_.find(sql);
  if (found != cache_.end()) return Statement(*this, found->second);
  sqlite3_stmt* stmt = nullptr;
  const int rc =
      sqlite3_prepare_v3(db_, sql.data(), static_cast<int>(sql.size()), SQLITE_PREPARE_PERSISTENT, &stmt, nullptr);
  if (rc != SQLITE_OK) fail(rc);
  cache_.emplace(std::string(sql), stmt);
  return Statement(*this, stmt);
}

void Connection::execute(std::string_view sql) {
  const char* next = sql.data();
  const char* end = sql.data() + sql.size();
  while (next < end) {
    sqlite3_stmt* stmt = nullptr;
    const char* tail = nullptr;
    const int rc = sqlite3_prepare_v2(db_, next, static_cast<int>(end - next), &stmt, &tail);
    if (rc != SQLITE_OK) fail(rc);
    if (!stmt) break;  // only white space or comments were left
    std::unique_ptr<sqlite3_stmt, int (*)(sqlite3_stmt*)> owned(stmt, sqlite3_finalize);
    int step = SQLITE_ROW;
    while (step == SQLITE_ROW) step = sqlite3_step(stmt);
    if (step != SQLITE_DONE) fail(step);
    next = tail;
  }
}

std::int64_t Connection::query_integer(std::string_view sql) {
  auto stmt = prepare(sql);
  if (!stmt.step()) detail::fail(StoreError::Kind::internal, fmt::format("'{}' returned no row", sql));
  return stmt.integer(0);
}

std::string Connection::query_text(std::string_view sql) {
  auto stmt = prepare(sql);
  if (!stmt.step()) detail::fail(StoreError::Kind::internal, fmt::format("'{}' returned no row", sql));
  return stmt.text(0);
}

// ---- Transaction ----

Transaction::Transaction(Connection& connection, Kind kind) : connection_(connection) {
  connection_.prepare(kind == Kind::write ? "BEGIN IMMEDIATE" : "BEGIN").run();
}

Transaction::~Transaction() {
  if (open_ && !sqlite3_get_autocommit(connection_.handle())) {
    // Nothing useful can be done if the rollback itself fails: SQLite then rolls back when
    // the connection next begins, or recovery does when it is reopened.
    sqlite3_exec(connection_.handle(), "ROLLBACK", nullptr, nullptr, nullptr);
  }
}

void Transaction::commit() {
  connection_.prepare("COMMIT").run();
  open_ = false;
}

}  // namespace skinspec::store::detail
