#pragma once
// The fitter's numerical core (private to fit/): start points, bounded Levenberg-Marquardt by
// active sets, and the Jacobian at the solution, for a model of any parameter count.

#include <Eigen/Core>
#include <string>
#include <vector>

#include "skinspec/fit/model.hpp"

namespace skinspec::detail {

// Where a parameter was left by the active-set loop.
enum class Pin { none, lower, upper };

// One fit's least-squares problem: sqrt(w_i) (model_i(p) - measured_i) over the samples.
struct Problem {
  const SkinModel& model;
  const std::vector<double>& measured;
  const std::vector<double>& weights;
  const std::vector<double>& sqrt_weights;
  std::vector<bool> held;  // held at their given value, never fitted
  Params held_values;      // the values of the held parameters (others unused)
};

struct Solution {
  Params params;
  double cost = 0;  // half the weighted sum of squared residuals
  int iterations = 0;
  bool converged = false;
  std::string message;
  std::vector<Pin> pinned;
  // The weighted residuals and their Jacobian (rows samples, columns parameters) at params;
  // empty while not known.
  Eigen::VectorXd residuals;
  Eigen::MatrixXd jacobian;
};

// The best solution from the coarse search's best starts, refined once more from a restart
// when an absorber ends at zero; with its residuals and Jacobian.
Solution solve(const Problem& problem);

}  // namespace skinspec::detail
