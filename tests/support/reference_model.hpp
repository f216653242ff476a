#pragma once
// Test helper: eq. 1 of Doi, Tanaka & Tominaga written out independently of the project's
// model (skinspec/fit/model.hpp), in the paper's hyperbolic forms, from plain numbers. Tests
// compare the model, or what the skinspec program prints, against it; so it must never use
// the code under test.

namespace skinspec::testing::reference {

// Reflectance and transmittance of one Kubelka-Munk layer.
struct Layer {
  double r, t;
};

// Kubelka: R = 1/(a + b coth C), T = b/(a sinh C + b cosh C), a = (S+K)/S, b = sqrt(a^2-1),
// C = D b S; K and S per mm, D in mm.
Layer kubelka(double K, double S, double D);

// Eq. 1's combination of the layers: the dermis over a white hypodermis (reflectance 1), seen
// through the epidermis, under a surface that reflects Rs.
double skin_reflectance(const Layer& epidermis, const Layer& dermis, double Rs);

// The model's constants at one wavelength: baseline absorption and scattering of each layer,
// and the absorption of weight 1.0 of each pigment.
struct Coefficients {
  double Ke, Se, Kd, Sd, Km, Kh, Kdh, Kb;
};

struct Weights {
  double surface_reflectance, melanin, oxyhemoglobin, deoxyhemoglobin, bilirubin;
};

// R(lambda) of eq. 1, with the pigment weights applied exactly as the paper's K_et and K_dt.
double eq1(const Coefficients& c, double epidermis_mm, double dermis_mm, const Weights& w);

// The extended model's parameters (docs/model.md): blood as total haemoglobin and saturation,
// the dermis's reduced scattering A (lambda / 620 nm)^-b in cm-1.
struct ExtendedParams {
  double surface_reflectance, melanin, total_hemoglobin, oxygen_saturation, bilirubin;
  double dermis_scattering, dermis_scattering_power;
};

// Kubelka's reflectance of a layer over a background of reflectance Rg:
// R = (1 - Rg (a - b coth C)) / (a - Rg + b coth C).
double kubelka_over(double K, double S, double D, double Rg);

// R(lambda) of the extended model without lateral diffusion, from eq. 1's layers, with blood
// packed in vessels of the given radius (0: spread evenly) and a stratum corneum of the given
// thickness (the epidermis's baseline absorption and scattering, no melanin) over the
// epidermis; c.Sd unused.
double extended(const Coefficients& c, double wavelength_nm, double epidermis_mm, double dermis_mm,
                double vessel_radius_mm, const ExtendedParams& p, double stratum_corneum_mm = 0);

}  // namespace skinspec::testing::reference
