#include "support/engine_reference.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fmt/format.h>
#include <sstream>

#include "skinspec/spectral/spectra_csv.hpp"
#include "support/data.hpp"

namespace skinspec::testing {

namespace {

const std::string kNistForearms = "real-skin/nist_forearm_odd_subjects_379-781nm_3nm.csv";

[[noreturn]] void die(const std::string& message) {
  std::fprintf(stderr, "engine reference: %s\n", message.c_str());
  std::abort();
}

std::string number(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  return fmt::format("{:.17g}", v);
}

std::string verdict(Determination status, int correlated_with, ModelKind model) {
  std::string out(to_string(status));
  if (correlated_with >= 0)
    out += ":" + std::string(model_spec(model).params[static_cast<std::size_t>(correlated_with)].name);
  return out;
}

// Everything a fit answers, in a fixed order. The solver's iteration count is recorded too,
// for the reader, though a faster engine may take other steps to the same answer.
void append_fit(std::vector<EngineAnswer>& out, const std::string& spectrum, const FitResult& fit) {
  const std::string model(to_string(fit.model));
  const auto add = [&](std::string quantity, std::string value) {
    out.push_back({model, spectrum, std::move(quantity), std::move(value)});
  };
  const auto specs = model_spec(fit.model).params;
  add("converged", fit.converged ? "1" : "0");
  add("iterations", std::to_string(fit.iterations));
  for (std::size_t i = 0; i < specs.size(); ++i) {
    const std::string name(specs[i].name);
    add("param." + name, number(fit.params[i]));
    add("standard_error." + name, number(fit.standard_error[i]));
    add("determination." + name, verdict(fit.determination[i].status, fit.determination[i].correlated_with, fit.model));
  }
  for (std::size_t a = 0; a < specs.size(); ++a)
    for (std::size_t b = a + 1; b < specs.size(); ++b)
      add(fmt::format("correlation.{}.{}", specs[a].name, specs[b].name), number(fit.correlation_between(a, b)));
  for (const auto& [name, q] :
       {std::pair<std::string, const DerivedQuantity&>{"oxygen_saturation", fit.oxygen_saturation},
        {"blood_volume_fraction", fit.blood_volume_fraction}}) {
    add("derived_value." + name, number(q.value));
    add("derived_standard_error." + name, number(q.standard_error));
    add("derived_determination." + name, std::string(to_string(q.status)));
  }
  add("fitted_samples", std::to_string(fit.fitted.size()));
  add("rmse", number(fit.rmse));
  add("max_abs_error", number(fit.max_abs_error));
  add("delta_e00_d65", number(fit.delta_e00_d65));
}

}  // namespace

std::vector<EngineAnswer> engine_answers(ModelKind model) {
  auto spectra = parse_spectra_csv(data_file(kNistForearms), kNistForearms);
  if (!spectra) die(spectra.error().what());
  FitOptions options;
  options.model = model;
  std::vector<EngineAnswer> answers;
  for (const NamedSpectrum& s : *spectra) {
    auto fit = shipped_fitter().fit(s.spectrum, options);
    if (!fit) die(s.name + ": " + fit.error());
    append_fit(answers, s.name, *fit);
  }
  return answers;
}

std::string to_csv(const std::vector<EngineAnswer>& answers) {
  std::string out = "model,spectrum,quantity,value\n";
  for (const auto& a : answers) out += fmt::format("{},{},{},{}\n", a.model, a.spectrum, a.quantity, a.value);
  return out;
}

std::vector<EngineAnswer> parse_engine_answers(const std::string& csv) {
  std::vector<EngineAnswer> answers;
  std::istringstream in(csv);
  bool header = true;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line.starts_with('#')) continue;
    if (header) {
      header = false;
      continue;
    }
    std::vector<std::string> cells;
    std::istringstream fields(line);
    for (std::string cell; std::getline(fields, cell, ',');) cells.push_back(cell);
    if (cells.size() != 4) die("not 4 cells: " + line);
    answers.push_back({cells[0], cells[1], cells[2], cells[3]});
  }
  return answers;
}

}  // namespace skinspec::testing
