// skinspec fit FILE: one JSON line per spectrum column, fitted on all cores.

#include <atomic>
#include <iostream>
#include <thread>

#include "common.hpp"
#include "fit_json.hpp"

namespace skinspec::cli {

namespace {

struct FitArgs {
  std::string file;
  std::string site = "forearm";
  bool no_lateral_diffusion = false;
};

// Fits every spectrum, spread over the machine's cores; results keep the input order.
std::vector<std::expected<FitResult, std::string>> fit_all(const std::vector<NamedSpectrum>& spectra,
                                                           const FitOptions& options) {
  std::vector<std::expected<FitResult, std::string>> results(spectra.size());
  std::atomic<std::size_t> next{0};
  const auto worker = [&] {
    for (std::size_t i; (i = next.fetch_add(1)) < spectra.size();)
      results[i] = fitter().fit(spectra[i].spectrum, options);
  };
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  const auto threads_wanted = std::min<std::size_t>(cores, spectra.size());
  std::vector<std::jthread> threads;
  for (std::size_t t = 1; t < threads_wanted; ++t) threads.emplace_back(worker);
  worker();
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
      throw Failure{kBadInput, input_name(args.file) + ": column '" + spectra[i].name + "': " + results[i].error()};
  std::size_t ignored = 0;
  for (std::size_t i = 0; i < results.size(); ++i) {
    std::cout << fit_to_json(spectra[i].name, *results[i]).dump() << '\n';
    ignored = std::max(ignored, results[i]->samples_ignored);
  }
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
  fit->callback([args] { run_fit(*args); });
}

}  // namespace skinspec::cli
