#include "spectrum_residuals.hpp"

#include <algorithm>

namespace skinspec::detail {

namespace {

Eigen::Map<const Eigen::ArrayXd> column(const std::vector<double>& v) {
  return {v.data(), static_cast<Eigen::Index>(v.size())};
}

}  // namespace

SpectrumResiduals::SpectrumResiduals(const SpectrumModel& model, const std::vector<double>& measured,
                                     const std::vector<double>& sqrt_weights, std::optional<Box> box)
    : model_(model),
      measured_(measured),
      sqrt_weights_(sqrt_weights),
      box_(box),
      unweighted_(std::ranges::all_of(sqrt_weights, [](double w) { return w == 1.0; })) {}

bool SpectrumResiduals::evaluate(const double* p, Workspace& work, double* residuals) const {
  if (box_)
    for (std::size_t k = 0; k < param_count(); ++k)
      if (p[k] < box_->lower[k] || p[k] > box_->upper[k]) return false;
  model_.reflectance(p, work, residuals);
  Eigen::Map<Eigen::ArrayXd> r(residuals, model_.size());
  if (unweighted_) r -= column(measured_);
  else r = column(sqrt_weights_) * (r - column(measured_));
  return true;
}

void SpectrumResiduals::jacobian(const double* p, Workspace& work, double* jacobian) const {
  model_.jacobian(p, work, jacobian);
  if (unweighted_) return;
  Eigen::Map<Eigen::ArrayXXd> J(jacobian, model_.size(), model_.param_count());
  J.colwise() *= column(sqrt_weights_);
}

}  // namespace skinspec::detail
