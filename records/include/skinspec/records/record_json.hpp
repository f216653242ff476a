#pragma once
// The JSON of each stored record: one function per record, used by the service's answers and
// by `skinspec export`, so that both show the same fields (docs/api.md, docs/store.md).
// Spectra are {"wavelength_nm": [...], "values": [...]} or null; times are json_time(); reply
// bytes are base64, since the meter's bytes need not be text; stored JSON text (settings,
// options, an instrument's configuration) is embedded as JSON.

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "skinspec/store/audit.hpp"
#include "skinspec/store/types.hpp"

namespace skinspec::records {

// RFC 3339 in UTC with microseconds: "2026-01-02T03:04:05.000123Z".
std::string json_time(store::Time time);

// id, model, serial_number, spectral_configuration (what the meter reported: points,
// bandwidth_nm, first_nm, last_nm, step_nm), connection, created_at, last_seen_at.
nlohmann::json to_json(const store::Instrument& instrument);
// id, name, certificate, wavelength_nm, reflectance, created_at: the fields it is created with.
nlohmann::json to_json(const store::WhiteStandard& standard);
nlohmann::json to_json(const store::Session& session);
// id, session_id, kind, label, quality {code, text}, units, reading_count, radiance,
// radiance_sd, reflectance, warnings, provenance {instrument_id, white_measurement_id, job_id,
// simulated, settings, raw_reply_base64, started_at, finished_at}, created_at, and fit_id (the
// measurement's latest fit, or null).
nlohmann::json to_json(const store::Measurement& measurement, std::optional<store::Id> latest_fit_id);
// id, session_id, job_id, instrument_id, attempt, quality {code, text}, reason,
// raw_reply_base64, measured_at, created_at.
nlohmann::json to_json(const store::RejectedReading& reading);
// The fields of `skinspec fit` (fit_to_json, `name` being "measurement-<id>"), then id,
// measurement_id, samples_ignored, solver_summary, options, model_version, tables_digest,
// created_at.
nlohmann::json to_json(const store::Fit& fit);

// id, at, token (its name; null when the change came without a token), address, request,
// change: one entry of the audit trail.
nlohmann::json to_json(const store::AuditEntry& entry);

// The id of the last of `fits` (in store order) that belongs to `measurement_id`.
std::optional<store::Id> latest_fit_of(store::Id measurement_id, const std::vector<store::Fit>& fits);

}  // namespace skinspec::records
