#pragma once
// The model at every sample of a spectrum at once (private to fit/): eq. 1 as operations on
// columns of samples (Eigen arrays, vectorised over the wavelengths) instead of one sample at a
// time, with its Jacobian by derivatives written out by hand.
//
// The solver needs the reflectance at every point it tries but the Jacobian only at the points
// it keeps (about half of them), so the two are apart: reflectance() keeps in a Workspace what
// the derivatives need, and jacobian() finishes from there. SkinModel::reflectance_and_gradient
// (automatic differentiation through the layers) stays the reference they are tested against
// (tests/model_test.cpp); they agree to rounding.

#include <Eigen/Core>
#include <cstdint>

#include "skinspec/fit/model.hpp"

namespace skinspec::detail {

// Kubelka's layer at every sample (model.hpp, kubelka_layer): k = K / S (K times inverse_S), a = 1 + k,
// b = sqrt(k (k + 2)), e1 = exp(-D S b), e = e1^2, R = (1 - e) / den, T = 2 b e1 / den with
// den = a (1 - e) + b (1 + e).
struct LayerColumns {
  Eigen::ArrayXd inverse_S, k, a, b, e1, e, inverse_den, r, t;
  void resize(Eigen::Index n);
};

// A layer's R and T as functions of k = K / S and c = D S b, each differentiated with the
// other fixed, 1 / b and a / b (db/dk).
struct LayerSlopes {
  Eigen::ArrayXd r_k, t_k, r_c, t_c, inverse_b, a_over_b;
  void resize(Eigen::Index n);
};

// Columns of one evaluation: the layers and what combines them, kept for the derivatives, and
// room for the derivatives' own columns, so that an evaluation allocates nothing once sized.
struct Workspace {
  LayerColumns epidermis, dermis;
  LayerSlopes epidermis_slopes, dermis_slopes;
  Eigen::ArrayXd epidermis_K, dermis_K, dermis_S;
  Eigen::ArrayXd packed_blood_K, packing_slope;  // the extended model: blood in vessels, d packed / d spread
  Eigen::ArrayXd scattering_power_law;           // the extended model: mu_s' / its amplitude, as S
  Eigen::ArrayXd total, kept, lateral_exp;       // dermis over white, its share kept, exp(-mu_eff r)
  Eigen::ArrayXd under_surface;                  // X of R = (1 - rs) X + rs
  Eigen::ArrayXd scratch1, scratch2, scratch3, scratch4, scratch5, scratch6, scratch7, scratch8;
  // Columns that depend on one parameter alone are kept while it stays the same (held, or
  // pinned at a bound by the active-set loop): blood packed in vessels at an oxygen
  // saturation, and the scattering's power law at an exponent. Which model (SpectrumModel's
  // id, 0: none) and value they were computed for.
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
  void absorption_and_scattering(const double* p, Workspace& w) const;
  void packed_blood(double saturation, Workspace& w) const;

  const SkinModel& model_;
  std::uint64_t id_;  // unique among every SpectrumModel ever made, for Workspace to tell them apart
  Geometry geometry_;
  // The constants at each sample (OpticsAt), as columns.
  Eigen::ArrayXd Ke_, Se_, Kd_, Sd_, Km_, Kh_, Kdh_, Kb_, log_scattering_ratio_;
  Eigen::ArrayXd inverse_Se_;
};

}  // namespace skinspec::detail
