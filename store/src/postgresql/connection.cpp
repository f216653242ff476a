#include "postgresql/connection.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <limits>
#include <utility>

#include "postgresql/errors.hpp"

namespace skinspec::store::postgresql {

using Kind = StoreError::Kind;

namespace {

std::string trimmed(std::string text) {
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back()))) text.pop_back();
  return text;
}

std::string_view type_name(TypeId type) {
  switch (type) {
    case TypeId::boolean:
      return "boolean";
    case TypeId::bytea:
      return "bytea";
    case TypeId::int8:
      return "bigint";
    case TypeId::int2:
      return "smallint";
    case TypeId::int4:
      return "integer";
    case TypeId::float4:
      return "real";
    case TypeId::float8:
      return "double precision";
    case TypeId::timestamp:
      return "timestamp";
    case TypeId::timestamptz:
      return "timestamptz";
    default:
      return is_textual(type) ? "text" : "a type the store does not use";
  }
}

// The SQLSTATE of an error result, empty for none (no result, or an error libpq made itself).
std::string_view sql_state_of(const PGresult* result) {
  const char* state = result ? PQresultErrorField(result, PG_DIAG_SQLSTATE) : nullptr;
  return state ? std::string_view(state) : std::string_view();
}

// Notices (such as "there is no transaction in progress") are for people at a terminal.
void ignore_notice(void*, const PGresult*) {}

}  // namespace

std::string postgresql_sql(std::string_view sql, RowLock lock) {
  std::string out;
  out.reserve(sql.size() + 12);
  for (std::size_t i = 0; i < sql.size();) {
    const char c = sql[i];
    // Quoted text and identifiers ('' and "" inside them are escaped quotes) and comments
    // are copied as they are.
    if (c == '\'' || c == '"') {
      const auto end = sql.find(c, i + 1);
      const auto stop = end == std::string_view::npos ? sql.size() : end + 1;
      out.append(sql.substr(i, stop - i));
      i = stop;
    } else if (sql.substr(i, 2) == "--") {
      const auto end = sql.find('\n', i);
      const auto stop = end == std::string_view::npos ? sql.size() : end;
      out.append(sql.substr(i, stop - i));
      i = stop;
    } else if (sql.substr(i, 2) == "/*") {
      const auto end = sql.find("*/", i + 2);
      const auto stop = end == std::string_view::npos ? sql.size() : end + 2;
      out.append(sql.substr(i, stop - i));
      i = stop;
    } else if (c == '?' && i + 1 < sql.size() && std::isdigit(static_cast<unsigned char>(sql[i + 1]))) {
      out.push_back('$');
      ++i;
    } else {
      out.push_back(c);
      ++i;
    }
  }
  if (lock == RowLock::share) out += " FOR SHARE";
  if (lock == RowLock::update) out += " FOR UPDATE";
  return out;
}

// ---- PgCursor ----

PgCursor::PgCursor(Connection& connection, std::string name, std::string sql, std::vector<TypeId> parameter_types)
    : connection_(&connection),
      name_(std::move(name)),
      sql_(std::move(sql)),
      parameter_types_(std::move(parameter_types)),
      values_(parameter_types_.size()),
      nulls_(parameter_types_.size(), true) {}

