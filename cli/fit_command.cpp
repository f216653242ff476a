// skinspec fit FILE: one JSON line per spectrum column, fitted on all cores.

#include <cmath>
#include <fmt/format.h>
#include <iostream>

#include "common.hpp"
#include "fit_json.hpp"
#include "fit_text.hpp"
#include "model_options.hpp"
#include "skinspec/spectral/parallel.hpp"

namespace skinspec::cli {

namespace {

struct FitArgs {
  std::string file;
  ModelKind model = kDefaultModel;
  std::string site = "forearm";
  bool no_lateral_diffusion = false;
  std::vector<std::string> fixes;
  std::string format = "json";
  ScaleRequest scale = ScaleRequest::automatic;
};

// "4.2 ± 0.3"; "1.3 held" for a parameter held at a value; "n.d." where the spectrum does not
// determine it.
std::string with_error(double value, double error, const ParamDetermination& d) {
  if (d.status == Determination::held) return fmt::format("{:.4g} held", value);
  if (!d.determined()) return "n.d.";
  return fmt::format("{:.4g} ± {:.2g}", value, error);
}

// A human-readable table: one row per spectrum, a column per parameter of the model; the units
// above it, what "n.d." means below.
void print_table(ModelKind model, const std::vector<NamedSpectrum>& spectra,
                 const std::vector<std::expected<FitResult, std::string>>& results) {
  const auto params = model_spec(model).params;
  std::vector<std::string> names;
  for (const ParamSpec& p : params) names.emplace_back(p.name);
  std::cout << units_line(to_string(model), names, "rmse", "dE00") << '\n';
  std::cout << fmt::format("{:<14} ", "spectrum");
  for (const ParamSpec& p : params)
    std::cout << fmt::format("{:<{}} ", p.name, std::max<std::size_t>(16, p.name.size()));
  std::cout << fmt::format("{:>7} {:>6}{} {:>5} {}\n", "rmse", "dE00", skin_tone_header(), "iter", "termination");
  for (std::size_t i = 0; i < results.size(); ++i) {
    const FitResult& r = *results[i];
    std::cout << fmt::format("{:<14} ", printable(spectra[i].name));
    for (std::size_t p = 0; p < params.size(); ++p)
      std::cout << fmt::format("{:<{}} ", with_error(r.params[p], r.standard_error[p], r.determination[p]),
                               std::max<std::size_t>(16, params[p].name.size()));
    std::cout << fmt::format("{:>7.4f} {:>6.2f}{} {:>5} {}\n", r.rmse, r.delta_e00_d65, skin_tone_cells(r.skin_tone),
                             r.iterations,
                             r.termination ? to_string(*r.termination) : "unknown");
  }
  std::cout << not_determined_line("--format json") << '\n';
}

// Fits every spectrum, spread over the machine's cores; results keep the input order.
std::vector<std::expected<FitResult, std::string>> fit_all(const std::vector<NamedSpectrum>& spectra,
                                                           const FitOptions& options) {
  std::vector<std::expected<FitResult, std::string>> results(spectra.size());
  parallel_for(spectra.size(), 0, [&](std::size_t i) { results[i] = fitter().fit(spectra[i].spectrum, options); });
  return results;
}

void run_fit(const FitArgs& args) {
  SpectraLimits limits;
  limits.must_cover_from_nm = kMinCoverFromNm;
  limits.must_cover_to_nm = kMinCoverToNm;
  limits.scale = args.scale;
  const auto [spectra, scale] = read_spectra_file(args.file, limits);
  if (scale.scale == ReflectanceScale::percent)
    std::cerr << "skinspec: " << input_name(args.file) << ": values read as " << describe(scale) << '\n';
  FitOptions options{.model = args.model,
                     .site = args.site,
                     .lateral_diffusion = !args.no_lateral_diffusion,
                     .weights = {},
                     .held = held_for(args.model, args.fixes), .start = {}};
  if (auto site = fitter().optics(args.model).site(args.site); !site) throw Failure{kBadInput, site.error()};
  const auto results = fit_all(spectra, options);
  // Refuse the whole file before printing anything, so a failure never leaves partial output.
  for (std::size_t i = 0; i < results.size(); ++i)
    if (!results[i])
      throw Failure{kBadInput,
                    input_name(args.file) + ": column " + quote(spectra[i].name) + ": " + results[i].error()};
  if (args.format == "table") {
    print_table(args.model, spectra, results);
  } else {
    for (std::size_t i = 0; i < results.size(); ++i) {
      auto line = fit_to_json(spectra[i].name, *results[i]);
      line["scale"] = to_string(scale.scale);
      std::cout << line.dump() << '\n';
    }
  }
  std::size_t ignored = 0;
  for (const auto& r : results) ignored = std::max(ignored, r->samples_ignored);
  if (ignored > 0)
    std::cerr << "skinspec: " << input_name(args.file) << ": " << ignored
              << " samples outside the model's 380-780 nm were not fitted\n";
  if (!results.empty() && !results.front()->coverage_note.empty())
    std::cerr << "skinspec: " << input_name(args.file) << ": " << results.front()->coverage_note << '\n';
}

}  // namespace

void add_fit_command(CLI::App& app) {
  auto args = std::make_shared<FitArgs>();
  auto* fit = app.add_subcommand("fit", "fit a skin model to reflectance spectra");
  fit->add_option("FILE", args->file,
                  "CSV: wavelength_nm, then one reflectance column (0..1, or percent) per spectrum; - reads stdin")
      ->required();
  add_scale_option(*fit, args->scale);
  add_model_option(*fit, args->model);
  add_site_option(*fit, args->site);
  fit->add_flag("--no-lateral-diffusion", args->no_lateral_diffusion,
                "leave out the correction for light lost outside the measured spot");
  add_fix_option(*fit, args->fixes);
  fit->add_option("--format", args->format, "json: one JSON object per spectrum per line; table: a summary for people")
      ->check(CLI::IsMember({"json", "table"}))
      ->capture_default_str();
  fit->callback([args] { run_fit(*args); });
}

}  // namespace skinspec::cli
