#include "skinspec/store/export.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <ctime>
#include <map>
#include <nlohmann/json.hpp>
#include <ostream>

namespace skinspec::store {

namespace {

using Json = nlohmann::json;

std::string iso8601(Time time) {
  const auto seconds = std::chrono::floor<std::chrono::seconds>(time);
  const auto micros = (time - seconds).count();
  const std::time_t t = std::chrono::system_clock::to_time_t(seconds);
  std::tm utc{};
  gmtime_r(&t, &utc);
  return fmt::format("{:04d}-{:02d}-{:02d}T{:02d}:{:02d}:{:02d}.{:06d}Z", utc.tm_year + 1900, utc.tm_mon + 1,
                     utc.tm_mday, utc.tm_hour, utc.tm_min, utc.tm_sec, micros);
}

Json optional_time(const std::optional<Time>& time) { return time ? Json(iso8601(*time)) : Json(); }
Json optional_id(const std::optional<Id>& id) { return id ? Json(*id) : Json(); }

std::string base64(std::string_view bytes) {
  static constexpr std::string_view kDigits = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  for (std::size_t i = 0; i < bytes.size(); i += 3) {
    const std::size_t n = std::min<std::size_t>(3, bytes.size() - i);
    std::uint32_t group = 0;
    for (std::size_t k = 0; k < 3; ++k)
      group = (group << 8) | (k < n ? static_cast<unsigned char>(bytes[i + k]) : 0u);
    for (std::size_t k = 0; k < 4; ++k)
      out += k <= n ? kDigits[(group >> (18 - 6 * k)) & 0x3f] : '=';
  }
  return out;
}

Json spectrum_json(const SpectralSamples& s) {
  if (s.empty()) return Json();
  return {{"wavelength_nm", s.wavelength_nm}, {"values", s.values}};
}

// JSON text stored by the store is valid (a CHECK constraint); embed it as JSON.
Json embedded(const std::string& text) {
  auto parsed = Json::parse(text, nullptr, false);
  return parsed.is_discarded() ? Json(text) : parsed;
}

Json params_json(const FitParams& values) {
  Json out = Json::object();
  for (std::size_t i = 0; i < kFitParamCount; ++i)
    out[std::string(kFitParamNames[i])] = std::isfinite(values[i]) ? Json(values[i]) : Json();
  return out;
}

// The fields of `skinspec fit`, then where the fit came from.
Json fit_json(const Fit& f) {
  return {{"id", f.id},
          {"measurement_id", f.measurement_id},
          {"site", f.site},
          {"params", params_json(f.params)},
          {"stderr", params_json(f.standard_error)},
          {"rmse", f.rmse},
          {"max_abs_error", f.max_abs_error},
          {"delta_e00_d65", f.delta_e00_d65},
          {"iterations", f.iterations},
          {"converged", f.converged},
          {"wavelength_nm", f.wavelength_nm},
          {"measured", f.measured},
          {"fitted", f.fitted},
          {"samples_ignored", f.samples_ignored},
          {"solver_summary", f.solver_summary},
          {"options", embedded(f.options)},
          {"model_version", f.model_version},
          {"tables_digest", f.tables_digest},
          {"created_at", iso8601(f.created_at)}};
}

Json measurement_json(const Measurement& m, const std::vector<Fit>& fits) {
  Json fits_json = Json::array();
  for (const auto& f : fits)
    if (f.measurement_id == m.id) fits_json.push_back(fit_json(f));
  return {{"id", m.id},
          {"kind", to_string(m.kind)},
          {"label", m.label},
          {"instrument_id", optional_id(m.instrument_id)},
          {"white_measurement_id", optional_id(m.white_measurement_id)},
          {"job_id", optional_id(m.job_id)},
          {"simulated", m.simulated},
          {"quality_code", m.quality_code},
          {"quality", m.quality},
          {"units", m.units},
          {"settings", embedded(m.settings)},
          {"reading_count", m.reading_count},
          {"radiance", spectrum_json(m.radiance)},
          {"radiance_sd", spectrum_json(m.radiance_sd)},
          {"reflectance", spectrum_json(m.reflectance)},
          {"warnings", m.warnings},
          {"raw_reply_base64", base64(m.raw_reply)},
          {"started_at", iso8601(m.started_at)},
          {"finished_at", iso8601(m.finished_at)},
          {"created_at", iso8601(m.created_at)},
          {"fits", std::move(fits_json)}};
}

Json rejected_reading_json(const RejectedReading& r) {
  return {{"id", r.id},
          {"job_id", optional_id(r.job_id)},
          {"instrument_id", optional_id(r.instrument_id)},
          {"attempt", r.attempt},
          {"quality_code", r.quality_code},
          {"quality", r.quality},
          {"reason", r.reason},
          {"raw_reply_base64", base64(r.raw_reply)},
          {"measured_at", iso8601(r.measured_at)},
          {"created_at", iso8601(r.created_at)}};
}

Json session_json(const Session& s) {
  return {{"id", s.id},
          {"subject", s.subject},
          {"site", s.site},
          {"operator", s.operator_name},
          {"notes", s.notes},
          {"white_standard_id", optional_id(s.white_standard_id)},
          {"state", to_string(s.state)},
          {"created_at", iso8601(s.created_at)},
          {"updated_at", iso8601(s.updated_at)},
          {"ended_at", optional_time(s.ended_at)}};
}

Json white_standard_json(const WhiteStandard& w) {
  return {{"id", w.id},
          {"name", w.name},
          {"certificate", w.certificate},
          {"reflectance", spectrum_json(w.reflectance)},
          {"created_at", iso8601(w.created_at)}};
}

Json instrument_json(const Instrument& i) {
  return {{"id", i.id},
          {"model", i.model},
          {"serial_number", i.serial_number},
          {"spectral_configuration", i.spectral_configuration},
          {"connection", i.connection},
          {"created_at", iso8601(i.created_at)},
          {"last_seen_at", iso8601(i.last_seen_at)}};
}

Result<Json> detail_json(const Store& store, const SessionDetail& detail) {
  Json out = {{"session", session_json(detail.session)}, {"white_standard", Json()}};
  if (detail.session.white_standard_id) {
    auto white = store.white_standard(*detail.session.white_standard_id);
    if (!white) return std::unexpected(white.error());
    out["white_standard"] = white_standard_json(*white);
  }
  std::vector<Id> instrument_ids;
  for (const auto& m : detail.measurements)
    if (m.instrument_id) instrument_ids.push_back(*m.instrument_id);
  for (const auto& r : detail.rejected_readings)
    if (r.instrument_id) instrument_ids.push_back(*r.instrument_id);
  std::ranges::sort(instrument_ids);
  instrument_ids.erase(std::unique(instrument_ids.begin(), instrument_ids.end()), instrument_ids.end());
  out["instruments"] = Json::array();
  for (const Id id : instrument_ids) {
    auto instrument = store.instrument(id);
    if (!instrument) return std::unexpected(instrument.error());
    out["instruments"].push_back(instrument_json(*instrument));
  }
  out["measurements"] = Json::array();
  for (const auto& m : detail.measurements) out["measurements"].push_back(measurement_json(m, detail.fits));
  out["rejected_readings"] = Json::array();
  for (const auto& r : detail.rejected_readings) out["rejected_readings"].push_back(rejected_reading_json(r));
  return out;
}

// RFC 4180: quoted when it holds a comma, a quote or a line break; quotes doubled.
std::string csv_field(std::string_view text) {
  if (text.find_first_of(",\"\r\n") == std::string_view::npos) return std::string(text);
  std::string out = "\"";
  for (const char c : text) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + '"';
}

std::string number(double v) { return fmt::format("{}", v); }

using Column = std::map<double, double>;

Column column_of(const std::vector<double>& grid, const std::vector<double>& values) {
  Column out;
  for (std::size_t i = 0; i < grid.size(); ++i) out.emplace(grid[i], values[i]);
  return out;
}

std::string value_at(const Column& column, double wavelength) {
  const auto found = column.find(wavelength);
  return found == column.end() ? std::string() : number(found->second);
}

void write_csv_rows(std::ostream& out, const Session& s, const Measurement& m, const Fit* fit) {
  const Column radiance = column_of(m.radiance.wavelength_nm, m.radiance.values);
  const Column sd = column_of(m.radiance_sd.wavelength_nm, m.radiance_sd.values);
  const Column reflectance = column_of(m.reflectance.wavelength_nm, m.reflectance.values);
  const Column fitted = fit ? column_of(fit->wavelength_nm, fit->fitted) : Column();
  std::map<double, bool> grid;
  for (const auto* column : {&radiance, &sd, &reflectance, &fitted})
    for (const auto& [w, v] : *column) grid[w] = true;

  std::string prefix = fmt::format("{},{},{},{},{},{},{},{},{},{},{},", s.id, csv_field(s.subject), csv_field(s.site),
                                   to_string(s.state), m.id, to_string(m.kind), csv_field(m.label),
                                   m.simulated ? 1 : 0, m.quality_code, m.reading_count, iso8601(m.started_at));
  if (fit) {
    prefix += fmt::format("{},", fit->id);
    for (const double p : fit->params) prefix += number(p) + ",";
    prefix += fmt::format("{},{},{},{},{},{},", number(fit->rmse), number(fit->max_abs_error),
                          number(fit->delta_e00_d65), fit->converged ? 1 : 0, csv_field(fit->model_version),
                          csv_field(fit->tables_digest));
  } else {
    prefix += std::string(12, ',');
  }
  for (const auto& [w, unused] : grid) {
    out << prefix << number(w) << ',' << value_at(radiance, w) << ',' << value_at(sd, w) << ','
        << value_at(reflectance, w) << ',' << value_at(fitted, w) << '\n';
  }
}

}  // namespace

void write_csv_header(std::ostream& out) {
  out << "session_id,subject,site,session_state,measurement_id,kind,label,simulated,quality_code,reading_count,"
         "started_at,fit_id,surface_reflectance,melanin,oxyhemoglobin,deoxyhemoglobin,bilirubin,rmse,max_abs_error,"
         "delta_e00_d65,converged,model_version,tables_digest,wavelength_nm,radiance,radiance_sd,reflectance,"
         "fitted\n";
}

Result<void> export_session(const Store& store, Id session_id, ExportFormat format, std::ostream& out) {
  auto detail = store.session_detail(session_id);
  if (!detail) return std::unexpected(detail.error());
  if (format == ExportFormat::json) {
    auto json = detail_json(store, *detail);
    if (!json) return std::unexpected(json.error());
    out << json->dump(-1, ' ', false, Json::error_handler_t::replace) << '\n';
    return {};
  }
  for (const auto& m : detail->measurements) {
    bool any = false;
    for (const auto& f : detail->fits) {
      if (f.measurement_id != m.id) continue;
      write_csv_rows(out, detail->session, m, &f);
      any = true;
    }
    if (!any) write_csv_rows(out, detail->session, m, nullptr);
  }
  return {};
}

Result<void> export_all(const Store& store, ExportFormat format, std::ostream& out) {
  std::vector<Id> ids;
  SessionFilter filter;
  filter.limit = 1000;
  for (;;) {
    auto page = store.sessions(filter);
    if (!page) return std::unexpected(page.error());
    for (const auto& s : page->sessions) ids.push_back(s.id);
    if (!page->next_cursor) break;
    filter.cursor = page->next_cursor;
  }
  std::ranges::reverse(ids);
  if (format == ExportFormat::csv) write_csv_header(out);
  for (const Id id : ids) {
    if (auto written = export_session(store, id, format, out); !written) return written;
  }
  return {};
}

}  // namespace skinspec::store
