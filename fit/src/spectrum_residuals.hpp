#pragma once
// The fit's residuals sqrt(w_i) (model_i(p) - measured_i) and their Jacobian (private to fit/),
// from the model at every sample at once (SpectrumModel).

#include <optional>
#include <vector>

#include "spectrum_model.hpp"

namespace skinspec::detail {

// Parameters outside the box [lower, upper] are refused (the evaluation fails), so that a
// Levenberg-Marquardt step out of it is simply rejected and the trust region shrinks. A
// projection onto the box would search along it instead, evaluating the Jacobian about twice
// per iteration.
struct Box {
  const Params& lower;
  const Params& upper;
};

class SpectrumResiduals {
 public:
  SpectrumResiduals(const SpectrumModel& model, const std::vector<double>& measured,
                    const std::vector<double>& sqrt_weights, std::optional<Box> box = std::nullopt);

  std::size_t size() const { return static_cast<std::size_t>(model_.size()); }
  std::size_t param_count() const { return static_cast<std::size_t>(model_.param_count()); }

  // The residuals at p (size() of them); false, with nothing written, where p lies outside the
  // box. `work` keeps what jacobian() needs.
  bool evaluate(const double* p, Workspace& work, double* residuals) const;
  // d residual_i / d p_k at jacobian[k * size() + i] (column-major) at the p of the last
  // evaluate() into `work`.
  void jacobian(const double* p, Workspace& work, double* jacobian) const;

 private:
  const SpectrumModel& model_;
  const std::vector<double>& measured_;
  const std::vector<double>& sqrt_weights_;
  std::optional<Box> box_;
  bool unweighted_;  // every weight 1 (the default): multiplying by it changes nothing, so it is skipped
};

}  // namespace skinspec::detail