void PgCursor::bind(int index, const Param& value) {
  if (index < 1 || static_cast<std::size_t>(index) > parameter_types_.size())
    detail::fail(Kind::internal, fmt::format("{} has no parameter ${}", sql_, index));
  const auto slot = static_cast<std::size_t>(index - 1);
  const TypeId type = parameter_types_[slot];
  auto& out = values_[slot];
  out.clear();
  nulls_[slot] = false;
  const auto mismatch = [&](std::string_view given) {
    detail::fail(Kind::internal,
                 fmt::format("{}: parameter ${} is {}, and cannot take {}", sql_, index, type_name(type), given));
  };
  std::visit(
      [&](const auto& v) {
        using T = std::decay_t<decltype(v)>;
        if constexpr (std::is_same_v<T, detail::Null>) {
          nulls_[slot] = true;
        } else if constexpr (std::is_same_v<T, std::int64_t> || std::is_same_v<T, bool>) {
          const auto number = static_cast<std::int64_t>(v);
          if (type == TypeId::int8) {
            put_integer(out, number, 8);
          } else if (type == TypeId::int4 || type == TypeId::int2) {
            const std::int64_t limit = type == TypeId::int4 ? std::numeric_limits<std::int32_t>::max()
                                                            : std::numeric_limits<std::int16_t>::max();
            if (number > limit || number < -limit - 1)
              detail::fail(Kind::invalid_argument, fmt::format("{} is out of range for {}", number, type_name(type)));
            put_integer(out, number, type == TypeId::int4 ? 4 : 2);
          } else if (type == TypeId::boolean) {
            out.push_back(number != 0 ? 1 : 0);
          } else if (type == TypeId::float8) {
            put_double(out, static_cast<double>(number));
          } else {
            mismatch(std::is_same_v<T, bool> ? "a boolean" : "an integer");
          }
        } else if constexpr (std::is_same_v<T, double>) {
          if (type != TypeId::float8) mismatch("a floating-point number");
          put_double(out, v);
        } else if constexpr (std::is_same_v<T, std::string_view>) {
          if (!is_textual(type) && type != TypeId::bytea) mismatch("text");
          out.assign(v);
        } else if constexpr (std::is_same_v<T, detail::Blob>) {
          if (type != TypeId::bytea) mismatch("bytes");
          out.assign(v.bytes);
        } else {
          static_assert(std::is_same_v<T, Time>);
          if (type != TypeId::timestamptz && type != TypeId::timestamp) mismatch("a time");
          put_time(out, v);
        }
      },
      value);
}

PgCursor::Arguments PgCursor::arguments() const {
  const auto n = parameter_types_.size();
  Arguments out{std::vector<const char*>(n), std::vector<int>(n), std::vector<int>(n, 1)};
  for (std::size_t i = 0; i < n; ++i) {
    out.values[i] = nulls_[i] ? nullptr : values_[i].data();
    out.lengths[i] = static_cast<int>(values_[i].size());
  }
  return out;
}

ResultPtr PgCursor::execute_on(PGconn* connection) const {
  const auto a = arguments();
  return ResultPtr(PQexecPrepared(connection, name_.c_str(), static_cast<int>(a.values.size()), a.values.data(),
                                  a.lengths.data(), a.formats.data(), 1),
                   &PQclear);
}

bool PgCursor::send_on(PGconn* connection) const {
  const auto a = arguments();
  return PQsendQueryPrepared(connection, name_.c_str(), static_cast<int>(a.values.size()), a.values.data(),
                             a.lengths.data(), a.formats.data(), 1) == 1;
}

void PgCursor::receive(ResultPtr result) { result_ = std::move(result); }

void PgCursor::receive(const detail::Failure& failure) { failure_ = failure; }

void PgCursor::require_unsent() const {
  if (result_ || failure_) detail::fail(Kind::internal, fmt::format("{}: sent again before it was reset", sql_));
}

void PgCursor::send() {
  require_unsent();
  connection_->queue(*this);
}

void PgCursor::send_with_commit() {
  require_unsent();
  connection_->queue_last(*this);
}

bool PgCursor::step() {
  if (!result_ && !failure_) {
    connection_->queue(*this);
    connection_->run_queued();
  }
  if (failure_) throw *failure_;
  return ++row_ < PQntuples(result_.get());
}

std::string_view PgCursor::value(int column) const {
  if (!result_ || row_ < 0 || row_ >= PQntuples(result_.get()) || column < 0 || column >= PQnfields(result_.get()))
    detail::fail(Kind::internal, fmt::format("{}: no column {} in the current row", sql_, column));
  return {PQgetvalue(result_.get(), row_, column), static_cast<std::size_t>(PQgetlength(result_.get(), row_, column))};
}

TypeId PgCursor::type(int column) const { return static_cast<TypeId>(PQftype(result_.get(), column)); }

void PgCursor::cannot_read(int column, std::string_view as) const {
  detail::fail(Kind::internal,
               fmt::format("{}: column {} is {} and cannot be read as {}", sql_, column, type_name(type(column)), as));
}

