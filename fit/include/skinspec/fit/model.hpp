#pragma once
// The two-layer Kubelka-Munk skin model of Doi, Tanaka & Tominaga, eq. 1, one wavelength at a
// time, in the forms of each model (model_spec.hpp). Templated on the scalar so that Ceres can
// differentiate exactly what plain double runs.

#include <cmath>
#include <span>
#include <string_view>
#include <vector>

#include "skinspec/fit/optics.hpp"

namespace skinspec {

// One wavelength's constants (per mm), and the logarithm the extended model's scattering power
// law needs.
struct OpticsAt {
  double Ke, Se, Kd, Sd, Km, Kh, Kdh, Kb;
  double log_scattering_ratio = 0;  // ln(lambda / kScatteringPivotNm)
  // The stratum corneum's reflectance and squared transmittance: no parameter acts on it, so
  // they are constants of the site (0 and 1: no stratum corneum).
  double corneum_r = 0, corneum_t2 = 1;
};

// Where the extended model's dermal scattering power law is pivoted: at 620 nm, in the red
// where blood absorbs little, so that its amplitude and its power are told apart (docs/model.md).
inline constexpr double kScatteringPivotNm = 620;
// Kubelka-Munk S per mm for a reduced scattering coefficient of 1 cm-1: S = 3/4 mu_s'.
inline constexpr double kScatteringPerTransport = 0.75 * 0.1;

template <typename T>
struct ReflectanceTransmittance {
  T r, t;
};

// Kubelka's reflectance and transmittance of a layer of absorption K, scattering S and
// thickness D: R = 1/(a + b coth C), T = b/(a sinh C + b cosh C), C = D b S. Written with
// e^(-C) and its square e^(-2C) (one exponential, the costliest part of the model), so that
// thick layers tend to R = a - b instead of overflowing cosh.
template <typename T, typename S>
ReflectanceTransmittance<T> kubelka_layer(const T& K, const S& scattering, double D) {
  using std::exp;
  using std::sqrt;
  const T k = K / scattering;
  const T a = 1.0 + k;
  const T b = sqrt(k * (k + 2.0));  // sqrt(a^2 - 1) without cancellation for small k
  const T c = D * scattering * b;
  const T e1 = exp(-c);
  const T e = e1 * e1;
  const T denominator = a * (1.0 - e) + b * (1.0 + e);
  return {(1.0 - e) / denominator, 2.0 * b * e1 / denominator};
}

// Fraction of the light remitted through the dermis that leaves the skin beyond `radius_mm`
// from where it entered, so is missed by the instrument: for an exponential radial profile
// exp(-mu_eff r) of diffusing light, the share beyond r0 is (1 + mu_eff r0) exp(-mu_eff r0).
template <typename T, typename S>
T lateral_loss(const T& dermis_K, const S& dermis_S, double radius_mm) {
  using std::exp;
  using std::sqrt;
  if (radius_mm <= 0) return T(0.0);
  const T mu_a = dermis_K / 2.0;                // K = 2 mu_a
  const S mu_s_reduced = dermis_S * 4.0 / 3.0;  // S = 3/4 mu_s'
  const T mu_eff = sqrt(3.0 * mu_a * (mu_a + mu_s_reduced));
  const T x = radius_mm * mu_eff;
  return (1.0 + x) * exp(-x);
}

// The fixed geometry of one model on one site: layer thicknesses, the radius beyond which
// remitted light is lost (0: none) and the radius of the vessels blood is packed in (0: blood
// spread evenly; the extended model only).
struct Geometry {
  Site site;
  double lateral_radius_mm = 0;
  double vessel_radius_mm = 0;
};

// The share of its absorption that blood packed in cylindrical vessels of radius r exerts,
// compared with the same blood spread evenly: C = (1 - exp(-x)) / x, x = 2 mu_a,blood r
// (L. O. Svaasand et al., Lasers Med. Sci. 10, 55 (1995); R. L. P. van Veen, W. Verkruysse and
// H. J. C. M. Sterenborg, Opt. Lett. 27, 246 (2002)). Strong bands are flattened most.
template <typename T>
T vessel_packaging(const T& blood_mu_a_per_mm, double vessel_radius_mm) {
  using std::expm1;
  if (vessel_radius_mm <= 0) return T(1.0);
  const T x = 2.0 * blood_mu_a_per_mm * vessel_radius_mm;
  return -expm1(-x) / x;
}

// The dermis over a white hypodermis (reflectance 1): its total reflectance Rdt.
template <typename T>
T dermis_over_white(const ReflectanceTransmittance<T>& dermis) {
  return dermis.r + dermis.t * dermis.t / (1.0 - dermis.r);
}

// What the dermis over a white hypodermis remits (`total`), and the share of it that reaches
// the instrument (`kept`: less what lateral diffusion carries out of the measured spot).
template <typename T>
struct DermisRemittance {
  T total, kept;
};

template <typename T, typename S>
DermisRemittance<T> dermis_remittance(const T& K, const S& scattering, const Geometry& g) {
  return {dermis_over_white(kubelka_layer(K, scattering, g.site.dermis_mm)),
          1.0 - lateral_loss(K, scattering, g.lateral_radius_mm)};
}

// What comes out of the skin under its surface when the stratum corneum lies over the rest,
// which remits x: Rc + Tc^2 x / (1 - Rc x), the same combination as the epidermis's over the
// dermis. Without one, x as it is.
template <typename T>
T under_stratum_corneum(const OpticsAt& o, const T& x) {
  if (o.corneum_r == 0) return x;
  return o.corneum_r + o.corneum_t2 * x / (1.0 - o.corneum_r * x);
}

// Eq. 1's layers combined: surface reflection rs, then the stratum corneum (if any) over the
// epidermis over the dermis.
template <typename T>
T combined_reflectance(const OpticsAt& o, const T& rs, const ReflectanceTransmittance<T>& epidermis,
                       const DermisRemittance<T>& dermis) {
  const T through_dermis = epidermis.t * epidermis.t * dermis.total / (1.0 - epidermis.r * dermis.total);
  return (1.0 - rs) * under_stratum_corneum(o, T(epidermis.r + dermis.kept * through_dermis)) + rs;
}

// The epidermis of either model: melanin over the baseline absorption (p in either model's
// order; melanin sits at the same index in both). The extended model's melanin and baseline
// absorption carry the tuned corrections already (SkinOptics::optics()).
template <typename T>
ReflectanceTransmittance<T> epidermis_layer(const OpticsAt& o, const Geometry& g, const T* p) {
  const T epidermis_K = o.Ke + p[kMelanin] * o.Km;
  return kubelka_layer(epidermis_K, o.Se, g.site.epidermis_mm);
}

// The paper's dermis: its three absorbers' weights in p (Param order).
template <typename T>
DermisRemittance<T> paper_dermis(const OpticsAt& o, const Geometry& g, const T* p) {
  const T dermis_K = o.Kd + p[kOxyhemoglobin] * o.Kh + p[kDeoxyhemoglobin] * o.Kdh + p[kBilirubin] * o.Kb;
  return dermis_remittance(dermis_K, o.Sd, g);
}

// The extended model's dermis (ExtendedParam order): blood as total haemoglobin and its oxygen
// saturation, packed in vessels, and the dermis's reduced scattering a power law
// mu_s' = A (lambda / 620 nm)^-b with A and b free.
template <typename T>
DermisRemittance<T> extended_dermis(const OpticsAt& o, const Geometry& g, const T* p) {
  using std::exp;
  const T saturation = p[kOxygenSaturation];
  const T blood_K = saturation * o.Kh + (1.0 - saturation) * o.Kdh;  // weight 1: kReferenceBloodFraction of blood
  const T packed_K = blood_K * vessel_packaging(blood_K / (2.0 * kReferenceBloodFraction), g.vessel_radius_mm);
  const T dermis_K = o.Kd + p[kTotalHemoglobin] * packed_K + p[kBilirubin] * o.Kb;
  const T dermis_S =
      kScatteringPerTransport * p[kDermisScattering] * exp(-p[kDermisScatteringPower] * o.log_scattering_ratio);
  return dermis_remittance(dermis_K, dermis_S, g);
}

// The model on one wavelength grid for one site.
class SkinModel {
 public:
  // lateral_diffusion false ignores the constants' lateral radius.
  SkinModel(const SkinOptics& optics, const Site& site, std::span<const double> grid_nm, bool lateral_diffusion);

