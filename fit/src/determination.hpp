#pragma once
// What a fit's spectrum determines (private to fit/): standard errors and correlations from
// the Gauss-Newton covariance, each parameter judged determined or not (and why), and the
// derived oxygen saturation and blood volume fraction by the delta method.

#include <Eigen/Core>
#include <vector>

#include "skinspec/fit/fitter.hpp"

namespace skinspec::detail {

enum class Pin;

struct FitUncertainty {
  Params standard_error;
  std::vector<double> correlation;  // row-major
  std::vector<ParamDetermination> determination;
  DerivedQuantity oxygen_saturation, blood_volume_fraction;
};

// Matrices of at most one row and column per parameter, kept in place rather than allocated.
using SmallMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxParamCount, kMaxParamCount>;

// sigma^2 (J^T J)^-1 over the `free` columns of `jacobian` (in their order), sigma^2 being
// 2 cost / max(1, rows - free); a parameter in the null space of J gets an infinite variance
// and NaN covariances. The usual estimate, which NIST certifies for its StRD problems.
SmallMatrix parameter_covariance(const Eigen::MatrixXd& jacobian, const std::vector<std::size_t>& free, double cost);

// `jacobian` of the weighted residuals at `params` (rows samples), `cost` half their sum of
// squares; `held` the parameters not fitted, `pinned` those the solver left on a bound.
FitUncertainty assess_uncertainty(ModelKind model, const Eigen::MatrixXd& jacobian, double cost, const Params& params,
                                  const std::vector<bool>& held, const std::vector<Pin>& pinned);

}  // namespace skinspec::detail
