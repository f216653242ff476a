#pragma once
// The descriptors of skin colour that dermatology and cosmetic science report, computed from a
// measured reflectance alone (no model), so that they mean the same whatever was fitted:
//
// - ITA°, the individual typology angle, atan((L* - 50) / b*) in degrees (Chardon,
//   Cretois & Hourseau 1991, Int. J. Cosmet. Sci. 13:191-208), from CIELAB under D65 with the
//   CIE 1931 2° observer, and its six classes as Del Bino et al. (2006, Pigment Cell Res.
//   19:606-614) draw them: very light above 55°, light above 41°, intermediate above 28°, tan
//   above 10°, brown above -30°, dark at or below -30°. A boundary value falls in the darker
//   class.
// - The melanin and erythema indices of Diffey, Oliver & Farr (1984, Br. J. Dermatol.
//   111:663-672): M = 100 log10(1 / R_red) and E = 100 log10(R_red / R_green), with R the
//   reflectance as a fraction, at the wavelengths of the DermaSpectrometer that made them
//   common (green 568 nm, red 655 nm). A narrow-band meter integrates over its LEDs' bands;
//   here R is the spectrum interpolated at each wavelength.

#include <optional>
#include <span>
#include <string_view>
#include <utility>

#include "skinspec/spectral/colour.hpp"
#include "skinspec/spectral/spectrum.hpp"

namespace skinspec {

enum class ItaClass { very_light, light, intermediate, tan, brown, dark };

std::string_view to_string(ItaClass ita_class);  // "very_light", ..., "dark"
std::optional<ItaClass> parse_ita_class(std::string_view name);
// Every class with its name, lightest first: for documents that list them (OpenAPI).
std::span<const std::pair<ItaClass, std::string_view>> ita_class_names();

inline constexpr double kErythemaGreenNm = 568, kMelaninRedNm = 655;
// Their units, for every place that shows them.
inline constexpr std::string_view kItaUnit = "degrees";
inline constexpr std::string_view kSkinIndexUnit = "100 log10 of a reflectance ratio (Diffey 1984)";

// atan2 keeps the angle defined where b* is not positive (no skin colour, but any spectrum):
// for b* > 0 it is the arctangent of the definition.
double individual_typology_angle(const Lab& lab_d65);
ItaClass classify_ita(double ita_deg);

struct SkinTone {
  double ita_deg = 0;
  ItaClass ita_class = ItaClass::intermediate;
  // Each needs the reflectance at its wavelengths above zero; nullopt where it is not (a dark
  // reading's noise), rather than an infinite or invented number.
  std::optional<double> melanin_index, erythema_index;
};

// `lab_d65`: the same reflectance's CIELAB under D65 (Colorimetry::lab), which callers have at
// hand already. The reflectance is sampled inside 568-655 nm or held at its ends beyond
// (Spectrum::at); a fit's spectrum always covers that range.
SkinTone skin_tone(const Spectrum& reflectance, const Lab& lab_d65);
// The same of samples (`wavelength_nm` increasing), as a fit holds them.
SkinTone skin_tone(std::span<const double> wavelength_nm, std::span<const double> reflectance, const Lab& lab_d65);

}  // namespace skinspec