bool PgCursor::is_null(int column) const {
  value(column);
  return PQgetisnull(result_.get(), row_, column) != 0;
}

std::int64_t PgCursor::integer(int column) const {
  const auto bytes = value(column);
  if (is_null(column)) return 0;
  switch (type(column)) {
    case TypeId::int8:
    case TypeId::int4:
    case TypeId::int2:
    case TypeId::boolean:
      return get_integer(bytes);
    case TypeId::oid:
      return static_cast<std::int64_t>(static_cast<std::uint32_t>(get_integer(bytes)));
    default:
      cannot_read(column, "an integer");
  }
}

double PgCursor::real(int column) const {
  const auto bytes = value(column);
  if (is_null(column)) return std::numeric_limits<double>::quiet_NaN();
  switch (type(column)) {
    case TypeId::float8:
    case TypeId::float4:
      return get_double(bytes);
    case TypeId::int8:
    case TypeId::int4:
    case TypeId::int2:
      return static_cast<double>(get_integer(bytes));
    default:
      cannot_read(column, "a number");
  }
}

bool PgCursor::boolean(int column) const {
  const auto t = type(column);
  if (t != TypeId::boolean && t != TypeId::int8 && t != TypeId::int4 && t != TypeId::int2)
    cannot_read(column, "a boolean");
  return integer(column) != 0;
}

std::string PgCursor::text(int column) const {
  const auto bytes = value(column);
  if (!is_textual(type(column))) cannot_read(column, "text");
  return std::string(bytes);
}

std::string PgCursor::blob(int column) const {
  const auto bytes = value(column);
  if (type(column) != TypeId::bytea && !is_textual(type(column))) cannot_read(column, "bytes");
  return std::string(bytes);
}

Time PgCursor::time(int column) const {
  const auto bytes = value(column);
  if (is_null(column)) return Time{};
  if (type(column) != TypeId::timestamptz && type(column) != TypeId::timestamp) cannot_read(column, "a time");
  return get_time(bytes);
}

void PgCursor::reset() noexcept {
  connection_->unqueue(*this);
  result_.reset();
  failure_.reset();
  row_ = -1;
  std::fill(nulls_.begin(), nulls_.end(), true);
}

// ---- Connection ----

Connection::Connection(const Target& target, const ConnectSettings& settings) : target_(target) {
  const auto keywords = connection_keywords(target, settings);
  std::vector<const char*> names, values;
  for (const auto& [name, value] : keywords) {
    names.push_back(name.c_str());
    values.push_back(value.c_str());
  }
  names.push_back(nullptr);
  values.push_back(nullptr);
  connection_.reset(PQconnectdbParams(names.data(), values.data(), 1));
  if (!connection_) detail::fail(Kind::internal, "libpq could not allocate a connection");
  if (PQstatus(handle()) == CONNECTION_OK) {
    PQsetNoticeReceiver(handle(), ignore_notice, nullptr);
    backend_pid_ = PQbackendPID(handle());
    apply(settings);
    return;
  }
  const std::string why = trimmed(PQerrorMessage(handle()));
  const std::string role = PQuser(handle()) ? PQuser(handle()) : "";
  if (PQconnectionNeedsPassword(handle()))
    detail::fail(Kind::access_denied,
                 fmt::format("{}: no password for role {} in PGPASSFILE or ~/.pgpass", target_.display, role));
  if (PQconnectionUsedPassword(handle()) && why.find("password authentication failed") != std::string::npos)
    detail::fail(Kind::access_denied, fmt::format("{}: the server refused the password of role {} (from PGPASSFILE "
                                                  "or ~/.pgpass)",
                                                  target_.display, role));
  detail::fail(Kind::unreachable, fmt::format("cannot reach the database server at {}: {}", target_.display, why));
}

bool Connection::still_connected() {
  // The first read takes what the server sent (its last error, when it ended the connection),
  // the second finds the end that follows it.
  for (int read = 0; read < 2 && !broken(); ++read) {
    if (PQconsumeInput(handle()) != 1) lost_ = true;
  }
  return !broken();
}

