#include "skinspec/records/record_json.hpp"

#include <fmt/format.h>

#include <chrono>

#include <stdexcept>

#include "fit_json.hpp"
#include "skinspec/records/fit_record.hpp"

namespace skinspec::records {

using Json = nlohmann::json;

namespace {

Json optional_id(const std::optional<store::Id>& id) { return id ? Json(*id) : Json(); }

Json samples(const store::SpectralSamples& s) {
  if (s.empty()) return Json();
  return {{"wavelength_nm", s.wavelength_nm}, {"values", s.values}};
}

// The store keeps these as JSON text (a CHECK constraint on the newer columns); text from
// before that, such as an old free-text configuration, is shown as a string.
Json embedded(const std::string& text) {
  Json value = Json::parse(text, nullptr, false);
  return value.is_discarded() ? Json(text) : value;
}

Json quality(int code, const std::string& text) { return {{"code", code}, {"text", text}}; }

std::string base64(std::string_view bytes) {
  static constexpr std::string_view kDigits = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  for (std::size_t i = 0; i < bytes.size(); i += 3) {
    const std::size_t n = std::min<std::size_t>(3, bytes.size() - i);
    std::uint32_t group = 0;
    for (std::size_t k = 0; k < 3; ++k) group = (group << 8) | (k < n ? static_cast<unsigned char>(bytes[i + k]) : 0u);
    for (std::size_t k = 0; k < 4; ++k) out += k <= n ? kDigits[(group >> (18 - 6 * k)) & 0x3f] : '=';
  }
  return out;
}

}  // namespace

std::string json_time(store::Time time) {
  const auto days = std::chrono::floor<std::chrono::days>(time);
  const std::chrono::year_month_day date{days};
  const std::chrono::hh_mm_ss clock{time - days};
  return fmt::format("{:04d}-{:02d}-{:02d}T{:02d}:{:02d}:{:02d}.{:06d}Z", static_cast<int>(date.year()),
                     static_cast<unsigned>(date.month()), static_cast<unsigned>(date.day()), clock.hours().count(),
                     clock.minutes().count(), clock.seconds().count(), clock.subseconds().count());
}

Json to_json(const store::Instrument& i) {
  return {{"id", i.id},
          {"model", i.model},
          {"serial_number", i.serial_number},
          {"spectral_configuration", embedded(i.spectral_configuration)},
          {"connection", i.connection},
          {"created_at", json_time(i.created_at)},
          {"last_seen_at", json_time(i.last_seen_at)}};
}

Json to_json(const store::WhiteStandard& s) {
  return {{"id", s.id},
          {"name", s.name},
          {"certificate", s.certificate},
          {"wavelength_nm", s.reflectance.wavelength_nm},
          {"reflectance", s.reflectance.values},
          {"created_at", json_time(s.created_at)}};
}

Json to_json(const store::Session& s) {
  return {{"id", s.id},
          {"subject", s.subject},
          {"site", s.site},
          {"operator", s.operator_name},
          {"notes", s.notes},
          {"model", s.model},
          {"bench", s.bench},
          {"white_standard_id", optional_id(s.white_standard_id)},
          {"state", store::to_string(s.state)},
          {"created_at", json_time(s.created_at)},
          {"updated_at", json_time(s.updated_at)},
          {"ended_at", s.ended_at ? Json(json_time(*s.ended_at)) : Json()}};
}

Json to_json(const store::Measurement& m, std::optional<store::Id> latest_fit_id) {
  return {{"id", m.id},
          {"session_id", m.session_id},
          {"kind", store::to_string(m.kind)},
          {"label", m.label},
          {"quality", quality(m.quality_code, m.quality)},
          {"units", m.units},
          {"reading_count", m.reading_count},
          {"radiance", samples(m.radiance)},
          {"radiance_sd", samples(m.radiance_sd)},
          {"reflectance", samples(m.reflectance)},
          {"warnings", m.warnings},
          {"provenance",
           {{"instrument_id", optional_id(m.instrument_id)},
            {"white_measurement_id", optional_id(m.white_measurement_id)},
            {"job_id", optional_id(m.job_id)},
            {"simulated", m.simulated},
            {"settings", embedded(m.settings)},
            {"raw_reply_base64", base64(m.raw_reply)},
            {"started_at", json_time(m.started_at)},
            {"finished_at", json_time(m.finished_at)}}},
          {"created_at", json_time(m.created_at)},
          {"fit_id", optional_id(latest_fit_id)}};
}

Json to_json(const store::RejectedReading& r) {
  return {{"id", r.id},
          {"session_id", r.session_id},
          {"job_id", optional_id(r.job_id)},
          {"instrument_id", optional_id(r.instrument_id)},
          {"attempt", r.attempt},
          {"quality", quality(r.quality_code, r.quality)},
          {"reason", r.reason},
          {"raw_reply_base64", base64(r.raw_reply)},
          {"measured_at", json_time(r.measured_at)},
          {"created_at", json_time(r.created_at)}};
}

Json to_json(const store::Fit& f) {
  const auto result = to_fit_result(f);
  // A store of this schema version holds only fits this version wrote or migrated.
  if (!result) throw std::runtime_error(result.error());
  Json out = fit_to_json("measurement-" + std::to_string(f.measurement_id), *result);
  out["id"] = f.id;
  out["measurement_id"] = f.measurement_id;
  out["samples_ignored"] = f.samples_ignored;
  out["solver_summary"] = f.solver_summary;
  out["options"] = embedded(f.options);
  out["model_version"] = f.model_version;
  out["tables_digest"] = f.tables_digest;
  out["constants_digest"] = f.constants_digest;
  out["created_at"] = json_time(f.created_at);
  return out;
}

Json to_json(const store::AuditEntry& e) {
  return {{"id", e.id},           {"at", json_time(e.at)}, {"token", e.token.empty() ? Json(nullptr) : Json(e.token)},
          {"address", e.address}, {"request", e.request},  {"change", e.change}};
}

std::optional<store::Id> latest_fit_of(store::Id measurement_id, const std::vector<store::Fit>& fits) {
  std::optional<store::Id> latest;
  for (const auto& f : fits)
    if (f.measurement_id == measurement_id) latest = f.id;
  return latest;
}

}  // namespace skinspec::records
