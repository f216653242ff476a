#include "rows.hpp"

#include <fmt/format.h>

#include "codec.hpp"

namespace skinspec::store::detail {

namespace {

template <typename T>
T parsed(std::optional<T> value, std::string_view text, std::string_view what) {
  if (!value) fail(StoreError::Kind::corrupt, fmt::format("{} '{}' is not one skinspec writes", what, text));
  return *value;
}

SpectralSamples optional_spectrum(const Statement& row, int column, std::string_view what) {
  if (row.is_null(column)) return {};
  return decode_spectrum(row.blob(column), what);
}

}  // namespace

Instrument read_instrument(const Statement& row) {
  Instrument out;
  out.id = row.integer(0);
  out.model = row.text(1);
  out.serial_number = row.text(2);
  out.spectral_configuration = row.text(3);
  out.connection = row.text(4);
  out.created_at = row.time(5);
  out.last_seen_at = row.time(6);
  return out;
}

WhiteStandard read_white_standard(const Statement& row) {
  WhiteStandard out;
  out.id = row.integer(0);
  out.name = row.text(1);
  out.certificate = row.text(2);
  out.reflectance = decode_spectrum(row.blob(3), "white_standards.reflectance");
  out.created_at = row.time(4);
  return out;
}

Session read_session(const Statement& row) {
  Session out;
  out.id = row.integer(0);
  out.subject = row.text(1);
  out.site = row.text(2);
  out.operator_name = row.text(3);
  out.notes = row.text(4);
  out.white_standard_id = row.optional_integer(5);
  const auto state = row.text(6);
  out.state = parsed(parse_session_state(state), state, "session state");
  out.created_at = row.time(7);
  out.updated_at = row.time(8);
  out.ended_at = row.optional_time(9);
  out.model = row.text(10);
  out.bench = row.text(11);
  return out;
}

Measurement read_measurement(const Statement& row) {
  Measurement out;
  out.id = row.integer(0);
  out.session_id = row.integer(1);
  const auto kind = row.text(2);
  out.kind = parsed(parse_measurement_kind(kind), kind, "measurement kind");
  out.label = row.text(3);
  out.instrument_id = row.optional_integer(4);
  out.white_measurement_id = row.optional_integer(5);
  out.job_id = row.optional_integer(6);
  out.simulated = row.boolean(7);
  out.quality_code = static_cast<int>(row.integer(8));
  out.quality = row.text(9);
  out.units = row.text(10);
  out.settings = row.text(11);
  out.reading_count = static_cast<int>(row.integer(12));
  out.radiance = decode_spectrum(row.blob(13), "measurements.radiance");
  out.radiance_sd = optional_spectrum(row, 14, "measurements.radiance_sd");
  out.reflectance = optional_spectrum(row, 15, "measurements.reflectance");
  out.warnings = decode_text_list(row.text(16), "measurements.warnings");
  out.raw_reply = row.blob(17);
  out.started_at = row.time(18);
  out.finished_at = row.time(19);
  out.created_at = row.time(20);
  return out;
}

Fit read_fit(const Statement& row) {
  Fit out;
  out.id = row.integer(0);
  out.measurement_id = row.integer(1);
  out.site = row.text(2);
  out.model = row.text(3);
  out.params = decode_fit_params(row.text(4), fmt::format("fit {} parameters", out.id));
  out.assessment = row.text(5);
  out.rmse = row.real(6);
  out.max_abs_error = row.real(7);
  out.delta_e00_d65 = row.real(8);
  out.iterations = static_cast<int>(row.integer(9));
  out.converged = row.boolean(10);
  out.solver_summary = row.text(11);
  out.options = row.text(12);
  out.model_version = row.text(13);
  out.tables_digest = row.text(14);
  out.constants_digest = row.text(15);
  auto measured = decode_spectrum(row.blob(16), "fits.measured");
  auto fitted = decode_spectrum(row.blob(17), "fits.fitted");
  if (measured.wavelength_nm != fitted.wavelength_nm)
    fail(StoreError::Kind::corrupt, fmt::format("fit {}: measured and fitted are on different grids", out.id));
  out.wavelength_nm = std::move(measured.wavelength_nm);
  out.measured = std::move(measured.values);
  out.fitted = std::move(fitted.values);
  out.samples_ignored = static_cast<int>(row.integer(18));
  out.created_at = row.time(19);
  return out;
}

Job read_job(const Statement& row) { return read_job_from(row, 0); }

Job read_job_from(const Statement& row, int first) {
  Job out;
  out.id = row.integer(first);
  out.kind = row.text(first + 1);
  out.request = row.text(first + 2);
  out.requested_by = row.text(first + 3);
  out.session_id = row.optional_integer(first + 4);
  out.idempotency_key = row.text(first + 5);  // NULL reads as empty
  const auto state = row.text(first + 6);
  out.state = parsed(parse_job_state(state), state, "job state");
  if (!row.is_null(first + 7)) out.error = decode_job_error(row.text(first + 7), "jobs.error");
  out.result = row.text(first + 8);
  out.created_at = row.time(first + 9);
  out.started_at = row.optional_time(first + 10);
  out.finished_at = row.optional_time(first + 11);
  out.bench = row.text(first + 12);
  return out;
}

AuditEntry read_audit_entry(const Statement& row) {
  AuditEntry out;
  out.id = row.integer(0);
  out.at = row.time(1);
  out.token = row.text(2);
  out.address = row.text(3);
  out.request = row.text(4);
  out.change = row.text(5);
  return out;
}

Bench read_bench(const Statement& row) {
  Bench out;
  out.name = row.text(0);
  out.host = row.text(1);
  out.pid = row.integer(2);
  out.started_at = row.time(3);
  out.heartbeat_at = row.time(4);
  out.lease = std::chrono::milliseconds(row.integer(5));
  out.instrument = row.text(6);
  out.stopped_at = row.optional_time(7);
  return out;
}

RejectedReading read_rejected_reading(const Statement& row) {
  RejectedReading out;
  out.id = row.integer(0);
  out.session_id = row.integer(1);
  out.job_id = row.optional_integer(2);
  out.instrument_id = row.optional_integer(3);
  out.attempt = static_cast<int>(row.integer(4));
  out.quality_code = static_cast<int>(row.integer(5));
  out.quality = row.text(6);
  out.reason = row.text(7);
  out.raw_reply = row.blob(8);
  out.measured_at = row.time(9);
  out.created_at = row.time(10);
  return out;
}

Map read_map(const Statement& row) {
  Map out;
  out.id = row.integer(0);
  out.job_id = row.integer(1);
  out.session_id = row.optional_integer(2);
  out.name = row.text(3);
  out.summary = row.text(4);
  out.header = row.text(5);
  out.data_bytes = row.integer(6);
  out.reflectance_bytes = row.integer(7);
  out.created_at = row.time(8);
  return out;
}

}  // namespace skinspec::store::detail
