#pragma once
// The store's Connection over libpq: one PGconn, its statements prepared once (named, with
// the parameter types the server inferred) and cached by their text, parameters and results in
// binary. The store's SQL says ?1, ?2 ...; PostgreSQL is given $1, $2 ... Statements sent
// (Statement::send) wait until one is stepped, then go out with it in one pipeline, one round
// trip: what the server does, it does in the order sent.

#include <libpq-fe.h>

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "db.hpp"
#include "postgresql/binary.hpp"
#include "postgresql/target.hpp"

namespace skinspec::store::postgresql {

using detail::Cursor;
using detail::Dialect;
using detail::Param;
using detail::RowLock;
using detail::TransactionKind;

// `sql` with each ?N outside quoted text and comments written $N, and `lock`'s clause appended.
std::string postgresql_sql(std::string_view sql, RowLock lock);

class Connection;

using ResultPtr = std::unique_ptr<PGresult, decltype(&PQclear)>;

class PgCursor final : public Cursor {
 public:
  PgCursor(Connection& connection, std::string name, std::string sql, std::vector<TypeId> parameter_types);

  void bind(int index, const Param& value) override;
  void send() override;
  void send_with_commit() override;
  bool step() override;
  bool is_null(int column) const override;
  std::int64_t integer(int column) const override;
  double real(int column) const override;
  bool boolean(int column) const override;
  std::string text(int column) const override;
  std::string blob(int column) const override;
  Time time(int column) const override;
  void reset() noexcept override;

  const std::string& sql() const { return sql_; }
  // Runs the statement with its bound values, binary parameters and results: at once
  // (PQexecPrepared), or sent into the connection's pipeline (false: it could not be sent).
  ResultPtr execute_on(PGconn* connection) const;
  bool send_on(PGconn* connection) const;
  // What running it gave: its rows, or its failure.
  void receive(ResultPtr result);
  void receive(const detail::Failure& failure);

 private:
  struct Arguments {
    std::vector<const char*> values;
    std::vector<int> lengths;
    std::vector<int> formats;
  };
  Arguments arguments() const;
  std::string_view value(int column) const;
  TypeId type(int column) const;
  [[noreturn]] void cannot_read(int column, std::string_view as) const;
  void require_unsent() const;

  Connection* connection_;
  std::string name_;
  std::string sql_;  // as sent, for messages
  std::vector<TypeId> parameter_types_;
  std::vector<std::string> values_;
  std::vector<bool> nulls_;
  ResultPtr result_{nullptr, &PQclear};
  std::optional<detail::Failure> failure_;
  int row_ = -1;
};

class Connection final : public detail::Connection {
 public:
  // Connects now; throws unreachable, access_denied or invalid_argument naming the cause.
  Connection(const Target& target, const ConnectSettings& settings);
  ~Connection() override = default;
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;

  Dialect dialect() const override { return Dialect::postgresql; }
  void execute(std::string_view script) override;
  // BEGIN (read committed; the store takes the row locks it needs), or a read-only snapshot
  // (REPEATABLE READ READ ONLY). Sent with the transaction's first statement, in one pipeline:
  // a round trip fewer per transaction.
  void begin(TransactionKind kind) override;
  void commit() override;
  void rollback() noexcept override;
  bool in_transaction() const override;

  // Whether the connection is gone: a pool drops it rather than hand it out again.
  bool broken() const { return lost_ || PQstatus(handle()) != CONNECTION_OK; }
  // Whether it is still connected as far as can be told without a round trip: what the server
  // sent since (the error and end of a connection it closed, as a restarted server does) is
  // read first. A write sent with its COMMIT on a connection found dead only after sending
  // could not tell whether it was stored.
  bool still_connected();
  // The server process serving this connection, as it was when connected (also once broken).
  int backend_pid() const { return backend_pid_; }
  PGconn* handle() const { return connection_.get(); }

  // Statements sent (PgCursor::send) wait here until one is stepped; a cursor reset before
  // then is taken out again. The transaction's last (queue_last) takes the COMMIT with it.
  void queue(PgCursor& cursor);
  void queue_last(PgCursor& cursor);
  void unqueue(const PgCursor& cursor) noexcept;
  // Runs the queued statements, BEGIN first when begin() is pending and COMMIT last when the
  // last statement is among them, each cursor given its result or failure; returns the first
  // failure.
  std::optional<detail::Failure> run_queued();

  // The failure `result` (null: the connection's own error) reports, for `what`.
  // `committing`: it was the reply to COMMIT, so a lost connection leaves the outcome unknown.
  detail::Failure failure(const PGresult* result, std::string_view what, bool committing = false) const;
  [[noreturn]] void fail(const PGresult* result, std::string_view what, bool committing = false) const;

 protected:
  Cursor& cursor(std::string_view sql, RowLock lock) override;

 private:
  void run(const char* command, std::string_view what);
  void apply(const ConnectSettings& settings);
  void run_before_script();
  std::optional<detail::Failure> run_pipelined(const char* begin, const std::vector<PgCursor*>& cursors, bool commit);
  std::optional<detail::Failure> read_commit();

  Target target_;
  std::unique_ptr<PGconn, decltype(&PQfinish)> connection_{nullptr, &PQfinish};
  mutable bool lost_ = false;            // a statement found the connection gone (fail())
  const char* pending_begin_ = nullptr;  // the BEGIN begin() asked for, not sent yet
  std::vector<PgCursor*> queued_;        // sent, in order, not run yet
  bool commit_queued_ = false;           // the transaction's last statement is among them
  bool committed_ = false;               // it ran with the COMMIT: the transaction has ended
  std::uint64_t statements_named_ = 0;
  int backend_pid_ = 0;
  // By the store's text of the statement, one map per row lock.
  std::array<std::unordered_map<std::string, std::unique_ptr<PgCursor>, detail::TextHash, std::equal_to<>>, 3> cache_;
};

}  // namespace skinspec::store::postgresql
