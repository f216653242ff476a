#pragma once
// The columns each record is read with, and the decoders from a result row to a record. The
// SELECT lists and the decoders change together, here.

#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "skinspec/store/audit.hpp"
#include "skinspec/store/types.hpp"
#include "db.hpp"

namespace skinspec::store::detail {

inline constexpr std::string_view kInstrumentColumns =
    "id, model, serial_number, spectral_configuration, connection, created_at, last_seen_at";
inline constexpr std::string_view kWhiteStandardColumns = "id, name, certificate, reflectance, created_at";
inline constexpr std::string_view kSessionColumns =
    "id, subject, site, operator_name, notes, white_standard_id, state, created_at, updated_at, ended_at, model, bench";
inline constexpr std::string_view kMeasurementColumns =
    "id, session_id, kind, label, instrument_id, white_measurement_id, job_id, simulated, quality_code, quality, "
    "units, settings, reading_count, radiance, radiance_sd, reflectance, warnings, raw_reply, started_at, "
    "finished_at, created_at";
// The condition of a measurement every read may see: none of an import not yet published
// (docs/store.md, "Imports"). Its columns are the measurement's, unqualified.
inline constexpr std::string_view kPublished =
    "(import_id IS NULL OR import_id NOT IN (SELECT id FROM imports WHERE published_at IS NULL))";
inline constexpr std::string_view kFitColumns =
    "id, measurement_id, site, model, parameters, assessment, rmse, max_abs_error, delta_e00_d65, iterations, "
    "converged, solver_summary, options, model_version, tables_digest, constants_digest, measured, fitted, "
    "samples_ignored, created_at";
inline constexpr std::string_view kJobColumns =
    "id, kind, request, requested_by, session_id, idempotency_key, state, error, result, created_at, started_at, "
    "finished_at, bench";
inline constexpr std::string_view kAuditColumns = "id, at, token, address, request, change";
inline constexpr std::string_view kBenchColumns =
    "name, host, pid, started_at, heartbeat_at, lease_ms, instrument, stopped_at";
inline constexpr std::string_view kRejectedReadingColumns =
    "id, session_id, job_id, instrument_id, attempt, quality_code, quality, reason, raw_reply, measured_at, created_at";
inline constexpr std::string_view kMapColumns =
    "id, job_id, session_id, name, summary, header, data_bytes, reflectance_bytes, created_at";
// A map's data and pictures, their keys first (the copy pages through them by key).
inline constexpr std::string_view kMapDataColumns = "map_id, part, piece, bytes";
inline constexpr std::string_view kMapPictureColumns = "map_id, ordinal, parameter, png";

// Every row `sql` selects with `args` bound, each decoded by `read`.
template <typename Read, typename... Args>
auto all(Connection& c, const std::string& sql, Read read, const Args&... args) {
  auto rows = c.prepare(sql);
  rows.bind(args...);
  std::vector<std::invoke_result_t<Read, const Statement&>> out;
  while (rows.step()) out.push_back(read(rows));
  return out;
}

Instrument read_instrument(const Statement& row);
WhiteStandard read_white_standard(const Statement& row);
Session read_session(const Statement& row);
Measurement read_measurement(const Statement& row);
Fit read_fit(const Statement& row);
Job read_job(const Statement& row);
// The job whose columns (kJobColumns) start at column `first`.
Job read_job_from(const Statement& row, int first);
Bench read_bench(const Statement& row);
AuditEntry read_audit_entry(const Statement& row);
RejectedReading read_rejected_reading(const Statement& row);
// A map without its pictures' names, which come from map_pictures.
Map read_map(const Statement& row);

}  // namespace skinspec::store::detail
