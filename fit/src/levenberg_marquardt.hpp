#pragma once
// Levenberg-Marquardt for the fit (private to fit/): at most a handful of parameters and a few
// hundred residuals, so each step is a small dense least-squares problem, solved without
// allocating. A general-purpose solver spends more on its own bookkeeping than the model costs.

#include <Eigen/Core>
#include <array>
#include <string>

#include "spectrum_residuals.hpp"

namespace skinspec::detail {

// Why a solve ended. `converged`: a tolerance was met (the cost changed by less than 1e-7 of
// itself, the step was shorter than 1e-8 of |p|, the gradient vanished or the trust region
// did); `left_bounds`: a free parameter left its plausible range, for the active-set loop to
// pin; `out_of_iterations`: 100 steps without converging; `failed`: the start could not be
// evaluated.
enum class LmEnd { converged, left_bounds, out_of_iterations, failed };

template <int N>
struct LmResult {
  std::array<double, N> params{};
  double cost = 0;     // half the sum of squared residuals at params
  int iterations = 0;  // steps tried, taken or not
  LmEnd end = LmEnd::failed;
  std::string message;
  // The residuals and their Jacobian (all N columns) at params, unless the start failed.
  Eigen::VectorXd residuals;
  Eigen::MatrixXd jacobian;
};

// Minimises half the sum of squared `residuals` over the parameters marked `free`, from
// `start`; the others stay at their start values. A step the residuals refuse (outside their
// box) is rejected like one that does not lower the cost. The solve stops early, with the
// point reached, when a free parameter leaves [plausible_lower, plausible_upper]. `work` is
// the model's room to evaluate in.
template <int N>
LmResult<N> levenberg_marquardt(const SpectrumResiduals& residuals, const std::array<double, N>& start,
                                const std::array<bool, N>& free, const Params& plausible_lower,
                                const Params& plausible_upper, Workspace& work);

}  // namespace skinspec::detail