void Connection::fail(const PGresult* result, std::string_view what, bool committing) const {
  throw failure(result, what, committing);
}

detail::Failure Connection::failure(const PGresult* result, std::string_view what, bool committing) const {
  const std::string sql_state(sql_state_of(result));
  // libpq's own errors carry no SQLSTATE: on a connection that was working they mean it is
  // gone (the server closed it, or the socket failed), whether or not libpq has noticed yet.
  const bool lost = broken() || connection_lost_sql_state(sql_state) || sql_state.empty();
  if (lost) lost_ = true;
  std::string message;
  if (const char* primary = result ? PQresultErrorField(result, PG_DIAG_MESSAGE_PRIMARY) : nullptr) {
    message = primary;
    if (const char* detail = PQresultErrorField(result, PG_DIAG_MESSAGE_DETAIL))
      message += fmt::format(" ({})", detail);
  } else {
    message = trimmed(PQerrorMessage(handle()));
  }
  StoreError error{lost ? Kind::unreachable : kind_of_sql_state(sql_state), "", 0, sql_state};
  bool retryable = retryable_sql_state(sql_state);
  if (lost && committing) {
    error.message = fmt::format("the connection to {} was lost while committing; whether it was stored is unknown: {}",
                                target_.display, message);
  } else if (lost) {
    error.message = fmt::format("the connection to {} was lost: {}", target_.display, message);
    retryable = true;  // nothing of the transaction was committed
  } else {
    error.message = fmt::format("{} (while running {})", message, what);
  }
  return detail::Failure{std::move(error), retryable};
}

// Set on the session rather than in libpq's `options`, which would replace any the URI gives
// (a search_path, say). The store's promise that a returned write is durable needs
// synchronous_commit on whatever the server, database or role say; and a server that keeps an
// idle connection of a host that vanished would hold its locks for the kernel's default two
// hours, so it probes the client as libpq probes the server. The writer's statements are
// inserts and updates by key, whose one right plan does not depend on the values: planned once
// (generic plans) rather than again on each run, which cost a fifth of each commit's time.
void Connection::apply(const ConnectSettings& settings) {
  execute(settings.read_only ? "SET SESSION CHARACTERISTICS AS TRANSACTION READ ONLY"
                             : "SET synchronous_commit = on; SET tcp_keepalives_idle = 10; "
                               "SET tcp_keepalives_interval = 5; SET tcp_keepalives_count = 3; "
                               "SET plan_cache_mode = force_generic_plan");
}

Cursor& Connection::cursor(std::string_view sql, RowLock lock) {
  auto& cache = cache_[static_cast<std::size_t>(lock)];
  auto found = cache.find(sql);
  if (found != cache.end()) {
    // Bound again, a statement sent and not run yet would run with the new values.
    if (std::find(queued_.begin(), queued_.end(), found->second.get()) != queued_.end())
      detail::fail(Kind::internal, fmt::format("{}: prepared again while sent and not run yet", sql));
    return *found->second;
  }
  const auto text = postgresql_sql(sql, lock);
  // Never a name used before: a statement whose describing failed may exist on the server.
  const auto name = fmt::format("s{}", ++statements_named_);
  std::unique_ptr<PGresult, decltype(&PQclear)> prepared(PQprepare(handle(), name.c_str(), text.c_str(), 0, nullptr),
                                                         &PQclear);
  if (!prepared || PQresultStatus(prepared.get()) != PGRES_COMMAND_OK) fail(prepared.get(), text);
  std::unique_ptr<PGresult, decltype(&PQclear)> described(PQdescribePrepared(handle(), name.c_str()), &PQclear);
  if (!described || PQresultStatus(described.get()) != PGRES_COMMAND_OK) fail(described.get(), text);
  std::vector<TypeId> types;
  for (int i = 0; i < PQnparams(described.get()); ++i)
    types.push_back(static_cast<TypeId>(PQparamtype(described.get(), i)));
  auto owned = std::make_unique<PgCursor>(*this, name, text, std::move(types));
  auto& cursor = *owned;
  cache.emplace(std::string(sql), std::move(owned));
  return cursor;
}

