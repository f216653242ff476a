// skinspec tune FILE: choose the model's fixed constants on measured skin spectra, holding out
// every Nth spectrum to report fit quality on spectra the constants never saw.

#include <filesystem>
#include <fmt/format.h>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>

#include "common.hpp"
#include "skinspec/fit/tuning.hpp"

namespace skinspec::cli {

namespace {

struct TuneArgs {
  std::string file;
  std::string site = "forearm";
  int holdout_every = 2;
  int max_evaluations = 300;
  int cross_validate = 0;
  std::string out;
};

nlohmann::json quality_json(const FitQuality& q) {
  return {{"spectra", q.count},
          {"converged", q.converged},
          {"median_rmse", q.median_rmse},
          {"p95_rmse", q.p95_rmse},
          {"max_rmse", q.max_rmse},
          {"median_delta_e00_d65", q.median_delta_e00},
          {"p95_delta_e00_d65", q.p95_delta_e00}};
}

FitScores score(const Fitter& f, const std::vector<Spectrum>& spectra, const std::string& site) {
  auto scores = score_fits(f, spectra, {.site = site, .lateral_diffusion = true, .weights = {}});
  if (!scores) throw Failure{kBadInput, scores.error()};
  return *scores;
}

FitQuality assess(const Fitter& f, const std::vector<Spectrum>& spectra, const std::string& site) {
  return summarize(score(f, spectra, site));
}

Fitter tuned_fitter(const std::vector<Spectrum>& training, const TuneArgs& args, TuningResult* result = nullptr) {
  const auto tuned =
      tune_constants(fitter(), training, {.site = args.site, .max_evaluations = args.max_evaluations, .threads = 0});
  if (!tuned) throw Failure{kBadInput, tuned.error()};
  if (result) *result = *tuned;
  return Fitter(fitter().optics().with_constants(tuned->constants), fitter().colorimetry());
}

// K-fold cross-validation: spectrum i belongs to fold i mod K; each fold is fitted with the
// constants tuned on the others, and the held-out figures of all folds are pooled.
nlohmann::json cross_validate(const std::vector<NamedSpectrum>& spectra, const TuneArgs& args) {
  const auto folds = static_cast<std::size_t>(args.cross_validate);
  FitScores pooled;
  for (std::size_t fold = 0; fold < folds; ++fold) {
    std::vector<Spectrum> training, held_out;
    for (std::size_t i = 0; i < spectra.size(); ++i)
      (i % folds == fold ? held_out : training).push_back(spectra[i].spectrum);
    if (training.empty() || held_out.empty()) throw Failure{kBadInput, "too few spectra for that many folds"};
    pooled.append(score(tuned_fitter(training, args), held_out, args.site));
  }
  return {{"folds", folds}, {"held_out", quality_json(summarize(pooled))}};
}

std::string constants_csv(const TuneArgs& args, const ModelConstants& c, std::size_t training, std::size_t held_out) {
  std::string out = fmt::format(
      "# title: Fixed constants of the two-layer skin model\n"
      "# source: chosen by `skinspec tune {} --site {} --holdout-every {} --max-evaluations {}` "
      "(scripts/tune-model): minimum mean fit RMSE over {} spectra, {} held out; spectra from the NIST "
      "Reference Data Set of Human Skin Reflectance, C. C. Cooksey et al., J. Res. NIST 122:26 (2017), "
      "doi:10.18434/M38597\n"
      "# licence: skinspec project data; the NIST spectra are public domain\n"
      "# units: scales dimensionless; lateral_radius_mm millimetres\n"
      "name,value\n",
      std::filesystem::path(args.file).filename().string(), args.site, args.holdout_every, args.max_evaluations,
      training, held_out);
  for (const auto& [name, field] : model_constant_fields()) out += fmt::format("{},{:.6g}\n", name, c.*field);
  return out;
}

void run_tune(const TuneArgs& args) {
  if (auto site = fitter().optics().site(args.site); !site) throw Failure{kBadInput, site.error()};
  std::vector<Spectrum> training, held_out;
  const auto spectra = read_spectra(args.file);
  for (std::size_t i = 0; i < spectra.size(); ++i)
    (args.holdout_every > 0 &&
             i % static_cast<std::size_t>(args.holdout_every) == static_cast<std::size_t>(args.holdout_every) - 1
         ? held_out
         : training)
        .push_back(spectra[i].spectrum);
  if (training.empty()) throw Failure{kBadInput, input_name(args.file) + ": no spectra left to tune on"};

  TuningResult tuned;
  const Fitter tuned_model = tuned_fitter(training, args, &tuned);

  nlohmann::json constants = nlohmann::json::object();
  for (const auto& [name, field] : model_constant_fields()) constants[std::string(name)] = tuned.constants.*field;
  nlohmann::json report = {
      {"constants", constants},
      {"evaluations", tuned.evaluations},
      {"before", {{"training", quality_json(assess(fitter(), training, args.site))}}},
      {"after", {{"training", quality_json(assess(tuned_model, training, args.site))}}},
  };
  if (!held_out.empty()) {
    report["before"]["held_out"] = quality_json(assess(fitter(), held_out, args.site));
    report["after"]["held_out"] = quality_json(assess(tuned_model, held_out, args.site));
  }
  if (args.cross_validate > 1) report["cross_validation"] = cross_validate(spectra, args);
  std::cout << report.dump(2) << '\n';
  if (!args.out.empty()) {
    std::ofstream out(args.out);
    out << constants_csv(args, tuned.constants, training.size(), held_out.size());
    if (!out) throw Failure{kFailure, args.out + ": cannot write"};
  }
}

}  // namespace

void add_tune_command(CLI::App& app) {
  auto args = std::make_shared<TuneArgs>();
  auto* tune = app.add_subcommand("tune", "choose the model's fixed constants on measured skin spectra");
  tune->add_option("FILE", args->file, "CSV of measured reflectance spectra as for `fit`")->required();
  add_site_option(*tune, args->site);
  tune->add_option("--holdout-every", args->holdout_every,
                   "hold out every Nth spectrum (the 2nd, 4th, ... for N = 2) to report on; 0 holds none out")
      ->check(CLI::Range(0, 1000))
      ->capture_default_str();
  tune->add_option("--max-evaluations", args->max_evaluations, "budget of the constant search")
      ->check(CLI::Range(10, 100000))
      ->capture_default_str();
  tune->add_option("--cross-validate", args->cross_validate,
                   "also report K-fold cross-validation: every spectrum fitted with constants tuned without it")
      ->check(CLI::Range(0, 100))
      ->capture_default_str();
  tune->add_option("--out", args->out, "write the tuned constants as a data/model/constants.csv table");
  tune->callback([args] { run_tune(*args); });
}

}  // namespace skinspec::cli
