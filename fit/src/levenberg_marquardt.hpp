#pragma once
// Levenberg-Marquardt for the fit (private to fit/): at most a handful of parameters and a few
// hundred residuals, so each step is a small dense least-squares problem, solved without
// allocating. A general-purpose solver spends more on its own bookkeeping than the model costs.
// The problem is behind an interface so that the same solver can be tested on the NIST StRD
// nonlinear regression problems (tests/fit/strd_test.cpp) as well as used on spectra.

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <limits>
#include <string>
#include <vector>

#include "skinspec/fit/termination.hpp"

namespace skinspec::detail {

// What the solver minimises: half the sum of squares of residual_count() residuals of the
// parameters.
class LeastSquares {
 public:
  virtual ~LeastSquares() = default;
  virtual std::size_t residual_count() const = 0;
  // The residuals at p; false where they cannot be had there (outside the problem's box, or
  // not finite), which the solver treats as a step that does not lower the cost.
  virtual bool residuals(const double* p, double* out) = 0;
  // d residual_i / d p_k at out[k * residual_count() + i] (column-major, every parameter's
  // column), at the p of the last residuals() call.
  virtual void jacobian(const double* p, double* out) = 0;
};

// The stopping rules (docs/solver.md, "When the solver stops"), as Ceres Solver defines them:
// the function tolerance on |Δcost| / cost, the parameter tolerance on |Δp| / (|p| + tolerance),
// the gradient tolerance on the largest component of the gradient of the scaled parameters,
// and the least trust region radius. The defaults are the skin fit's.
struct LmOptions {
  int max_iterations = 100;  // steps tried, taken or not, in one solve
  // In the scaled parameters: 10^4 makes the first steps nearly Gauss-Newton's.
  double initial_trust_region_radius = 1e4;
  double function_tolerance = 1e-7;
  double parameter_tolerance = 1e-8;
  double gradient_tolerance = 1e-12;
  double min_trust_region_radius = 1e-32;
};

// Why a solve stopped: it ended (LmResult::termination says how), or a free parameter left its
// plausible range, for the active-set loop to pin.
enum class LmStop { ended, left_plausible_range };

template <int N>
struct LmResult {
  std::array<double, N> params{};
  double cost = 0;     // half the sum of squared residuals at params
  int iterations = 0;  // steps tried, taken or not
  LmStop stop = LmStop::ended;
  Termination termination = Termination::failed;  // meaningful where stop is `ended`
  std::string message;
  // The residuals and their Jacobian (all N columns) at params, unless the start failed.
  Eigen::VectorXd residuals;
  Eigen::MatrixXd jacobian;
};

// Minimises half the sum of squared residuals of `problem` over the parameters marked `free`,
// from `start`; the others stay at their start values. The solve stops early, with the point
// reached, when a free parameter leaves [plausible_lower, plausible_upper] (N values each).
// Instantiated for 2 to 7 parameters.
template <int N>
LmResult<N> levenberg_marquardt(LeastSquares& problem, const std::array<double, N>& start,
                                const std::array<bool, N>& free, const std::vector<double>& plausible_lower,
                                const std::vector<double>& plausible_upper, const LmOptions& options = {});

}  // namespace skinspec::detail
