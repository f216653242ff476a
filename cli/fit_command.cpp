// skinspec fit FILE: one JSON line per spectrum column, fitted on all cores.

#include <cmath>
#include <fmt/format.h>
#include <iostream>

#include "common.hpp"
#include "fit_json.hpp"
#include "skinspec/spectral/parallel.hpp"

namespace skinspec::cli {

namespace {

struct FitArgs {
  std::string file;
  std::string site = "forearm";
  bool no_lateral_diffusion = false;
  std::string format = "json";
};

// "4.2 ± 0.3", or "4.2 ± ?" where the spectrum cannot determine the parameter.
std::string with_error(double value, double error) {
  return std::isfinite(error) ? fmt::format("{:.4g} ± {:.2g}", value, error) : fmt::format("{:.4g} ± ?", value);
}

// A human-readable table: one row per spectrum.
void print_table(const std::vector<NamedSpectrum>& spectra,
                 const std::vector<std::expected<FitResult, std::string>>& results) {
  std::cout << fmt::format("{:<14} {:<16} {:<16} {:<16} {:<16} {:<16} {:>7} {:>6} {}\n", "spectrum", "surface_refl",
                           "melanin", "oxyhemoglobin", "deoxyhemoglobin", "bilirubin", "rmse", "dE00", "converged");
  for (std::size_t i = 0; i < results.size(); ++i) {
    const FitResult& r = *results[i];
    std::cout << fmt::format("{:<14} ", printable(spectra[i].name));
    for (std::size_t p = 0; p < kParamCount; ++p)
      std::cout << fmt::format("{:<16} ", with_error(r.params[p], r.standard_error[p]));
    std::cout << fmt::format("{:>7.4f} {:>6.2f} {}\n", r.rmse, r.delta_e00_d65, r.converged ? "yes" : "no");
  }
}

// Fits every spectrum, spread over the machine's cores; results keep the input order.
std::vector<std::expected<FitResult, std::string>> fit_all(const std::vector<NamedSpectrum>& spectra,
                                                           const FitOptions& options) {
  std::vector<std::expected<FitResult, std::string>> results(spectra.size());
  parallel_for(spectra.size(), 0, [&](std::size_t i) { results[i] = fitter().fit(spectra[i].spectrum, options); });
  return results;
}

void run_fit(const FitArgs& args) {
  const auto spectra = read_spectra(args.file);
  FitOptions options{.site = args.site, .lateral_diffusion = !args.no_lateral_diffusion, .weights = {}};
  if (auto site = fitter().optics().site(args.site); !site) throw Failure{kBadInput, site.error()};
  const auto results = fit_all(spectra, options);
  // Refuse the whole file before printing anything, so a failure never leaves partial output.
  for (std::size_t i = 0; i < results.size(); ++i)
    if (!results[i])
      throw Failure{kBadInput,
                    input_name(args.file) + ": column " + quote(spectra[i].name) + ": " + results[i].error()};
  if (args.format == "table") {
    print_table(spectra, results);
  } else {
    for (std::size_t i = 0; i < results.size(); ++i)
      std::cout << fit_to_json(spectra[i].name, *results[i]).dump() << '\n';
  }
  std::size_t ignored = 0;
  for (const auto& r : results) ignored = std::max(ignored, r->samples_ignored);
  if (ignored > 0)
    std::cerr << "skinspec: " << input_name(args.file) << ": " << ignored
              << " samples outside the model's 380-780 nm were not fitted\n";
}

}  // namespace

void add_fit_command(CLI::App& app) {
  auto args = std::make_shared<FitArgs>();
  auto* fit = app.add_subcommand("fit", "fit the five-parameter skin model to reflectance spectra");
  fit->add_option("FILE", args->file,
                  "CSV: wavelength_nm, then one reflectance column (0..1) per spectrum; - reads stdin")
      ->required();
  add_site_option(*fit, args->site);
  fit->add_flag("--no-lateral-diffusion", args->no_lateral_diffusion,
                "leave out the correction for light lost outside the measured spot");
  fit->add_option("--format", args->format, "json: one JSON object per spectrum per line; table: a summary for people")
      ->check(CLI::IsMember({"json", "table"}))
      ->capture_default_str();
  fit->callback([args] { run_fit(*args); });
}

}  // namespace skinspec::cli
