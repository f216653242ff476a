// The fit engine on measured spectra, one fit at a time on one thread: every column of a
// spectra CSV (data/real-skin/nist_forearm_odd_subjects_379-781nm_3nm.csv, the 50 NIST
// forearms) fitted with the options `skinspec fit` uses by default (extended model, forearm,
// lateral diffusion on), the whole set repeated until the timing is steady. Prints one JSON
// object: each spectrum's rmse, parameters and fitted model spectrum (so that another
// implementation of the model can be checked against this one at the same parameters), the
// median time per fit and the median rmse, and how the solver ended: each fit's iterations and
// termination, their median and 99th percentile (nearest rank) and the count of each termination.
// bench/fit-vs-scipy runs it beside a scipy fit.
// Run: build/release/bin/fit_real_bench [--repeats N] [--spectra N] [--model NAME] [--evaluate] FILE
//   --repeats N  rounds over the whole set (default: as many as take 2 s, at least 5)
//   --spectra N  only the first N columns
//   --model NAME the skin model (default: extended, as `skinspec fit`)
//   --evaluate   no fits: the model (same options) at each parameter set read from stdin, one
//                set of the model's parameters a line, on the samples the fit of FILE's first
//                spectrum uses; prints {"wavelength_nm": [...], "reflectance": [[...], ...]}

#include <time.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "fit_json.hpp"
#include "fitter_loader.hpp"
#include "skinspec/spectral/spectra_csv.hpp"

namespace {

using namespace skinspec;
using Clock = std::chrono::steady_clock;

// Enough rounds for a steady median on a shared machine, without making the benchmark slow.
constexpr double kMinTimedSeconds = 2.0;
constexpr int kMinRounds = 5;

constexpr const char* kUsage = "usage: fit_real_bench [--repeats N] [--spectra N] [--model NAME] [--evaluate] FILE";

[[noreturn]] void die(const std::string& message) {
  std::fprintf(stderr, "fit_real_bench: %s\n", message.c_str());
  std::exit(2);
}

struct Args {
  std::string file;
  int repeats = 0;          // 0: time-based
  std::size_t spectra = 0;  // 0: all
  ModelKind model = kDefaultModel;
  bool evaluate = false;
};

int positive(std::string_view option, std::string_view text) {
  int value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc{} || end != text.data() + text.size() || value < 1)
    die(std::string(option) + " needs a positive whole number, not '" + std::string(text) + "'");
  return value;
}

Args parse_args(int argc, char** argv) {
  Args args;
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    if ((arg == "--repeats" || arg == "--spectra") && i + 1 < argc) {
      const int value = positive(arg, argv[++i]);
      if (arg == "--repeats") args.repeats = value;
      else args.spectra = static_cast<std::size_t>(value);
    } else if (arg == "--model" && i + 1 < argc) {
      const auto model = parse_model_kind(argv[++i]);
      if (!model) die("--model: one of " + model_names());
      args.model = *model;
    } else if (arg == "--evaluate") {
      args.evaluate = true;
    } else if (!arg.starts_with("--") && args.file.empty()) {
      args.file = arg;
    } else {
      die(kUsage);
    }
  }
  if (args.file.empty()) die(kUsage);
  return args;
}

std::vector<NamedSpectrum> read_spectra(const Args& args) {
  std::ifstream in(args.file, std::ios::binary);
  if (!in) die("cannot read " + args.file);
  std::ostringstream bytes;
  bytes << in.rdbuf();
  // The limits `skinspec fit` reads its input with.
  SpectraLimits limits;
  limits.must_cover_from_nm = kMinCoverFromNm;
  limits.must_cover_to_nm = kMinCoverToNm;
  auto spectra = parse_spectra_csv(bytes.str(), args.file, limits);
  if (!spectra) die(spectra.error().what());
  if (args.spectra > 0 && args.spectra < spectra->size())
    spectra->erase(spectra->begin() + static_cast<std::ptrdiff_t>(args.spectra), spectra->end());
  return std::move(*spectra);
}

// CPU time of this thread: unlike the wall clock, not lengthened by other processes sharing
// the machine.
double thread_cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + static_cast<double>(t.tv_nsec) * 1e-9;
}

double median(std::vector<double> values) {
  std::ranges::sort(values);
  const std::size_t n = values.size();
  return n % 2 == 1 ? values[n / 2] : (values[n / 2 - 1] + values[n / 2]) / 2;
}

// The nearest-rank percentile: the smallest value with at least `percent` % of them at or below.
double percentile(std::vector<double> values, double percent) {
  std::ranges::sort(values);
  const auto rank = static_cast<std::size_t>(std::ceil(percent / 100 * static_cast<double>(values.size())));
  return values[std::clamp<std::size_t>(rank, 1, values.size()) - 1];
}

