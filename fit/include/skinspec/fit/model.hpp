#pragma once
// The two-layer Kubelka-Munk skin model of Doi, Tanaka & Tominaga, eq. 1, one wavelength at a
// time. Templated on the scalar so that Ceres can differentiate exactly what plain double runs.

#include <array>
#include <cmath>
#include <span>
#include <string_view>
#include <vector>

#include "skinspec/fit/optics.hpp"

namespace skinspec {

// The five unknowns, in the order of the parameter vector.
enum Param : int { kSurfaceReflectance, kMelanin, kOxyhemoglobin, kDeoxyhemoglobin, kBilirubin };
inline constexpr int kParamCount = 5;
using Params = std::array<double, kParamCount>;
inline constexpr std::array<std::string_view, kParamCount> kParamNames = {
    "surface_reflectance", "melanin", "oxyhemoglobin", "deoxyhemoglobin", "bilirubin"};

// One wavelength's constants (per mm).
struct OpticsAt {
  double Ke, Se, Kd, Sd, Km, Kh, Kdh, Kb;
};

template <typename T>
struct ReflectanceTransmittance {
  T r, t;
};

// Kubelka's reflectance and transmittance of a layer of absorption K, scattering S and
// thickness D: R = 1/(a + b coth C), T = b/(a sinh C + b cosh C), C = D b S. Written with
// e^(-2C) so that thick layers tend to R = a - b instead of overflowing cosh.
template <typename T>
ReflectanceTransmittance<T> kubelka_layer(const T& K, double S, double D) {
  using std::exp;
  using std::sqrt;
  const T k = K / S;
  const T a = 1.0 + k;
  const T b = sqrt(k * (k + 2.0));  // sqrt(a^2 - 1) without cancellation for small k
  const T c = D * S * b;
  const T e = exp(-2.0 * c);
  const T denominator = a * (1.0 - e) + b * (1.0 + e);
  return {(1.0 - e) / denominator, 2.0 * b * exp(-c) / denominator};
}

// Fraction of the light remitted through the dermis that leaves the skin beyond `radius_mm`
// from where it entered, so is missed by the instrument: for an exponential radial profile
// exp(-mu_eff r) of diffusing light, the share beyond r0 is (1 + mu_eff r0) exp(-mu_eff r0).
template <typename T>
T lateral_loss(const T& dermis_K, double dermis_S, double radius_mm) {
  using std::exp;
  using std::sqrt;
  if (radius_mm <= 0) return T(0.0);
  const T mu_a = dermis_K / 2.0;                     // K = 2 mu_a
  const double mu_s_reduced = dermis_S * 4.0 / 3.0;  // S = 3/4 mu_s'
  const T mu_eff = sqrt(3.0 * mu_a * (mu_a + mu_s_reduced));
  const T x = radius_mm * mu_eff;
  return (1.0 + x) * exp(-x);
}

// Eq. 1: surface reflection Rs, then the epidermis over the dermis over a white hypodermis
// (reflectance 1). p holds the five unknowns in Param order.
template <typename T>
T skin_reflectance(const OpticsAt& o, const Site& site, double lateral_radius_mm, const T* p) {
  const T& rs = p[kSurfaceReflectance];
  const T epidermis_K = o.Ke + p[kMelanin] * o.Km;
  const T dermis_K = o.Kd + p[kOxyhemoglobin] * o.Kh + p[kDeoxyhemoglobin] * o.Kdh + p[kBilirubin] * o.Kb;
  const auto epidermis = kubelka_layer(epidermis_K, o.Se, site.epidermis_mm);
  const auto dermis = kubelka_layer(dermis_K, o.Sd, site.dermis_mm);
  const T dermis_total = dermis.r + dermis.t * dermis.t / (1.0 - dermis.r);  // Rdt, hypodermis R = 1
  const T through_dermis = epidermis.t * epidermis.t * dermis_total / (1.0 - epidermis.r * dermis_total);
  const T kept = 1.0 - lateral_loss(dermis_K, o.Sd, lateral_radius_mm);
  return (1.0 - rs) * (epidermis.r + kept * through_dermis) + rs;
}

// The model on one wavelength grid for one site.
class SkinModel {
 public:
  // lateral_diffusion false ignores the constants' lateral radius.
  SkinModel(const SkinOptics& optics, const Site& site, std::span<const double> grid_nm, bool lateral_diffusion);

  std::span<const double> grid() const { return grid_; }
  std::size_t size() const { return at_.size(); }
  const Site& site() const { return site_; }

  template <typename T>
  T reflectance_at(std::size_t i, const T* p) const {
    return skin_reflectance(at_[i], site_, lateral_radius_mm_, p);
  }
  std::vector<double> reflectance(const Params& p) const;

  // The most negative pigment weights that still leave every layer's absorption positive
  // (with margin), even when all pigments of a layer are that negative at once: a solver may
  // wander there briefly without the model turning into NaN.
  Params lowest_safe_weights() const;

 private:
  std::vector<double> grid_;
  std::vector<OpticsAt> at_;
  Site site_;
  double lateral_radius_mm_;
};

}  // namespace skinspec
