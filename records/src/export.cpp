#include "skinspec/records/export.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <map>
#include <nlohmann/json.hpp>
#include <ostream>
#include <stdexcept>
#include <utility>
#include <vector>

#include "skinspec/records/cgats.hpp"
#include "skinspec/records/fit_record.hpp"
#include "skinspec/records/record_json.hpp"

namespace skinspec::records {

namespace {

using Json = nlohmann::json;
using store::AuditEntry;
using store::Fit;
using store::Id;
using store::Measurement;
using store::Result;
using store::Session;
using store::SessionDetail;
using store::SessionFilter;
using store::Store;
using store::StoreError;

// A measurement with its fits, each as the service shows it.
Json measurement_with_fits(const Measurement& m, const std::vector<Fit>& fits) {
  Json out = to_json(m, latest_fit_of(m.id, fits));
  out["fits"] = Json::array();
  for (const auto& f : fits)
    if (f.measurement_id == m.id) out["fits"].push_back(to_json(f));
  return out;
}

Result<Json> detail_json(const Store& store, const SessionDetail& detail) {
  Json out = {{"session", to_json(detail.session)}, {"white_standard", Json()}};
  if (detail.session.white_standard_id) {
    auto white = store.white_standard(*detail.session.white_standard_id);
    if (!white) return std::unexpected(white.error());
    out["white_standard"] = to_json(*white);
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
    out["instruments"].push_back(to_json(*instrument));
  }
  out["measurements"] = Json::array();
  for (const auto& m : detail.measurements) out["measurements"].push_back(measurement_with_fits(m, detail.fits));
  out["rejected_readings"] = Json::array();
  for (const auto& r : detail.rejected_readings) out["rejected_readings"].push_back(to_json(r));
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

// One column per parameter of any model, in the models' order: a fit leaves the columns of
// parameters its model does not have empty.
const std::vector<std::string>& parameter_columns() {
  static const auto columns = [] {
    std::vector<std::string> names;
    for (const auto model : kModelKinds)
      for (const auto& spec : model_spec(model).params)
        if (std::ranges::find(names, spec.name) == names.end()) names.emplace_back(spec.name);
    return names;
  }();
  return columns;
}

struct CsvColumn {
  std::string name;
  std::string unit;  // empty for text, counts, flags and times
};

// The CSV's columns with their units: a parameter's from its model (ParamSpec::unit, the same in
// every model that has it), a radiance's the measurement's own (its units column).
std::vector<CsvColumn> csv_columns() {
  std::vector<CsvColumn> columns;
  for (const char* name : {"session_id", "subject", "site", "session_state", "measurement_id", "kind", "label",
                           "simulated", "quality_code", "reading_count", "units", "started_at", "fit_id", "model"})
    columns.push_back({name, ""});
  for (const auto& name : parameter_columns()) {
    for (const auto model : kModelKinds)
      if (const auto i = param_index(model, name)) {
        columns.push_back({name, std::string(model_spec(model).params[*i].unit)});
        break;
      }
  }
  const std::string reflectance = "reflectance (fraction)", radiance = "as in units";
  columns.insert(columns.end(), {{"not_determined", ""},
                                 {"rmse", reflectance},
                                 {"max_abs_error", reflectance},
                                 {"delta_e00_d65", "CIEDE2000"},
                                 {"ita_deg", std::string(kItaUnit)},
                                 {"ita_class", ""},
                                 {"melanin_index", std::string(kSkinIndexUnit)},
                                 {"erythema_index", std::string(kSkinIndexUnit)},
                                 {"converged", ""},
                                 {"iterations", ""},
                                 {"termination", ""},
                                 {"model_version", ""},
                                 {"tables_digest", ""},
                                 {"constants_digest", ""},
                                 {"wavelength_nm", "nm"},
                                 {"radiance", radiance},
                                 {"radiance_sd", radiance},
                                 {"reflectance", "fraction"},
                                 {"fitted", "fraction"}});
  return columns;
}

std::string value_of(const Fit& fit, const std::string& name) {
  const auto found = std::ranges::find(fit.params, name, &store::FitParam::name);
  return found == fit.params.end() ? std::string() : number(found->value);
}

// The parameters the spectrum did not determine, with why: "bilirubin:at_bound;...".
std::string not_determined(const Fit& fit, const FitResult& result) {
  std::string out;
  for (std::size_t i = 0; i < result.determination.size(); ++i) {
    const auto& d = result.determination[i];
    if (d.determined()) continue;
    if (!out.empty()) out += ';';
    out += fmt::format("{}:{}", fit.params[i].name, to_string(d.status));
  }
  return out;
}

// ita_deg, ita_class, melanin_index and erythema_index; empty for a fit stored without them.
std::string skin_tone_fields(const std::optional<SkinTone>& tone) {
  if (!tone) return ",,,";
  const auto index = [](const std::optional<double>& v) { return v ? number(*v) : std::string(); };
  return fmt::format("{},{},{},{}", number(tone->ita_deg), to_string(tone->ita_class), index(tone->melanin_index),
                     index(tone->erythema_index));
}

void write_csv_rows(std::ostream& out, const Session& s, const Measurement& m, const Fit* fit) {
  const Column radiance = column_of(m.radiance.wavelength_nm, m.radiance.values);
  const Column sd = column_of(m.radiance_sd.wavelength_nm, m.radiance_sd.values);
  const Column reflectance = column_of(m.reflectance.wavelength_nm, m.reflectance.values);
  const Column fitted = fit ? column_of(fit->wavelength_nm, fit->fitted) : Column();
  std::map<double, bool> grid;
  for (const auto* column : {&radiance, &sd, &reflectance, &fitted})
    for (const auto& [w, v] : *column) grid[w] = true;

  std::string prefix =
      fmt::format("{},{},{},{},{},{},{},{},{},{},{},{},", s.id, csv_field(s.subject), csv_field(s.site),
                  to_string(s.state), m.id, to_string(m.kind), csv_field(m.label), m.simulated ? 1 : 0, m.quality_code,
                  m.reading_count, csv_field(m.units), json_time(m.started_at));
  if (fit) {
    const auto result = to_fit_result(*fit);
    if (!result) throw std::runtime_error(result.error());
    prefix += fmt::format("{},{},", fit->id, csv_field(fit->model));
    for (const auto& name : parameter_columns()) prefix += value_of(*fit, name) + ",";
    prefix += fmt::format("{},{},{},{},{},", csv_field(not_determined(*fit, *result)), number(fit->rmse),
                          number(fit->max_abs_error), number(fit->delta_e00_d65), skin_tone_fields(result->skin_tone));
    prefix +=
        fmt::format("{},{},{},{},{},{},", fit->converged ? 1 : 0, fit->iterations,
                    result->termination ? to_string(*result->termination) : std::string_view(),
                    csv_field(fit->model_version), csv_field(fit->tables_digest), csv_field(fit->constants_digest));
  } else {
    prefix += std::string(parameter_columns().size() + 16, ',');
  }
  for (const auto& [w, unused] : grid) {
    out << prefix << number(w) << ',' << value_at(radiance, w) << ',' << value_at(sd, w) << ','
        << value_at(reflectance, w) << ',' << value_at(fitted, w) << '\n';
  }
}

}  // namespace

void write_csv_header(std::ostream& out) {
  const auto columns = csv_columns();
  out << "# units";
  for (std::size_t i = 1; i < columns.size(); ++i) out << ',' << csv_field(columns[i].unit);
  out << '\n';
  for (std::size_t i = 0; i < columns.size(); ++i) out << (i == 0 ? "" : ",") << columns[i].name;
  out << '\n';
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
  if (format == ExportFormat::cgats) {
    if (auto written = write_cgats(*detail, out); !written)
      return std::unexpected(store::StoreError{store::StoreError::Kind::invalid_argument, written.error(), 0});
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

Result<void> export_audit(const Store& store, ExportFormat format, std::ostream& out) {
  if (format == ExportFormat::cgats)
    return std::unexpected(StoreError{StoreError::Kind::invalid_argument, "the audit trail has no CGATS form", 0});
  // The store reads the trail newest first, a page at a time.
  std::vector<AuditEntry> entries;
  std::optional<Id> before;
  for (;;) {
    constexpr int kPage = 1000;
    auto page = store.audit(before, kPage);
    if (!page) return std::unexpected(page.error());
    entries.insert(entries.end(), page->begin(), page->end());
    if (std::cmp_less(page->size(), kPage)) break;
    before = page->back().id;
  }
  std::ranges::reverse(entries);
  if (format == ExportFormat::csv) out << "id,at,token,address,request,change\n";
  for (const auto& e : entries) {
    if (format == ExportFormat::json) {
      out << to_json(e).dump(-1, ' ', false, Json::error_handler_t::replace) << '\n';
    } else {
      out << e.id << ',' << json_time(e.at) << ',' << csv_field(e.token) << ',' << csv_field(e.address) << ','
          << csv_field(e.request) << ',' << csv_field(e.change) << '\n';
    }
  }
  return {};
}

}  // namespace skinspec::records
