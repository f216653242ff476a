#include "db.hpp"

#include <fmt/format.h>

namespace skinspec::store::detail {

void fail(StoreError::Kind kind, std::string message) { throw Failure{StoreError{kind, std::move(message), 0}}; }

std::string placeholders(int first, int count) {
  std::string out;
  for (int n = first; n < first + count; ++n) out += fmt::format("{}?{}", n == first ? "" : ", ", n);
  return out;
}

void Statement::run() {
  while (step()) {
  }
}

std::optional<std::int64_t> Statement::optional_integer(int column) const {
  if (is_null(column)) return std::nullopt;
  return integer(column);
}

std::optional<Time> Statement::optional_time(int column) const {
  if (is_null(column)) return std::nullopt;
  return time(column);
}

Statement Connection::prepare(std::string_view sql, RowLock lock) {
  auto& prepared = cursor(sql, lock);
  ++prepared_;
  return Statement(prepared);
}

std::int64_t Connection::query_integer(std::string_view sql) {
  auto stmt = prepare(sql);
  if (!stmt.step()) fail(StoreError::Kind::internal, fmt::format("'{}' returned no row", sql));
  return stmt.integer(0);
}

std::string Connection::query_text(std::string_view sql) {
  auto stmt = prepare(sql);
  if (!stmt.step()) fail(StoreError::Kind::internal, fmt::format("'{}' returned no row", sql));
  return stmt.text(0);
}

}  // namespace skinspec::store::detail
