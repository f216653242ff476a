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

double eq1(const Coefficients& c, double epidermis_mm, double dermis_mm, const Weights& w) {
  const double K_et = c.Ke + w.melanin * c.Km;
  const double K_dt = c.Kd + w.oxyhemoglobin * c.Kh + w.deoxyhemoglobin * c.Kdh + w.bilirubin * c.Kb;
  return skin_reflectance(kubelka(K_et, c.Se, epidermis_mm), kubelka(K_dt, c.Sd, dermis_mm), w.surface_reflectance);
}

}  // namespace skinspec::testing::reference
