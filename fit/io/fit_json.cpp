#include "fit_json.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <numeric>
#include <optional>
#include <vector>

namespace skinspec {

namespace {

nlohmann::json finite_or_null(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

std::string_view param_name(ModelKind model, std::size_t i) { return model_spec(model).params[i].name; }

// JSON text written as it goes: no values built first, for the judgement every stored fit
// keeps (an import or a refit writes thousands a second). Keys come in the order the callers
// give, which is sorted, as the JSON library keeps an object's keys.
class JsonText {
 public:
  JsonText& open(char bracket) {
    separate();
    out_ += bracket;
    first_ = true;
    return *this;
  }
  JsonText& close(char bracket) {
    out_ += bracket;
    first_ = false;
    return *this;
  }
  JsonText& key(std::string_view name) {
    string(name);
    out_ += ':';
    first_ = true;
    return *this;
  }
  // The shortest text that reads back as `v`, with ".0" where it would read as an integer;
  // null for a value that is not finite.
  JsonText& number(double v) {
    if (!std::isfinite(v)) return null();
    separate();
    char text[32];
    const std::string_view written(std::begin(text), std::to_chars(std::begin(text), std::end(text), v).ptr);
    out_ += written;
    if (written.find_first_of(".e") == std::string_view::npos) out_ += ".0";
    return *this;
  }
  JsonText& boolean(bool v) { return literal(v ? "true" : "false"); }
  JsonText& null() { return literal("null"); }
  // As it is between quotes when nothing in it needs escaping (names and reasons never do),
  // else as the JSON library writes it (a note may hold anything).
  JsonText& string(std::string_view text) {
    separate();
    const bool plain = std::ranges::all_of(text, [](char c) { return c >= 0x20 && c < 0x7f && c != '"' && c != '\\'; });
    if (plain) {
      out_ += '"';
      out_ += text;
      out_ += '"';
    } else {
      out_ += nlohmann::json(text).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
    }
    return *this;
  }
  std::string take() { return std::move(out_); }

 private:
  JsonText& literal(std::string_view text) {
    separate();
    out_ += text;
    return *this;
  }
  void separate() {
    if (!first_) out_ += ',';
    first_ = false;
  }

  std::string out_;
  bool first_ = true;
};

// {correlated_with?, determined, reason?}
void write_determination(JsonText& out, const FitResult& fit, const ParamDetermination& d) {
  out.open('{');
  if (d.correlated_with >= 0)
    out.key("correlated_with").string(param_name(fit.model, static_cast<std::size_t>(d.correlated_with)));
  out.key("determined").boolean(d.determined());
  if (!d.determined()) out.key("reason").string(to_string(d.status));
  out.close('}');
}

// {determined, reason?, stderr, value}
void write_derived(JsonText& out, const DerivedQuantity& q) {
  out.open('{').key("determined").boolean(q.determined());
  if (!q.determined()) out.key("reason").string(to_string(q.status));
  out.key("stderr");
  if (q.determined()) out.number(q.standard_error);
  else out.null();
  out.key("value").number(q.value).close('}');
}

// The parameters' names in order, and their correlation matrix row by row (null where a
// parameter was not fitted): {matrix, params}.
void write_correlation(JsonText& out, const FitResult& fit) {
  const std::size_t n = fit.params.size();
  out.open('{').key("matrix").open('[');
  for (std::size_t i = 0; i < n; ++i) {
    out.open('[');
    for (std::size_t j = 0; j < n; ++j) out.number(fit.correlation_between(i, j));
    out.close(']');
  }
  out.close(']').key("params").open('[');
  for (std::size_t i = 0; i < n; ++i) out.string(param_name(fit.model, i));
  out.close(']').close('}');
}

void write_optional(JsonText& out, const std::optional<double>& v) {
  if (v) {
    out.number(*v);
  } else {
    out.null();
  }
}

void write_skin_tone(JsonText& out, const SkinTone& tone) {
  out.open('{');
  write_optional(out.key("erythema_index"), tone.erythema_index);
  out.key("ita_class").string(to_string(tone.ita_class));
  out.key("ita_deg").number(tone.ita_deg);
  write_optional(out.key("melanin_index"), tone.melanin_index);
  out.close('}');
}

}  // namespace

nlohmann::json params_to_json(ModelKind model, const Params& params) {
  nlohmann::json out = nlohmann::json::object();
  for (std::size_t i = 0; i < params.size(); ++i) out[std::string(param_name(model, i))] = finite_or_null(params[i]);
  return out;
}

std::string assessment_text(const FitResult& fit) {
  const std::size_t n = fit.params.size();
  JsonText out;
  out.open('{');
  if (fit.correlation.size() == n * n && n > 0) write_correlation(out.key("correlation"), fit);
  if (fit.determination.size() == n && n > 0) {
    out.key("derived").open('{');
    write_derived(out.key("blood_volume_fraction"), fit.blood_volume_fraction);
    write_derived(out.key("oxygen_saturation"), fit.oxygen_saturation);
    out.close('}');
    std::vector<std::size_t> by_name(n);
    std::iota(by_name.begin(), by_name.end(), 0);
    std::ranges::sort(by_name, {}, [&](std::size_t i) { return param_name(fit.model, i); });
    out.key("determination").open('{');
    for (const std::size_t i : by_name)
      write_determination(out.key(param_name(fit.model, i)), fit, fit.determination[i]);
    out.close('}');
  }
  if (!fit.coverage_note.empty()) out.key("note").string(fit.coverage_note);
  if (fit.skin_tone) write_skin_tone(out.key("skin_tone"), *fit.skin_tone);
  if (fit.termination) out.key("termination").string(to_string(*fit.termination));
  out.close('}');
  return out.take();
}

nlohmann::json assessment_to_json(const FitResult& fit) { return nlohmann::json::parse(assessment_text(fit)); }

std::string options_text(const FitOptions& options) {
  JsonText out;
  out.open('{').key("lateral_diffusion").boolean(options.lateral_diffusion).key("site").string(options.site);
  return out.close('}').take();
}

namespace {

double number_or_nan(const nlohmann::json& v) {
  return v.is_number() ? v.get<double>() : std::numeric_limits<double>::quiet_NaN();
}

std::optional<ParamDetermination> determination_from_json(ModelKind model, const nlohmann::json& j) {
  if (!j.is_object() || !j.contains("determined") || !j["determined"].is_boolean()) return std::nullopt;
  ParamDetermination d;
  if (j["determined"].get<bool>()) return d;
  if (!j.contains("reason") || !j["reason"].is_string()) return std::nullopt;
  const auto status = parse_determination(j["reason"].get<std::string>());
  if (!status) return std::nullopt;
  d.status = *status;
  if (j.contains("correlated_with")) {
    const auto other =
        j["correlated_with"].is_string() ? param_index(model, j["correlated_with"].get<std::string>()) : std::nullopt;
    if (!other) return std::nullopt;
    d.correlated_with = static_cast<int>(*other);
  }
  return d;
}

std::optional<DerivedQuantity> derived_from_json(const nlohmann::json& j) {
  if (!j.is_object() || !j.contains("value") || !j.contains("determined") || !j["determined"].is_boolean())
    return std::nullopt;
  DerivedQuantity q;
  q.value = number_or_nan(j["value"]);
  q.standard_error = j.contains("stderr") && j["stderr"].is_number() ? j["stderr"].get<double>()
                                                                     : std::numeric_limits<double>::infinity();
  if (!j["determined"].get<bool>()) {
    const auto status = j.contains("reason") && j["reason"].is_string()
                            ? parse_determination(j["reason"].get<std::string>())
                            : std::nullopt;
    if (!status) return std::nullopt;
    q.status = *status;
  }
  return q;
}

bool determinations_from_json(const nlohmann::json& j, FitResult& fit) {
  const auto specs = model_spec(fit.model).params;
  if (!j.is_object() || j.size() != fit.params.size() || specs.size() != fit.params.size()) return false;
  for (const auto& spec : specs) {
    const auto name = std::string(spec.name);
    const auto d = j.contains(name) ? determination_from_json(fit.model, j[name]) : std::nullopt;
    if (!d) return false;
    fit.determination.push_back(*d);
  }
  return true;
}

bool correlation_from_json(const nlohmann::json& j, FitResult& fit) {
  const std::size_t n = fit.params.size();
  if (!j.is_object() || !j.contains("matrix") || !j["matrix"].is_array() || j["matrix"].size() != n) return false;
  for (const auto& row : j["matrix"]) {
    if (!row.is_array() || row.size() != n) return false;
    for (const auto& v : row) fit.correlation.push_back(number_or_nan(v));
  }
  return true;
}

// A skin-tone index: a number, or null where the reflectance did not allow one. The outer
// nullopt is a key missing or holding anything else.
std::optional<std::optional<double>> index_from_json(const nlohmann::json& j, const char* key) {
  if (!j.contains(key)) return std::nullopt;
  if (j[key].is_null()) return std::optional<double>();
  if (j[key].is_number()) return std::optional<double>(j[key].get<double>());
  return std::nullopt;
}

}  // namespace

std::optional<SkinTone> skin_tone_from_json(const nlohmann::json& j) {
  if (!j.is_object() || !j.contains("ita_deg") || !j["ita_deg"].is_number() || !j.contains("ita_class") ||
      !j["ita_class"].is_string())
    return std::nullopt;
  const auto ita_class = parse_ita_class(j["ita_class"].get<std::string>());
  const auto melanin = index_from_json(j, "melanin_index"), erythema = index_from_json(j, "erythema_index");
  if (!ita_class || !melanin || !erythema) return std::nullopt;
  return SkinTone{.ita_deg = j["ita_deg"].get<double>(),
                  .ita_class = *ita_class,
                  .melanin_index = *melanin,
                  .erythema_index = *erythema};
}

bool assessment_from_json(const nlohmann::json& assessment, FitResult& fit) {
  if (!assessment.is_object()) return false;
  if (assessment.contains("determination") && !determinations_from_json(assessment["determination"], fit)) return false;
  if (assessment.contains("derived")) {
    const auto& derived = assessment["derived"];
    const auto saturation = derived.is_object() && derived.contains("oxygen_saturation")
                                ? derived_from_json(derived["oxygen_saturation"])
                                : std::nullopt;
    const auto blood = derived.is_object() && derived.contains("blood_volume_fraction")
                           ? derived_from_json(derived["blood_volume_fraction"])
                           : std::nullopt;
    if (!saturation || !blood) return false;
    fit.oxygen_saturation = *saturation;
    fit.blood_volume_fraction = *blood;
  }
  if (assessment.contains("correlation") && !correlation_from_json(assessment["correlation"], fit)) return false;
  if (assessment.contains("note")) {
    if (!assessment["note"].is_string()) return false;
    fit.coverage_note = assessment["note"].get<std::string>();
  }
  if (assessment.contains("skin_tone")) {
    fit.skin_tone = skin_tone_from_json(assessment["skin_tone"]);
    if (!fit.skin_tone) return false;
  }
  if (assessment.contains("termination")) {
    const auto& termination = assessment["termination"];
    fit.termination = termination.is_string() ? parse_termination(termination.get<std::string>()) : std::nullopt;
    if (!fit.termination) return false;
  }
  return true;
}

nlohmann::json fit_to_json(std::string_view name, const FitResult& fit) {
  const bool judged = fit.determination.size() == fit.params.size();
  Params shown_error = fit.standard_error;
  for (std::size_t i = 0; judged && i < shown_error.size(); ++i)
    if (!fit.determination[i].determined()) shown_error[i] = std::numeric_limits<double>::infinity();
  nlohmann::json out = {
      {"name", name},
      {"model", to_string(fit.model)},
      {"site", fit.site},
      {"params", params_to_json(fit.model, fit.params)},
      {"stderr", params_to_json(fit.model, shown_error)},
      {"rmse", fit.rmse},
      {"max_abs_error", fit.max_abs_error},
      {"delta_e00_d65", fit.delta_e00_d65},
      {"iterations", fit.iterations},
      {"converged", fit.converged},
      {"samples_ignored", fit.samples_ignored},
      {"wavelength_nm", fit.wavelength_nm},
      {"measured", fit.measured},
      {"fitted", fit.fitted},
  };
  out.update(assessment_to_json(fit));
  return out;
}

}  // namespace skinspec
