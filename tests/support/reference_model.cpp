#include "support/reference_model.hpp"

#include <cmath>

namespace skinspec::testing::reference {

Layer kubelka(double K, double S, double D) {
  const double a = (S + K) / S;
  const double b = std::sqrt(a * a - 1);
  const double C = D * b * S;
  const double coth = 1 / std::tanh(C);  // not cosh/sinh: both overflow to inf past C = 710
  return {1 / (a + b * coth), b / (a * std::sinh(C) + b * std::cosh(C))};
}

double skin_reflectance(const Layer& epidermis, const Layer& dermis, double Rs) {
  const double R_dt = dermis.r + dermis.t * dermis.t / (1 - dermis.r);
  const double Re = epidermis.r, Te = epidermis.t;
  return (1 - Rs) * (Re + Te * Te * R_dt / (1 - Re * R_dt)) + Rs;
}

double kubelka_over(double K, double S, double D, double Rg) {
  const double a = (S + K) / S;
  const double b = std::sqrt(a * a - 1);
  const double coth = 1 / std::tanh(D * b * S);
  return (1 - Rg * (a - b * coth)) / (a - Rg + b * coth);
}

double eq1(const Coefficients& c, double epidermis_mm, double dermis_mm, const Weights& w) {
  const double K_et = c.Ke + w.melanin * c.Km;
  const double K_dt = c.Kd + w.oxyhemoglobin * c.Kh + w.deoxyhemoglobin * c.Kdh + w.bilirubin * c.Kb;
  return skin_reflectance(kubelka(K_et, c.Se, epidermis_mm), kubelka(K_dt, c.Sd, dermis_mm), w.surface_reflectance);
}

double extended(const Coefficients& c, double wavelength_nm, double epidermis_mm, double dermis_mm,
                double vessel_radius_mm, const ExtendedParams& p, double stratum_corneum_mm) {
  const double oxy = p.total_hemoglobin * p.oxygen_saturation, deoxy = p.total_hemoglobin * (1 - p.oxygen_saturation);
  // Whole blood's mu_a per mm: weight 1.0 is 0.2 % blood, and K = 2 mu_a.
  const double blood_mu_a = (p.oxygen_saturation * c.Kh + (1 - p.oxygen_saturation) * c.Kdh) / (2 * 0.002);
  const double x = 2 * blood_mu_a * vessel_radius_mm;
  const double packaging = vessel_radius_mm > 0 ? (1 - std::exp(-x)) / x : 1.0;
  const double K_et = c.Ke + p.melanin * c.Km;
  const double K_dt = c.Kd + packaging * (oxy * c.Kh + deoxy * c.Kdh) + p.bilirubin * c.Kb;
  const double mu_s_reduced_per_mm =
      p.dermis_scattering * std::pow(wavelength_nm / 620, -p.dermis_scattering_power) / 10;
  const double S_d = 0.75 * mu_s_reduced_per_mm;
  if (stratum_corneum_mm <= 0)
    return skin_reflectance(kubelka(K_et, c.Se, epidermis_mm), kubelka(K_dt, S_d, dermis_mm), p.surface_reflectance);
  // The skin under the stratum corneum, as eq. 1 without a surface, is its background.
  const double below = skin_reflectance(kubelka(K_et, c.Se, epidermis_mm), kubelka(K_dt, S_d, dermis_mm), 0);
  return (1 - p.surface_reflectance) * kubelka_over(c.Ke, c.Se, stratum_corneum_mm, below) + p.surface_reflectance;
}

}  // namespace skinspec::testing::reference
