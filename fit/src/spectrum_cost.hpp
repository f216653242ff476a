#pragma once
// The fit's residuals sqrt(w_i) (model_i(p) - measured_i) and their Jacobian (private to fit/),
// from the model's own derivatives (SkinModel::reflectance_and_gradient).

#include <ceres/cost_function.h>

#include <optional>
#include <vector>

#include "skinspec/fit/model.hpp"

namespace skinspec::detail {

// Parameters outside the box [lower, upper] are refused (the evaluation fails), so that a
// Levenberg-Marquardt step out of it is simply rejected and the trust region shrinks. Ceres's
// own bounds would project the step and search along the projection, evaluating the Jacobian
// about twice per iteration.
struct Box {
  const Params& lower;
  const Params& upper;
};

class SpectrumCost final : public ceres::CostFunction {
 public:
  SpectrumCost(const SkinModel& model, const std::vector<double>& measured, const std::vector<double>& sqrt_weights,
               std::optional<Box> box = std::nullopt);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  const SkinModel& model_;
  const std::vector<double>& measured_;
  const std::vector<double>& sqrt_weights_;
  std::optional<Box> box_;
};

}  // namespace skinspec::detail
