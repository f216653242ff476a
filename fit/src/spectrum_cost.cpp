#include "spectrum_cost.hpp"

#include <array>

namespace skinspec::detail {

SpectrumCost::SpectrumCost(const SkinModel& model, const std::vector<double>& measured,
                           const std::vector<double>& sqrt_weights, std::optional<Box> box)
    : model_(model), measured_(measured), sqrt_weights_(sqrt_weights), box_(box) {
  set_num_residuals(static_cast<int>(model.size()));
  mutable_parameter_block_sizes()->push_back(static_cast<int>(model.param_count()));
}

bool SpectrumCost::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const double* p = parameters[0];
  const std::size_t n = model_.param_count();
  if (box_)
    for (std::size_t k = 0; k < n; ++k)
      if (p[k] < box_->lower[k] || p[k] > box_->upper[k]) return false;
  double* jacobian = jacobians != nullptr ? jacobians[0] : nullptr;
  std::array<double, kMaxParamCount> gradient{};
  for (std::size_t i = 0; i < model_.size(); ++i) {
    const double r =
        jacobian != nullptr ? model_.reflectance_and_gradient(i, p, gradient.data()) : model_.reflectance_at(i, p);
    residuals[i] = sqrt_weights_[i] * (r - measured_[i]);
    if (jacobian != nullptr)
      for (std::size_t k = 0; k < n; ++k) jacobian[i * n + k] = sqrt_weights_[i] * gradient[k];
  }
  return true;
}

}  // namespace skinspec::detail