  std::span<const double> grid() const { return grid_; }
  std::size_t size() const { return at_.size(); }
  const Site& site() const { return geometry_.site; }
  const Geometry& geometry() const { return geometry_; }
  // The constants at sample i.
  const OpticsAt& optics_at(std::size_t i) const { return at_[i]; }

  ModelKind kind() const { return kind_; }
  std::size_t param_count() const { return model_spec(kind_).params.size(); }

  // Eq. 1 at sample i: surface reflection, then the epidermis over the dermis. p holds
  // param_count() values in the order of the model's ParamSpec table.
  template <typename T>
  T reflectance_at(std::size_t i, const T* p) const {
    return combined_reflectance(at_[i], T(p[kSurfaceReflectance]), epidermis_at(i, p), dermis_at(i, p));
  }
  // The two layers at sample i apart, for a search over points that share one of them: the
  // epidermis depends on melanin alone, the dermis on every parameter but melanin and Rs.
  template <typename T>
  ReflectanceTransmittance<T> epidermis_at(std::size_t i, const T* p) const {
    return epidermis_layer(at_[i], geometry_, p);
  }
  template <typename T>
  DermisRemittance<T> dermis_at(std::size_t i, const T* p) const {
    return kind_ == ModelKind::paper ? paper_dermis(at_[i], geometry_, p) : extended_dermis(at_[i], geometry_, p);
  }
  // The reflectance at sample i and, when `gradient` is not null, its derivative with respect
  // to each of the param_count() parameters, exactly (model_gradient.cpp).
  double reflectance_and_gradient(std::size_t i, const double* p, double* gradient) const;
  // Requires p.size() == param_count().
  std::vector<double> reflectance(const Params& p) const;

  // The most negative absorber amounts that still leave every layer's absorption positive
  // (with margin), even when all absorbers of a layer are that negative at once: a solver may
  // wander there briefly without the model turning into NaN. Other entries are 0.
  Params lowest_safe_weights() const;

 private:
  void with_stratum_corneum(double thickness_mm);

  ModelKind kind_;
  std::vector<double> grid_;
  std::vector<OpticsAt> at_;
  Geometry geometry_;
};

}  // namespace skinspec