// How the solver ended, over every fit: the iterations' median and 99th percentile, and how many
// fits ended each way.
nlohmann::json solver_summary(const std::vector<FitResult>& results) {
  std::vector<double> iterations;
  nlohmann::json by_termination = nlohmann::json::object();
  for (const auto& [termination, name] : termination_names()) by_termination[std::string(name)] = 0;
  for (const FitResult& r : results) {
    iterations.push_back(r.iterations);
    if (!r.termination) continue;  // never for a fit just made
    auto& count = by_termination[std::string(to_string(*r.termination))];
    count = count.get<int>() + 1;
  }
  return {{"median_iterations", median(iterations)},
          {"p99_iterations", percentile(iterations, 99)},
          {"max_iterations", percentile(iterations, 100)},
          {"terminations", std::move(by_termination)}};
}

// --evaluate: the model of the fit at each parameter set on stdin, on the samples the fitter
// takes from the file (the fit of its first spectrum says which), as `skinspec fit` builds it.
void evaluate(const Fitter& fitter, const NamedSpectrum& first, const FitOptions& options) {
  const auto fit = fitter.fit(first.spectrum, options);
  if (!fit) die("column '" + first.name + "': " + fit.error());
  const SkinOptics& optics = fitter.optics(options.model);
  const SkinModel model(optics, *optics.site(options.site), fit->wavelength_nm, options.lateral_diffusion);
  nlohmann::json reflectance = nlohmann::json::array();
  std::string line;
  while (std::getline(std::cin, line)) {
    std::istringstream fields(line);
    Params p;
    for (double v = 0; fields >> v;) p.push_back(v);
    if (p.empty()) continue;
    if (p.size() != model.param_count() || !fields.eof())
      die("--evaluate: each line must hold the model's " + std::to_string(model.param_count()) + " parameters");
    reflectance.push_back(model.reflectance(p));
  }
  std::cout << nlohmann::json{{"wavelength_nm", fit->wavelength_nm}, {"reflectance", std::move(reflectance)}}.dump()
            << '\n';
}

}  // namespace

int main(int argc, char** argv) {
  const Args args = parse_args(argc, argv);
  auto loaded = load_fitter();
  if (!loaded) die(loaded.error() + " (set SKINSPEC_DATA_DIR)");
  const Fitter& fitter = *loaded;
  const auto spectra = read_spectra(args);
  // What `skinspec fit FILE` does with no options but --model.
  FitOptions options;
  options.model = args.model;
  if (args.evaluate) {
    evaluate(fitter, spectra.front(), options);
    return 0;
  }

  // One untimed round gives the results (every round fits the same spectra to the same
  // parameters) and warms the caches.
  std::vector<FitResult> results;
  for (const auto& s : spectra) {
    auto fit = fitter.fit(s.spectrum, options);
    if (!fit) die("column '" + s.name + "': " + fit.error());
    results.push_back(std::move(*fit));
  }

  std::vector<double> wall, cpu;
  const auto start = Clock::now();
  int rounds = 0;
  const auto more_rounds = [&] {
    if (args.repeats > 0) return rounds < args.repeats;
    return rounds < kMinRounds || std::chrono::duration<double>(Clock::now() - start).count() < kMinTimedSeconds;
  };
  for (; more_rounds(); ++rounds) {
    for (const auto& s : spectra) {
      const double cpu_before = thread_cpu_seconds();
      const auto wall_before = Clock::now();
      auto fit = fitter.fit(s.spectrum, options);
      wall.push_back(std::chrono::duration<double>(Clock::now() - wall_before).count());
      cpu.push_back(thread_cpu_seconds() - cpu_before);
      if (!fit) die("column '" + s.name + "': " + fit.error());
    }
  }

  nlohmann::json out;
  out["engine"] = "skinspec Fitter::fit";
  out["file"] = args.file;
  out["model"] = to_string(options.model);
  out["site"] = options.site;
  out["lateral_diffusion"] = options.lateral_diffusion;
  // The parameters with their fit ranges and defaults, so that another implementation can check
  // it fits the same ones.
  nlohmann::json param_specs = nlohmann::json::array();
  for (const ParamSpec& spec : model_spec(options.model).params)
    param_specs.push_back(
        {{"name", spec.name}, {"lower", spec.lower}, {"upper", spec.upper}, {"default", spec.initial}});
  out["param_specs"] = std::move(param_specs);
  out["rounds"] = rounds;
  out["fits_timed"] = wall.size();
  out["median_seconds_per_fit"] = median(wall);
  out["median_cpu_seconds_per_fit"] = median(cpu);
  std::vector<double> rmse;
  std::size_t converged = 0;
  nlohmann::json per_spectrum = nlohmann::json::array();
  for (std::size_t i = 0; i < results.size(); ++i) {
    const FitResult& r = results[i];
    rmse.push_back(r.rmse);
    converged += r.converged ? 1 : 0;
    per_spectrum.push_back({{"name", spectra[i].name},
                            {"rmse", r.rmse},
                            {"converged", r.converged},
                            {"iterations", r.iterations},
                            {"termination", r.termination ? to_string(*r.termination) : "unknown"},
                            {"params", params_to_json(r.model, r.params)},
                            {"wavelength_nm", r.wavelength_nm},
                            {"fitted", r.fitted}});
  }
  out["median_rmse"] = median(rmse);
  out["converged"] = converged;
  out["solver"] = solver_summary(results);
  out["spectra"] = std::move(per_spectrum);
  std::cout << out.dump() << '\n';
  return 0;
}
