#include "postgresql/statements.hpp"

#include <fmt/format.h>

#include "db.hpp"

namespace skinspec::store::postgresql {

namespace {

// "?N" for `column`, the Nth of the comma-separated `columns` (bound from ?1 in that order).
std::string parameter_of(std::string_view columns, std::string_view column) {
  int position = 1;
  for (std::size_t at = 0;; ++position) {
    const auto comma = columns.find(',', at);
    auto name = columns.substr(at, comma == std::string_view::npos ? std::string_view::npos : comma - at);
    while (name.starts_with(' ')) name.remove_prefix(1);
    if (name == column) return fmt::format("?{}", position);
    if (comma == std::string_view::npos) detail::fail(StoreError::Kind::internal, fmt::format("no column {}", column));
    at = comma + 1;
  }
}

}  // namespace

std::string recording_statement(const Recording& shape) {
  const auto param = [&](std::string_view column) { return parameter_of(shape.measurement_columns, column); };
  const auto session = param("session_id"), white = param("white_measurement_id"), instrument = param("instrument_id"),
             job = param("job_id"), now = param("created_at");
  const bool fit = !shape.fit_columns.empty(), ends_job = !shape.job_columns.empty();
  std::string sql = "WITH ";
  std::string passes = fmt::format(
      "context.state = 'open' AND ({0} IS NULL OR context.white_kind = 'white') AND ({1} IS NULL OR "
      "context.instruments > 0)",
      white, instrument);
  if (ends_job) {
    sql += fmt::format("job AS (SELECT state, session_id FROM jobs WHERE id = {} FOR UPDATE), ", job);
    passes += fmt::format(" AND job.state = 'running' AND job.session_id = {}", session);
  }
  sql += fmt::format(
      "context AS (SELECT s.state, (SELECT kind FROM measurements WHERE id = {0}) AS white_kind, "
      "(SELECT count(*) FROM instruments WHERE id = {1}) AS instruments FROM sessions s WHERE s.id = {2} FOR SHARE), "
      "m AS (INSERT INTO measurements ({3}) SELECT {4} FROM context{5} WHERE {6} RETURNING id AS measurement_id)",
      white, instrument, session, shape.measurement_columns, detail::placeholders(1, shape.measurement_count),
      ends_job ? ", job" : "", passes);
  if (fit) {
    sql += fmt::format(
        ", f AS (INSERT INTO fits (measurement_id, {}) SELECT measurement_id, {} FROM m RETURNING id AS fit_id)",
        shape.fit_columns, detail::placeholders(shape.measurement_count + 1, shape.fit_count));
  }
  if (ends_job) {
    // The result's text is its head (the caller's result, all but its closing brace) and the
    // new ids, the same text that store_write.cpp's with_ids() makes for the other engine.
    const int head = shape.measurement_count + shape.fit_count + 1;
    sql += fmt::format(
        ", done AS (UPDATE jobs SET state = 'succeeded', error = NULL, result = (?{0} || '\"measurement_id\":' || "
        "m.measurement_id || ',\"fit_id\":' || {1} || '}}')::json, finished_at = coalesce(jobs.finished_at, {2}) "
        "FROM m{3} WHERE jobs.id = {4} RETURNING {5})",
        head, fit ? "f.fit_id" : "'null'", now, fit ? " LEFT JOIN f ON true" : "", job, shape.job_columns);
  }
  sql += fmt::format(
      " SELECT {}, context.state, context.white_kind, context.instruments, m.measurement_id, {}{} FROM (VALUES (1)) "
      "AS one{} LEFT JOIN context ON true LEFT JOIN m ON true{}{}",
      ends_job ? "job.state, job.session_id" : "NULL::text, NULL::bigint", fit ? "f.fit_id" : "NULL::bigint",
      ends_job ? ", done.*" : "", ends_job ? " LEFT JOIN job ON true" : "", fit ? " LEFT JOIN f ON true" : "",
      ends_job ? " LEFT JOIN done ON true" : "");
  return sql;
}

}  // namespace skinspec::store::postgresql
