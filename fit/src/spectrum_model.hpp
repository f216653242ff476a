#pragma once
// The model at every sample of a spectrum at once (private to fit/): eq. 1 in one loop over the
// samples (the kernels of kernels/kernels.hpp, vectorised over the wavelengths, in the widest set
// the processor runs) instead of one call per sample, with its Jacobian by derivatives written
// out by hand.
//
// The solver needs the reflectance at every point it tries but the Jacobian only at the points
// it keeps (about half of them), so the two are apart: reflectance() keeps in a Workspace what
// the derivatives need, and jacobian() finishes from there. SkinModel::reflectance_and_gradient
// (automatic differentiation through the layers) stays the reference they are tested against
// (tests/fit/model_test.cpp); they agree to rounding.

#include <Eigen/Core>
#include <cstdint>

#include "kernels/kernels.hpp"
#include "skinspec/fit/model.hpp"

namespace skinspec::detail {

// A Kubelka layer's columns at every sample, kept for the derivatives (kernels.hpp, LayerColumnsOut).
struct LayerColumns {
  Eigen::ArrayXd k, b, e1, inverse_den, r, t;
  void resize(Eigen::Index n);
};

// Columns of one evaluation: what the reflectance keeps for the derivatives, and room for the
// columns of derivatives a model does not have, so that an evaluation allocates nothing once
// sized.
struct Workspace {
  LayerColumns epidermis, dermis;
  Eigen::ArrayXd dermis_K, dermis_S, dermis_inverse_S, dermis_t_over_1_minus_r, inverse_q;
  Eigen::ArrayXd total, kept, lateral_exp;  // dermis over white, its share kept, exp(-mu_eff r)
  Eigen::ArrayXd under_surface;             // X of R = (1 - rs) X + rs
  Eigen::ArrayXd corneum_slope;             // dX / d(what the stratum corneum lies over)
  Eigen::ArrayXd unused_derivative1, unused_derivative2;
  // Columns that depend on one parameter alone are kept while it stays the same (held, or
  // pinned at a bound by the active-set loop): for the extended model, blood packed in vessels
  // at an oxygen saturation and its derivative by the saturation; the scattering's power law
  // at an exponent (mu_s' / its amplitude, as S), and that times ln(lambda / pivot). Which
  // model (SpectrumModel's id, 0: none) and value they were computed for.
  Eigen::ArrayXd packed_blood_K, packed_blood_by_saturation;
  Eigen::ArrayXd scattering_power_law, power_law_by_log_ratio;
  std::uint64_t packing_model = 0, power_law_model = 0;
  double packing_saturation = 0, power_law_exponent = 0;
  void resize(Eigen::Index n);
};

class SpectrumModel {
 public:
  explicit SpectrumModel(const SkinModel& model);

  Eigen::Index size() const { return Ke_.size(); }
  int param_count() const { return static_cast<int>(model_.param_count()); }
  const SkinModel& model() const { return model_; }

  // The reflectance at every sample for parameters p (param_count() of them) into
  // `reflectance` (size() entries); `work` keeps what jacobian() needs.
  void reflectance(const double* p, Workspace& work, double* reflectance) const;
  // d reflectance_i / d p_k at jacobian[k * size() + i] (column-major), for the p of the last
  // reflectance() into `work`.
  void jacobian(const double* p, Workspace& work, double* jacobian) const;

 private:
  // The extended model's columns that depend on one parameter alone, where it changed.
  void update_single_parameter_columns(const double* p, Workspace& w) const;
  ReflectanceArgs reflectance_args(const double* p, Workspace& w, double* reflectance) const;
  JacobianArgs jacobian_args(const double* p, Workspace& w, double* jacobian) const;

  const SkinModel& model_;
  std::uint64_t id_;  // unique among every SpectrumModel ever made, for Workspace to tell them apart
  Geometry geometry_;
  // The constants at each sample (OpticsAt), as columns.
  Eigen::ArrayXd Ke_, Se_, Kd_, Sd_, Km_, Kh_, Kdh_, Kb_, log_scattering_ratio_;
  Eigen::ArrayXd inverse_Se_;
  // The stratum corneum's R and T^2 at each sample; empty when the site has none.
  Eigen::ArrayXd corneum_r_, corneum_t2_;
};

}  // namespace skinspec::detail