namespace {

bool succeeded(const PGresult* result) {
  const auto status = result ? PQresultStatus(result) : PGRES_FATAL_ERROR;
  return status == PGRES_TUPLES_OK || status == PGRES_COMMAND_OK;
}

// Whether `result` is an error the server sent: the server stopped at that statement and ran
// nothing after it (an error libpq made itself, such as a connection found closed, says
// nothing of what the server did).
bool server_error(const PGresult* result) { return !sql_state_of(result).empty(); }

// A command without parameters, sent (into the pipeline, in pipeline mode).
bool send_command(PGconn* connection, const char* command) {
  return PQsendQueryParams(connection, command, 0, nullptr, nullptr, nullptr, nullptr, 1) == 1;
}

// The next query's result (in a pipeline, or alone), and past the null that ends its results.
ResultPtr next_result(PGconn* connection) {
  ResultPtr result(PQgetResult(connection), &PQclear);
  while (auto* rest = PQgetResult(connection)) PQclear(rest);
  return result;
}

}  // namespace

void Connection::queue(PgCursor& cursor) {
  if (std::find(queued_.begin(), queued_.end(), &cursor) != queued_.end()) return;
  if (commit_queued_ || committed_)
    detail::fail(Kind::internal, fmt::format("{}: run after the transaction's last statement", cursor.sql()));
  queued_.push_back(&cursor);
}

void Connection::queue_last(PgCursor& cursor) {
  if (!in_transaction())
    detail::fail(Kind::internal, fmt::format("{}: sent as a transaction's last outside a transaction", cursor.sql()));
  if (std::find(queued_.begin(), queued_.end(), &cursor) != queued_.end())
    detail::fail(Kind::internal, fmt::format("{}: sent as the transaction's last after it was sent", cursor.sql()));
  queue(cursor);
  commit_queued_ = true;
}

void Connection::unqueue(const PgCursor& cursor) noexcept {
  if (commit_queued_ && !queued_.empty() && queued_.back() == &cursor) commit_queued_ = false;
  std::erase(queued_, &cursor);
}

// One statement alone runs as it is; BEGIN and statements together go out in one pipeline.
std::optional<detail::Failure> Connection::run_queued() {
  const auto cursors = std::exchange(queued_, {});
  const char* begin = std::exchange(pending_begin_, nullptr);
  const bool commit = std::exchange(commit_queued_, false);
  if (begin || commit || cursors.size() > 1) return run_pipelined(begin, cursors, commit);
  if (cursors.empty()) return std::nullopt;
  auto result = cursors.front()->execute_on(handle());
  if (succeeded(result.get())) {
    cursors.front()->receive(std::move(result));
    return std::nullopt;
  }
  auto failed = failure(result.get(), cursors.front()->sql());
  cursors.front()->receive(failed);
  return failed;
}

// BEGIN and the statements sent together (and COMMIT after them, with the transaction's last),
// then their results read in order and the pipeline's end. After a failure the server skips the
// rest of the pipeline: the statements after it were not run, and fail as it did. Once COMMIT
// is sent, a lost connection leaves the outcome unknown unless the server's own error for an
// earlier statement shows that it stopped before COMMIT.
std::optional<detail::Failure> Connection::run_pipelined(const char* begin, const std::vector<PgCursor*>& cursors,
                                                         bool commit) {
  const std::string_view what = cursors.empty() ? std::string_view("BEGIN") : cursors.back()->sql();
  const bool sendable = !broken();  // else nothing goes out, and nothing is committed
  const bool entered = sendable && PQenterPipelineMode(handle()) == 1;
  bool sent = entered && (!begin || send_command(handle(), begin));
  for (const auto* cursor : cursors) sent = sent && cursor->send_on(handle());
  sent = sent && (!commit || send_command(handle(), "COMMIT"));
  sent = sent && PQpipelineSync(handle()) == 1;
  std::optional<detail::Failure> first;
  if (sent) {
    if (begin) {
      const auto begun = next_result(handle());
      if (!succeeded(begun.get())) first = failure(begun.get(), "BEGIN", commit && !server_error(begun.get()));
    }
    for (auto* cursor : cursors) {
      auto result = next_result(handle());
      if (!first && !succeeded(result.get()))
        first = failure(result.get(), cursor->sql(), commit && !server_error(result.get()));
      if (first) {
        cursor->receive(*first);
      } else {
        cursor->receive(std::move(result));
      }
    }
    if (commit) {
      if (first) {
        next_result(handle());  // skipped: a statement before it failed
      } else if ((first = read_commit())) {
        for (auto* cursor : cursors) cursor->receive(*first);  // the transaction's outcome is theirs
      }
      committed_ = !first;
    }
    while (auto* rest = PQgetResult(handle())) {
      const bool synced = PQresultStatus(rest) == PGRES_PIPELINE_SYNC;
      PQclear(rest);
      if (synced) break;
    }
  }
  if (entered && PQexitPipelineMode(handle()) != 1) lost_ = true;  // stuck in pipeline mode: not usable again
  if (!sent) {
    first = failure(nullptr, what, commit && sendable);
    for (auto* cursor : cursors) cursor->receive(*first);
  }
  return first;
}

