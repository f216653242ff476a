#include "sqlite/connection.hpp"

#include <limits>

#include "codec.hpp"

namespace skinspec::store::sqlite {

StoreError::Kind kind_of_code(int extended_code) {
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

void fail(int extended_code, std::string message) {
  throw detail::Failure{StoreError{kind_of_code(extended_code), std::move(message), extended_code}};
}

// ---- SqliteCursor ----

SqliteCursor::~SqliteCursor() { sqlite3_finalize(stmt_); }

void SqliteCursor::bind(int index, const Param& value) {
  // A zero-length text or blob still binds as one (not NULL): its data must be non-null.
  static const char kEmpty = 0;
  const auto data = [](std::string_view bytes) { return bytes.empty() ? &kEmpty : bytes.data(); };
  const int rc = std::visit(
      [&](const auto& v) {
        using T = std::decay_t<decltype(v)>;
        if constexpr (std::is_same_v<T, detail::Null>) {
          return sqlite3_bind_null(stmt_, index);
        } else if constexpr (std::is_same_v<T, std::int64_t>) {
          return sqlite3_bind_int64(stmt_, index, v);
        } else if constexpr (std::is_same_v<T, bool>) {
          return sqlite3_bind_int64(stmt_, index, v ? 1 : 0);
        } else if constexpr (std::is_same_v<T, double>) {
          return sqlite3_bind_double(stmt_, index, v);
        } else if constexpr (std::is_same_v<T, std::string_view>) {
          return sqlite3_bind_text64(stmt_, index, data(v), v.size(), SQLITE_TRANSIENT, SQLITE_UTF8);
        } else if constexpr (std::is_same_v<T, detail::Blob>) {
          return sqlite3_bind_blob64(stmt_, index, data(v.bytes), v.bytes.size(), SQLITE_TRANSIENT);
        } else {
          static_assert(std::is_same_v<T, Time>);
          return sqlite3_bind_int64(stmt_, index, detail::to_micros(v));
        }
      },
      value);
  if (rc != SQLITE_OK) connection_->fail(rc);
}

bool SqliteCursor::step() {
  const int rc = sqlite3_step(stmt_);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  connection_->fail(rc);
}

bool SqliteCursor::is_null(int column) const { return sqlite3_column_type(stmt_, column) == SQLITE_NULL; }
std::int64_t SqliteCursor::integer(int column) const { return sqlite3_column_int64(stmt_, column); }
double SqliteCursor::real(int column) const {
  if (is_null(column)) return std::numeric_limits<double>::quiet_NaN();
  return sqlite3_column_double(stmt_, column);
}
bool SqliteCursor::boolean(int column) const { return integer(column) != 0; }
std::string SqliteCursor::text(int column) const {
  const auto* p = sqlite3_column_text(stmt_, column);
  const int n = sqlite3_column_bytes(stmt_, column);
  return p ? std::string(reinterpret_cast<const char*>(p), static_cast<std::size_t>(n)) : std::string();
}
std::string SqliteCursor::blob(int column) const {
  const void* p = sqlite3_column_blob(stmt_, column);
  const int n = sqlite3_column_bytes(stmt_, column);
  return p ? std::string(static_cast<const char*>(p), static_cast<std::size_t>(n)) : std::string();
}
Time SqliteCursor::time(int column) const { return detail::from_micros(integer(column)); }

void SqliteCursor::reset() noexcept {
  sqlite3_reset(stmt_);
  sqlite3_clear_bindings(stmt_);
}

// ---- Connection ----

Connection::Connection(const std::string& filename, int flags) {
  const int rc = sqlite3_open_v2(filename.c_str(), &db_, flags | SQLITE_OPEN_NOMUTEX, nullptr);
  if (rc != SQLITE_OK) {
    const std::string message = db_ ? sqlite3_errmsg(db_) : sqlite3_errstr(rc);
    const int code = db_ ? sqlite3_extended_errcode(db_) : rc;
    sqlite3_close_v2(db_);
    db_ = nullptr;
    sqlite::fail(code, message);
  }
  sqlite3_extended_result_codes(db_, 1);
}

Connection::~Connection() {
  cache_.clear();  // every statement finalized before the handle closes
  sqlite3_close_v2(db_);
}

void Connection::fail(int rc) const {
  const int code = sqlite3_extended_errcode(db_);
  // Errors from sqlite3_step carry their own message; bind errors only the code.
  const bool same = (code & 0xff) == (rc & 0xff);
  sqlite::fail(same ? code : rc, same ? sqlite3_errmsg(db_) : sqlite3_errstr(rc));
}

Cursor& Connection::cursor(std::string_view sql, RowLock) {
  auto found = cache_.find(sql);
  if (found != cache_.end()) return *found->second;
  sqlite3_stmt* stmt = nullptr;
  const int rc =
      sqlite3_prepare_v3(db_, sql.data(), static_cast<int>(sql.size()), SQLITE_PREPARE_PERSISTENT, &stmt, nullptr);
  if (rc != SQLITE_OK) fail(rc);
  auto owned = std::make_unique<SqliteCursor>(*this, stmt);
  auto& cursor = *owned;
  cache_.emplace(std::string(sql), std::move(owned));
  return cursor;
}

void Connection::execute(std::string_view script) {
  const char* next = script.data();
  const char* end = script.data() + script.size();
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

void Connection::begin(TransactionKind kind) {
  detail::Statement(cursor(kind == TransactionKind::write ? "BEGIN IMMEDIATE" : "BEGIN", RowLock::none)).run();
}

void Connection::commit() { detail::Statement(cursor("COMMIT", RowLock::none)).run(); }

void Connection::rollback() noexcept {
  // Nothing useful can be done if the rollback itself fails: SQLite then rolls back when the
  // connection next begins, or recovery does when it is reopened.
  if (in_transaction()) sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
}

}  // namespace skinspec::store::sqlite
