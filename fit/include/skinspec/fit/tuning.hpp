#pragma once
// Choosing a model's fixed constants (those its ConstantSpec table names: scattering and
// thickness scales, lateral-diffusion radius, baseline-absorption correction) on measured skin:
// the constants that minimise the mean fit RMSE of a training set, found by a Nelder-Mead
// search over their logarithms (or values, for coefficients that may be negative) within
// their plausible ranges, and within which no more than the model's share of the training fits
// leaves a watched parameter on a bound (ModelSpec::most_at_bound). Repeatable: no randomness.

#include <expected>
#include <string>
#include <vector>

#include "skinspec/fit/fitter.hpp"

namespace skinspec {

// How well the model fits a set of spectra.
struct FitQuality {
  std::size_t count = 0;
  std::size_t converged = 0;
  double median_rmse = 0, p95_rmse = 0, max_rmse = 0;
  double median_delta_e00 = 0, p95_delta_e00 = 0;
  // Per watched parameter (ModelSpec::bound_watched, in its order): the fits that left it on a
  // bound.
  std::vector<std::size_t> at_bound;
};

// Per-spectrum figures of a set of fits, for pooling across cross-validation folds.
struct FitScores {
  std::vector<double> rmse, delta_e00;
  std::size_t converged = 0;
  std::vector<std::size_t> at_bound;  // as in FitQuality
  void add(const FitResult& fit);
  void append(const FitScores& other);
};

FitQuality summarize(const FitScores& scores);

// Fits every spectrum (on `threads` threads, 0 = all cores).
std::expected<FitScores, std::string> score_fits(const Fitter& fitter, const std::vector<Spectrum>& spectra,
                                                 const FitOptions& options, unsigned threads = 0);

struct TuningOptions {
  FitOptions fit;  // how each training spectrum is fitted: the model, site, held parameters
  int max_evaluations = 300;
  unsigned threads = 0;
  // Constants kept at a value instead of searched: (name as in the model's ConstantSpec, value).
  std::vector<std::pair<std::string, double>> held_constants;
};

struct TuningResult {
  ModelConstants constants;
  double mean_rmse = 0;  // on the training set
  // The minimised objective: the mean RMSE, raised for every watched parameter left on a bound
  // by more than the model's share of the training fits.
  double objective = 0;
  int evaluations = 0;
};

// Starts from start.optics(options.fit.model)'s constants. Errors: a model not loaded, an
// unknown site, a held constant the model does not have.
std::expected<TuningResult, std::string> tune_constants(const Fitter& start, const std::vector<Spectrum>& training,
                                                        const TuningOptions& options);

}  // namespace skinspec
