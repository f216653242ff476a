#include "json_io.hpp"

#include <cmath>

#include "fit_json.hpp"
#include "text.hpp"

namespace skinspec::api::detail {

using nlohmann::json;

void fail(ErrorKind kind, std::string code, std::string message) {
  throw HandlerError{ApiError{kind, std::move(code), std::move(message)}};
}

void fail_store(const store::StoreError& error) {
  using K = store::StoreError::Kind;
  switch (error.kind) {
    case K::invalid_argument: fail(ErrorKind::unprocessable, "invalid_value", error.message);
    case K::not_found: fail(ErrorKind::not_found, "not_found", error.message);
    case K::conflict: fail(ErrorKind::conflict, "conflict", error.message);
    case K::busy: fail(ErrorKind::unavailable, "database_busy", error.message);
    case K::full: fail(ErrorKind::unavailable, "database_full", error.message);
    case K::read_only: fail(ErrorKind::unavailable, "database_read_only", error.message);
    default: fail(ErrorKind::internal, "database_error", std::string(store::to_string(error.kind)) + ": " + error.message);
  }
}

json parse_object(const std::string& body) {
  if (!valid_utf8(body)) fail(ErrorKind::bad_request, "invalid_utf8", "the body is not valid UTF-8");
  json value = json::parse(body, nullptr, false);
  if (value.is_discarded()) fail(ErrorKind::bad_request, "malformed_json", "the body is not well-formed JSON");
  if (!value.is_object()) fail(ErrorKind::unprocessable, "wrong_type", "the body must be a JSON object");
  return value;
}

void only_fields(const json& object, std::initializer_list<const char*> allowed) {
  for (const auto& item : object.items()) {
    bool known = false;
    for (const char* name : allowed) known = known || item.key() == name;
    if (!known) fail(ErrorKind::unprocessable, "unknown_field", "unknown field '" + item.key() + "'");
  }
}

std::optional<std::string> optional_string(const json& object, const char* key, std::size_t max_length) {
  const auto it = object.find(key);
  if (it == object.end() || it->is_null()) return std::nullopt;
  if (!it->is_string()) fail(ErrorKind::unprocessable, "wrong_type", std::string("'") + key + "' must be a string");
  auto text = it->get<std::string>();
  if (text.size() > max_length)
    fail(ErrorKind::unprocessable, "too_long", std::string("'") + key + "' is longer than " + std::to_string(max_length) + " bytes");
  return text;
}

std::string required_string(const json& object, const char* key, std::size_t max_length) {
  auto text = optional_string(object, key, max_length);
  if (!text) fail(ErrorKind::unprocessable, "missing_field", std::string("'") + key + "' is required");
  if (text->empty()) fail(ErrorKind::unprocessable, "invalid_value", std::string("'") + key + "' must not be empty");
  return *text;
}

std::optional<bool> optional_bool(const json& object, const char* key) {
  const auto it = object.find(key);
  if (it == object.end() || it->is_null()) return std::nullopt;
  if (!it->is_boolean()) fail(ErrorKind::unprocessable, "wrong_type", std::string("'") + key + "' must be true or false");
  return it->get<bool>();
}

std::optional<store::Id> optional_id(const json& object, const char* key) {
  const auto it = object.find(key);
  if (it == object.end() || it->is_null()) return std::nullopt;
  if (!it->is_number_integer() || it->get<std::int64_t>() <= 0 ||
      (it->is_number_unsigned() && it->get<std::uint64_t>() > static_cast<std::uint64_t>(INT64_MAX)))
    fail(ErrorKind::unprocessable, "wrong_type", std::string("'") + key + "' must be a positive integer id");
  return it->get<store::Id>();
}

std::vector<double> number_array(const json& value, const std::string& name, double min, double max, std::size_t max_size) {
  if (!value.is_array()) fail(ErrorKind::unprocessable, "wrong_type", "'" + name + "' must be an array of numbers");
  if (value.size() < 2 || value.size() > max_size)
    fail(ErrorKind::unprocessable, "invalid_length",
         "'" + name + "' must have 2 to " + std::to_string(max_size) + " values, not " + std::to_string(value.size()));
  std::vector<double> out;
  out.reserve(value.size());
  for (std::size_t i = 0; i < value.size(); ++i) {
    const json& v = value[i];
    if (!v.is_number()) fail(ErrorKind::unprocessable, "wrong_type", "'" + name + "'[" + std::to_string(i) + "] is not a number");
    const double x = v.get<double>();
    if (!std::isfinite(x) || x < min || x > max)
      fail(ErrorKind::unprocessable, "out_of_range",
           "'" + name + "'[" + std::to_string(i) + "] must be finite and within [" + json(min).dump() + ", " +
               json(max).dump() + "]");
    out.push_back(x);
  }
  return out;
}

namespace {
json samples(const store::SpectralSamples& s) {
  if (s.empty()) return nullptr;
  return {{"wavelength_nm", s.wavelength_nm}, {"values", s.values}};
}
json optional_value(const std::optional<store::Id>& id) { return id ? json(*id) : json(nullptr); }
json object_text(const std::string& text) {
  json value = json::parse(text, nullptr, false);
  return value.is_discarded() ? json(text) : value;
}
}  // namespace

json to_json(const store::WhiteStandard& s) {
  return {{"id", s.id},
          {"name", s.name},
          {"certificate", s.certificate},
          {"wavelength_nm", s.reflectance.wavelength_nm},
          {"reflectance", s.reflectance.values},
          {"created_at", format_time(s.created_at)}};
}

json to_json(const store::Session& s) {
  return {{"id", s.id},
          {"subject", s.subject},
          {"site", s.site},
          {"operator", s.operator_name},
          {"notes", s.notes},
          {"white_standard_id", optional_value(s.white_standard_id)},
          {"state", store::to_string(s.state)},
          {"created_at", format_time(s.created_at)},
          {"updated_at", format_time(s.updated_at)},
          {"ended_at", s.ended_at ? json(format_time(*s.ended_at)) : json(nullptr)}};
}

json to_json(const store::Measurement& m, std::optional<store::Id> fit_id) {
  return {{"id", m.id},
          {"session_id", m.session_id},
          {"kind", store::to_string(m.kind)},
          {"label", m.label},
          {"quality", {{"code", m.quality_code}, {"text", m.quality}}},
          {"units", m.units},
          {"reading_count", m.reading_count},
          {"radiance", samples(m.radiance)},
          {"radiance_sd", samples(m.radiance_sd)},
          {"reflectance", samples(m.reflectance)},
          {"warnings", m.warnings},
          {"provenance",
           {{"instrument_id", optional_value(m.instrument_id)},
            {"white_measurement_id", optional_value(m.white_measurement_id)},
            {"job_id", optional_value(m.job_id)},
            {"simulated", m.simulated},
            {"settings", object_text(m.settings)},
            {"raw_reply", m.raw_reply},
            {"started_at", format_time(m.started_at)},
            {"finished_at", format_time(m.finished_at)}}},
          {"created_at", format_time(m.created_at)},
          {"fit_id", optional_value(fit_id)}};
}

json to_json(const store::RejectedReading& r) {
  return {{"id", r.id},
          {"job_id", optional_value(r.job_id)},
          {"instrument_id", optional_value(r.instrument_id)},
          {"attempt", r.attempt},
          {"quality", {{"code", r.quality_code}, {"text", r.quality}}},
          {"reason", r.reason},
          {"raw_reply_bytes", r.raw_reply.size()},
          {"measured_at", format_time(r.measured_at)},
          {"created_at", format_time(r.created_at)}};
}

json to_json(const store::Fit& f) {
  FitResult r;
  r.model = kServiceModel;
  r.site = f.site;
  r.params.assign(f.params.begin(), f.params.end());
  r.standard_error.assign(f.standard_error.begin(), f.standard_error.end());
  r.rmse = f.rmse;
  r.max_abs_error = f.max_abs_error;
  r.delta_e00_d65 = f.delta_e00_d65;
  r.iterations = f.iterations;
  r.converged = f.converged;
  r.solver_message = f.solver_summary;
  r.wavelength_nm = f.wavelength_nm;
  r.measured = f.measured;
  r.fitted = f.fitted;
  r.samples_ignored = static_cast<std::size_t>(f.samples_ignored);
  json out = fit_to_json("measurement-" + std::to_string(f.measurement_id), r);
  out["id"] = f.id;
  out["measurement_id"] = f.measurement_id;
  out["options"] = object_text(f.options);
  out["model_version"] = f.model_version;
  out["tables_digest"] = f.tables_digest;
  out["samples_ignored"] = f.samples_ignored;
  out["created_at"] = format_time(f.created_at);
  return out;
}

store::Fit to_store_fit(const FitResult& r, const json& options, const std::string& model_version,
                        const std::string& tables_digest) {
  store::Fit f;
  f.site = r.site;
  for (std::size_t i = 0; i < store::kFitParamCount; ++i) {
    f.params[i] = r.params[i];
    f.standard_error[i] = r.standard_error[i];
  }
  f.rmse = r.rmse;
  f.max_abs_error = r.max_abs_error;
  f.delta_e00_d65 = r.delta_e00_d65;
  f.iterations = r.iterations;
  f.converged = r.converged;
  f.solver_summary = r.solver_message;
  f.options = options.dump();
  f.model_version = model_version;
  f.tables_digest = tables_digest;
  f.wavelength_nm = r.wavelength_nm;
  f.measured = r.measured;
  f.fitted = r.fitted;
  f.samples_ignored = static_cast<int>(r.samples_ignored);
  return f;
}

std::string dump(const json& value) { return value.dump(-1, ' ', false, json::error_handler_t::replace); }

}  // namespace skinspec::api::detail
