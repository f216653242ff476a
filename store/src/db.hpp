#pragma once
// What the store's code runs its SQL through, whatever the engine: connections with a cache of
// prepared statements, statements bound by position (?1, ?2 ...), transactions that roll back
// unless committed. Each engine implements Connection and Cursor (sqlite/connection.hpp).
// Inside the library a failure is thrown as Failure; the public methods return it.

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <variant>

#include "skinspec/store/types.hpp"

namespace skinspec::store::detail {

struct Failure {
  StoreError error;
  bool retryable = false;  // nothing was committed: the whole transaction may be run again
};

[[noreturn]] void fail(StoreError::Kind kind, std::string message);

// "?first, ?first+1, ..." for `count` parameters.
std::string placeholders(int first, int count);

// Raw bytes to bind as a BLOB (text binds as TEXT).
struct Blob {
  std::string_view bytes;
};
struct Null {};

// One bound value. Text and bytes are copied by the cursor when bound.
using Param = std::variant<Null, std::int64_t, double, bool, std::string_view, Blob, Time>;

enum class Dialect { sqlite, postgresql };

// For maps of prepared statements looked up by their SQL text without copying it.
struct TextHash {
  using is_transparent = void;
  std::size_t operator()(std::string_view text) const { return std::hash<std::string_view>{}(text); }
};
// A row lock taken by a SELECT where the engine has them (FOR SHARE / FOR UPDATE); SQLite has
// one writer and needs none.
enum class RowLock { none, share, update };
enum class TransactionKind { read, write };

// One engine's execution of a prepared statement.
class Cursor {
 public:
  virtual ~Cursor() = default;
  virtual void bind(int index, const Param& value) = 0;  // 1-based
  // Bound and to run: where the engine is a server, it goes out with the next statement whose
  // result is needed, in one round trip (SQLite has none to save: it runs at step()).
  virtual void send() {}
  // Sent as the write transaction's last statement: where the engine is a server, the COMMIT
  // goes out with it, in its round trip. (SQLite commits when the write ends, as always.)
  virtual void send_with_commit() {}
  virtual bool step() = 0;  // true: a row is ready; false: done
  virtual bool is_null(int column) const = 0;
  virtual std::int64_t integer(int column) const = 0;
  virtual double real(int column) const = 0;  // NULL reads as NaN
  virtual bool boolean(int column) const = 0;
  virtual std::string text(int column) const = 0;
  virtual std::string blob(int column) const = 0;
  virtual Time time(int column) const = 0;
  // Ready for the next use: unbound, not running.
  virtual void reset() noexcept = 0;
};

// One use of a cached prepared statement: bind, step, read columns. Resets it when it goes out
// of scope, so the next use starts clean.
class Statement {
 public:
  explicit Statement(Cursor& cursor) : cursor_(&cursor) {}
  ~Statement() { cursor_->reset(); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  // Binds ?1, ?2, ... in order; an empty optional binds NULL.
  template <typename... Args>
  Statement& bind(const Args&... args) {
    return bind_from(1, args...);
  }
  // Binds ?first, ?first+1, ... in order.
  template <typename... Args>
  Statement& bind_from(int first, const Args&... args) {
    int index = first - 1;
    (cursor_->bind(++index, to_param(args)), ...);
    return *this;
  }

  // Binds one value by position (1-based), for statements whose columns are listed as data.
  Statement& bind_at(int index, const Param& value) {
    cursor_->bind(index, value);
    return *this;
  }

  // Lets the statement, bound, go out before its result is needed: with a server, it runs in
  // the round trip of the next statement stepped, after the statements sent before it. Each
  // statement sent must be stepped before it goes out of scope (one that was not may or may not
  // have run); its step() gives its result, or throws its failure (or that of a statement sent
  // before it, which kept it from running).
  Statement& send() {
    cursor_->send();
    return *this;
  }
  // Makes the statement, bound, the last of its write transaction: with a server, the
  // transaction commits in the statement's own round trip when it succeeds, and its rows are read
  // after the commit. So what they show can no longer undo it: a statement sent so writes only
  // what its own conditions allow, and nothing else runs in the transaction after it. Where the
  // engine commits when the write ends (SQLite), a failure found in its rows still rolls back.
  Statement& send_with_commit() {
    cursor_->send_with_commit();
    return *this;
  }
  bool step() { return cursor_->step(); }
  void run();  // steps to the end, ignoring any rows

  bool is_null(int column) const { return cursor_->is_null(column); }
  std::int64_t integer(int column) const { return cursor_->integer(column); }
  std::optional<std::int64_t> optional_integer(int column) const;
  double real(int column) const { return cursor_->real(column); }
  bool boolean(int column) const { return cursor_->boolean(column); }
  std::string text(int column) const { return cursor_->text(column); }
  std::string blob(int column) const { return cursor_->blob(column); }
  Time time(int column) const { return cursor_->time(column); }
  std::optional<Time> optional_time(int column) const;

 private:
  static Param to_param(std::int64_t value) { return value; }
  static Param to_param(int value) { return std::int64_t{value}; }
  static Param to_param(bool value) { return value; }
  static Param to_param(double value) { return value; }
  static Param to_param(std::string_view value) { return value; }
  static Param to_param(const std::string& value) { return std::string_view(value); }
  static Param to_param(const char* value) { return std::string_view(value); }
  static Param to_param(Blob value) { return value; }
  static Param to_param(Null) { return Null{}; }
  static Param to_param(Time value) { return value; }
  template <typename T>
  static Param to_param(const std::optional<T>& value) {
    return value ? to_param(*value) : Param(Null{});
  }

  Cursor* cursor_;
};

class Connection {
 public:
  virtual ~Connection() = default;
  virtual Dialect dialect() const = 0;

  // The statement for `sql` (placeholders ?1, ?2 ...), prepared once per connection and cached
  // by its text; `lock` appends the engine's row lock to a SELECT.
  Statement prepare(std::string_view sql, RowLock lock = RowLock::none);
  // Runs every statement of a script, none with parameters (schema scripts, settings).
  virtual void execute(std::string_view script) = 0;
  // The first column of the first row of a one-value query.
  std::int64_t query_integer(std::string_view sql);
  std::string query_text(std::string_view sql);

  virtual void begin(TransactionKind kind) = 0;
  virtual void commit() = 0;
  virtual void rollback() noexcept = 0;  // nothing when no transaction is open
  virtual bool in_transaction() const = 0;

  // How many statements prepare() handed out: a body that must run one statement is checked
  // by comparing this before and after it.
  std::uint64_t statements_prepared() const { return prepared_; }

 protected:
  virtual Cursor& cursor(std::string_view sql, RowLock lock) = 0;

 private:
  std::uint64_t prepared_ = 0;
};

// begin() now; rolls back on scope exit unless committed.
class Transaction {
 public:
  Transaction(Connection& connection, TransactionKind kind) : connection_(connection) { connection_.begin(kind); }
  ~Transaction() {
    if (open_) connection_.rollback();
  }
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;
  void commit() {
    connection_.commit();
    open_ = false;
  }

 private:
  Connection& connection_;
  bool open_ = true;
};

}  // namespace skinspec::store::detail
