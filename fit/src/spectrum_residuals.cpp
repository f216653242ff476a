#include "spectrum_residuals.hpp"

#include <array>

namespace skinspec::detail {

SpectrumResiduals::SpectrumResiduals(const SkinModel& model, const std::vector<double>& measured,
                                     const std::vector<double>& sqrt_weights, std::optional<Box> box)
    : model_(model), measured_(measured), sqrt_weights_(sqrt_weights), box_(box) {}

bool SpectrumResiduals::evaluate(const double* p, double* residuals, double* jacobian) const {
  const std::size_t n = param_count(), rows = size();
  if (box_)
    for (std::size_t k = 0; k < n; ++k)
      if (p[k] < box_->lower[k] || p[k] > box_->upper[k]) return false;
  std::array<double, kMaxParamCount> gradient{};
  for (std::size_t i = 0; i < rows; ++i) {
    const double r =
        jacobian != nullptr ? model_.reflectance_and_gradient(i, p, gradient.data()) : model_.reflectance_at(i, p);
    residuals[i] = sqrt_weights_[i] * (r - measured_[i]);
    if (jacobian != nullptr)
      for (std::size_t k = 0; k < n; ++k) jacobian[k * rows + i] = sqrt_weights_[i] * gradient[k];
  }
  return true;
}

}  // namespace skinspec::detail
