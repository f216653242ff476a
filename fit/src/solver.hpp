#pragma once
// The fitter's numerical core (private to fit/): start points, bounded Levenberg-Marquardt by
// active sets, and the Jacobian at the solution, for a model of any parameter count.

#include <Eigen/Core>
#include <string>
#include <vector>

#include "skinspec/fit/model.hpp"
#include "skinspec/fit/termination.hpp"
#include "spectrum_model.hpp"

namespace skinspec::detail {

// Where a parameter was left by the active-set loop.
enum class Pin { none, lower, upper };

// The plausible range of each parameter, and the wider box the solver may roam before the
// active-set loop pins a parameter at the bound it crossed.
struct Bounds {
  Params lower, upper, solver_lower, solver_upper;
};
Bounds bounds_of(const SkinModel& model);

// The coarse search's layers (solver.cpp, coarse_starts) on every fourth sample: the epidermis
// at each melanin level and the dermis at each blood level and oxygen share, all other
// parameters at their start values. They depend on the model and what is held, not on the
// measurement. As columns, which the fit's kernels combine (kernels.hpp, CoarseErrorsArgs).
struct CoarseLayers {
  std::size_t samples = 0;
  std::vector<double> epidermis_r, epidermis_t2;  // by melanin level, then sample
  std::vector<double> dermis_total, dermis_kept;  // by blood level and share, then sample
  std::vector<double> corneum_r, corneum_t2;      // by sample; empty without a stratum corneum
};
CoarseLayers coarse_layers(const SkinModel& model, const std::vector<bool>& held, const Params& held_values);

// One fit's least-squares problem: sqrt(w_i) (model_i(p) - measured_i) over the samples.
struct Problem {
  const SkinModel& model;
  const SpectrumModel& columns;  // the same model at every sample at once
  const Bounds& bounds;          // bounds_of(model)
  const CoarseLayers& coarse;    // coarse_layers(model, held, held_values)
  const std::vector<double>& measured;
  const std::vector<double>& weights;
  const std::vector<double>& sqrt_weights;
  const std::vector<bool>& held;  // held at their given value, never fitted
  const Params& held_values;      // the values of the held parameters (others unused)
  const Params* start = nullptr;  // the solver's one start instead of the coarse search's
};

struct Solution {
  Params params;
  double cost = 0;     // half the weighted sum of squared residuals
  int iterations = 0;  // of every solve that led to it: the active-set loop's and a restart's
  // How its last solve ended; iteration_limit too where the active-set loop ran out of rounds.
  Termination termination = Termination::failed;
  std::string message;
  std::vector<Pin> pinned;
  // The weighted residuals and their Jacobian (rows samples, columns parameters) at params;
  // empty while not known.
  Eigen::VectorXd residuals;
  Eigen::MatrixXd jacobian;
};

// The best solution from the coarse search's best starts (or from problem.start), refined once
// more from a restart when an absorber ends at zero; with its residuals and Jacobian.
Solution solve(const Problem& problem);

// The model's reflectance at every sample for p, as the solver computes it.
std::vector<double> reflectance(const SpectrumModel& columns, const Params& p);

}  // namespace skinspec::detail