// COMMIT's reply in a pipeline: its failure, if it did not commit.
std::optional<detail::Failure> Connection::read_commit() {
  const auto result = next_result(handle());
  if (!succeeded(result.get())) return failure(result.get(), "COMMIT", true);
  // PostgreSQL answers COMMIT of a transaction a statement failed in with ROLLBACK.
  if (std::string_view(PQcmdStatus(result.get())) == "ROLLBACK")
    return detail::Failure{{Kind::internal, "the transaction had failed and was rolled back, not committed", 0}};
  return std::nullopt;
}

// A script runs after what was sent before it.
void Connection::run_before_script() {
  if (queued_.empty()) {
    if (const char* begin = std::exchange(pending_begin_, nullptr)) run(begin, "BEGIN");
    return;
  }
  if (auto failed = run_queued()) throw *failed;
}

void Connection::run(const char* command, std::string_view what) {
  std::unique_ptr<PGresult, decltype(&PQclear)> result(PQexec(handle(), command), &PQclear);
  const auto status = result ? PQresultStatus(result.get()) : PGRES_FATAL_ERROR;
  if (status != PGRES_COMMAND_OK && status != PGRES_TUPLES_OK) fail(result.get(), what);
}

void Connection::execute(std::string_view script) {
  if (committed_) detail::fail(Kind::internal, "a script run after the transaction's last statement");
  run_before_script();
  const std::string text(script);
  run(text.c_str(), "a script");
}

void Connection::begin(TransactionKind kind) {
  if (in_transaction()) detail::fail(Kind::internal, "a transaction is already open");
  committed_ = false;
  pending_begin_ = kind == TransactionKind::write ? "BEGIN" : "BEGIN ISOLATION LEVEL REPEATABLE READ READ ONLY";
}

void Connection::commit() {
  if (!queued_.empty()) {
    if (auto failed = run_queued()) throw *failed;
  }
  if (std::exchange(committed_, false)) return;        // with its last statement
  if (std::exchange(pending_begin_, nullptr)) return;  // nothing ran: nothing to commit
  if (!send_command(handle(), "COMMIT")) fail(nullptr, "COMMIT", true);
  if (auto failed = read_commit()) throw *failed;
}

void Connection::rollback() noexcept {
  pending_begin_ = nullptr;
  queued_.clear();  // not run: nothing to undo
  commit_queued_ = false;
  committed_ = false;
  if (!in_transaction()) return;
  // A failure here leaves nothing to do: the server rolls back a transaction whose
  // connection is gone, and a broken connection is not used again.
  PQclear(PQexec(handle(), "ROLLBACK"));
}

bool Connection::in_transaction() const {
  if (pending_begin_) return true;
  const auto status = PQtransactionStatus(handle());
  return status == PQTRANS_INTRANS || status == PQTRANS_INERROR || status == PQTRANS_ACTIVE;
}

}  // namespace skinspec::store::postgresql
