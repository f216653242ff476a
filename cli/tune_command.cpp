// skinspec tune FILE: choose the model's fixed constants on measured skin spectra, holding out
// every Nth spectrum to report fit quality on spectra the constants never saw.

#include <charconv>
#include <filesystem>
#include <fmt/format.h>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>

#include "common.hpp"
#include "model_options.hpp"
#include "skinspec/fit/tuning.hpp"

namespace skinspec::cli {

namespace {

struct TuneArgs {
  std::string file;
  ModelKind model = kDefaultModel;
  std::string site = "forearm";
  std::vector<std::string> fixes;
  std::vector<std::string> held_constants;
  int holdout_every = 2;
  int max_evaluations = 300;
  int cross_validate = 0;
  std::string out;
  std::string fold_out;
  bool from_textbook = false;
  bool only_cross_validation = false;

  FitOptions fit_options() const {
    return {.model = model, .site = site, .lateral_diffusion = true, .weights = {}, .held = held_for(model, fixes), .start = {}};
  }
};

// The fits that left each watched parameter on a bound (ModelSpec::bound_watched).
nlohmann::json at_bound_json(ModelKind model, const FitQuality& q) {
  nlohmann::json counts = nlohmann::json::object();
  const auto watched = model_spec(model).bound_watched;
  for (std::size_t w = 0; w < watched.size(); ++w)
    counts[std::string(model_spec(model).params[static_cast<std::size_t>(watched[w])].name)] =
        w < q.at_bound.size() ? q.at_bound[w] : 0;
  return counts;
}

nlohmann::json quality_json(ModelKind model, const FitQuality& q) {
  return {{"spectra", q.count},
          {"converged", q.converged},
          {"median_rmse", q.median_rmse},
          {"p95_rmse", q.p95_rmse},
          {"max_rmse", q.max_rmse},
          {"median_delta_e00_d65", q.median_delta_e00},
          {"p95_delta_e00_d65", q.p95_delta_e00},
          {"at_bound", at_bound_json(model, q)}};
}

FitScores score(const Fitter& f, const std::vector<Spectrum>& spectra, const TuneArgs& args) {
  auto scores = score_fits(f, spectra, args.fit_options());
  if (!scores) throw Failure{kBadInput, scores.error()};
  return *scores;
}

FitQuality assess(const Fitter& f, const std::vector<Spectrum>& spectra, const TuneArgs& args) {
  return summarize(score(f, spectra, args));
}

// --hold-constant NAME=VALUE, as (name, value).
std::vector<std::pair<std::string, double>> held_constants(const std::vector<std::string>& texts) {
  std::vector<std::pair<std::string, double>> held;
  for (const std::string& text : texts) {
    const auto equals = text.find('=');
    double value = 0;
    const char* end = text.data() + text.size();
    if (equals == std::string::npos || std::from_chars(text.data() + equals + 1, end, value).ptr != end ||
        equals + 1 == text.size())
      throw Failure{kBadInput, "--hold-constant " + text + ": expected NAME=VALUE"};
    held.emplace_back(text.substr(0, equals), value);
  }
  return held;
}

Fitter fitter_with(const ModelConstants& constants, const TuneArgs& args) {
  return fitter().with_optics(fitter().optics(args.model).with_constants(constants));
}

// Where the search starts: the loaded constants, or with --from-textbook the untuned ones, so
// that the result does not depend on a previous tuning.
Fitter starting_fitter(const TuneArgs& args) {
  return args.from_textbook ? fitter_with(textbook_constants(args.model), args) : fitter();
}

TuningResult tune(const std::vector<Spectrum>& training, const TuneArgs& args) {
  const auto tuned = tune_constants(starting_fitter(args), training,
                                    {.fit = args.fit_options(),
                                     .max_evaluations = args.max_evaluations,
                                     .threads = 0,
                                     .held_constants = held_constants(args.held_constants)});
  if (!tuned) throw Failure{kBadInput, tuned.error()};
  return *tuned;
}

void write_text(const std::string& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
  if (!out) throw Failure{kFailure, path + ": cannot write"};
}

// The options that chose a set of constants, as `skinspec tune` takes them.
std::string tune_command_line(const TuneArgs& args) {
  std::string line = fmt::format("skinspec tune {} --model {}", std::filesystem::path(args.file).filename().string(),
                                 to_string(args.model));
  if (args.from_textbook) line += " --from-textbook";
  for (const auto& fix : args.fixes) line += " --fix " + fix;
  for (const auto& held : args.held_constants) line += " --hold-constant " + held;
  line += fmt::format(" --site {} --holdout-every {} --max-evaluations {}", args.site, args.holdout_every,
                      args.max_evaluations);
  if (args.cross_validate > 0) line += fmt::format(" --cross-validate {}", args.cross_validate);
  return line;
}

std::string constants_csv(const TuneArgs& args, const ModelConstants& c, const std::string& chosen_on) {
  const std::string title = args.model == ModelKind::paper
                                ? "Fixed constants of the two-layer skin model"
                                : fmt::format("Fixed constants of the {} skin model", to_string(args.model));
  std::string out = fmt::format(
      "# title: {}\n"
      "# source: chosen by `{}` (scripts/tune-model): minimum mean fit RMSE over {}{}; spectra from the NIST "
      "Reference Data Set of Human Skin Reflectance, C. C. Cooksey et al., J. Res. NIST 122:26 (2017), "
      "doi:10.18434/M38597\n"
      "# licence: skinspec project data; the NIST spectra are public domain\n"
      "# units: {}\n"
      "name,value\n",
      title, tune_command_line(args), chosen_on,
      model_spec(args.model).bound_watched.empty() ? ""
                                                   : ", with few fits leaving a parameter on a bound (docs/model.md)",
      args.model == ModelKind::paper ? "scales dimensionless; lateral_radius_mm millimetres"
                                     : "scales dimensionless; lateral_radius_mm millimetres; baseline_absorption_N "
                                       "dimensionless Legendre coefficients of ln(correction factor)");
  const auto values = constant_values(args.model, c);
  const auto specs = model_spec(args.model).constants;
  for (std::size_t i = 0; i < specs.size(); ++i) out += fmt::format("{},{:.6g}\n", specs[i].name, values[i]);
  return out;
}

// K-fold cross-validation: spectrum i belongs to fold i mod K; each fold is fitted with the
// constants tuned on the others, and the held-out figures of all folds are pooled. With
// --fold-out, fold k's constants go to PREFIX-k.csv (k from 1).
nlohmann::json cross_validate(const std::vector<NamedSpectrum>& spectra, const TuneArgs& args) {
  const auto folds = static_cast<std::size_t>(args.cross_validate);
  FitScores pooled;
  for (std::size_t fold = 0; fold < folds; ++fold) {
    std::vector<Spectrum> training, held_out;
    for (std::size_t i = 0; i < spectra.size(); ++i)
      (i % folds == fold ? held_out : training).push_back(spectra[i].spectrum);
    if (training.empty() || held_out.empty()) throw Failure{kBadInput, "too few spectra for that many folds"};
    const TuningResult tuned = tune(training, args);
    pooled.append(score(fitter_with(tuned.constants, args), held_out, args));
    if (!args.fold_out.empty())
      write_text(fmt::format("{}-{}.csv", args.fold_out, fold + 1),
                 constants_csv(args, tuned.constants,
                               fmt::format("the {} spectra outside fold {} of {} (spectrum i is in fold i mod {} + 1)",
                                           training.size(), fold + 1, folds, folds)));
  }
  return {{"folds", folds}, {"held_out", quality_json(args.model, summarize(pooled))}};
}

void run_tune(const TuneArgs& args) {
  if (auto site = fitter().optics(args.model).site(args.site); !site) throw Failure{kBadInput, site.error()};
  if (args.only_cross_validation) {
    if (args.cross_validate < 2) throw Failure{kBadInput, "--only-cross-validation needs --cross-validate K, K >= 2"};
    std::cout << nlohmann::json{{"model", to_string(args.model)},
                                {"cross_validation", cross_validate(read_spectra(args.file), args)}}
                     .dump(2)
              << '\n';
    return;
  }
  std::vector<Spectrum> training, held_out;
  const auto spectra = read_spectra(args.file);
  for (std::size_t i = 0; i < spectra.size(); ++i)
    (args.holdout_every > 0 &&
             i % static_cast<std::size_t>(args.holdout_every) == static_cast<std::size_t>(args.holdout_every) - 1
         ? held_out
         : training)
        .push_back(spectra[i].spectrum);
  if (training.empty()) throw Failure{kBadInput, input_name(args.file) + ": no spectra left to tune on"};

  const TuningResult tuned = tune(training, args);
  const Fitter tuned_model = fitter_with(tuned.constants, args);

  nlohmann::json constants = nlohmann::json::object();
  const auto values = constant_values(args.model, tuned.constants);
  const auto specs = model_spec(args.model).constants;
  for (std::size_t i = 0; i < specs.size(); ++i) constants[std::string(specs[i].name)] = values[i];
  nlohmann::json report = {
      {"model", to_string(args.model)},
      {"constants", constants},
      {"evaluations", tuned.evaluations},
      {"before", {{"training", quality_json(args.model, assess(starting_fitter(args), training, args))}}},
      {"after", {{"training", quality_json(args.model, assess(tuned_model, training, args))}}},
  };
  if (!held_out.empty()) {
    report["before"]["held_out"] = quality_json(args.model, assess(starting_fitter(args), held_out, args));
    report["after"]["held_out"] = quality_json(args.model, assess(tuned_model, held_out, args));
  }
  if (args.cross_validate > 1) report["cross_validation"] = cross_validate(spectra, args);
  std::cout << report.dump(2) << '\n';
  if (!args.out.empty())
    write_text(args.out, constants_csv(args, tuned.constants,
                                       fmt::format("{} spectra, {} held out", training.size(), held_out.size())));
}

}  // namespace

void add_tune_command(CLI::App& app) {
  auto args = std::make_shared<TuneArgs>();
  auto* tune = app.add_subcommand("tune", "choose the model's fixed constants on measured skin spectra");
  tune->add_option("FILE", args->file, "CSV of measured reflectance spectra as for `fit`")->required();
  add_model_option(*tune, args->model);
  add_site_option(*tune, args->site);
  add_fix_option(*tune, args->fixes);
  tune->add_option("--hold-constant", args->held_constants,
                   "keep a constant at a value instead of searching it: NAME=VALUE (repeatable)");
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
  tune->add_option("--out", args->out, "write the tuned constants as a data/model/constants*.csv table");
  tune->add_flag("--only-cross-validation", args->only_cross_validation,
                 "report only the cross-validation (with --cross-validate K), tuning nothing on all spectra");
  tune->add_flag("--from-textbook", args->from_textbook,
                 "start the search from the untuned constants (docs/model.md) instead of the shipped ones");
  tune->add_option("--fold-out", args->fold_out,
                   "with --cross-validate K: write fold k's constants to PREFIX-k.csv (k = 1..K)");
  tune->callback([args] { run_tune(*args); });
}

}  // namespace skinspec::cli
