#pragma once
// The fit's residuals sqrt(w_i) (model_i(p) - measured_i) and their Jacobian (private to fit/),
// from the model's own derivatives (SkinModel::reflectance_and_gradient).

#include <ceres/cost_function.h>

#include <vector>

#include "skinspec/fit/model.hpp"

namespace skinspec::detail {

class SpectrumCost final : public ceres::CostFunction {
 public:
  SpectrumCost(const SkinModel& model, const std::vector<double>& measured, const std::vector<double>& sqrt_weights);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  const SkinModel& model_;
  const std::vector<double>& measured_;
  const std::vector<double>& sqrt_weights_;
};

}  // namespace skinspec::detail
