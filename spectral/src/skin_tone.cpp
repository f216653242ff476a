#include "skinspec/spectral/skin_tone.hpp"

#include <cmath>
#include <numbers>

#include "skinspec/spectral/enum_names.hpp"

namespace skinspec {
namespace {

constexpr EnumNames<ItaClass, 6> kItaClassNames{{
    {ItaClass::very_light, "very_light"},
    {ItaClass::light, "light"},
    {ItaClass::intermediate, "intermediate"},
    {ItaClass::tan, "tan"},
    {ItaClass::brown, "brown"},
    {ItaClass::dark, "dark"},
}};

// Each class's lower bound, exclusive, lightest first (Del Bino et al. 2006).
struct ItaBound {
  double above_deg;
  ItaClass ita_class;
};
constexpr ItaBound kItaBounds[] = {
    {55, ItaClass::very_light}, {41, ItaClass::light}, {28, ItaClass::intermediate},
    {10, ItaClass::tan},        {-30, ItaClass::brown},
};

// 100 log10 of a ratio of two reflectances; nullopt unless both are above zero.
std::optional<double> hundred_log10(double numerator, double denominator) {
  if (!(numerator > 0) || !(denominator > 0)) return std::nullopt;
  return 100 * std::log10(numerator / denominator);
}

}  // namespace

std::string_view to_string(ItaClass ita_class) { return name_of(kItaClassNames, ita_class); }

std::optional<ItaClass> parse_ita_class(std::string_view name) { return value_named(kItaClassNames, name); }

std::span<const std::pair<ItaClass, std::string_view>> ita_class_names() { return kItaClassNames; }

double individual_typology_angle(const Lab& lab_d65) {
  return std::atan2(lab_d65.l - 50, lab_d65.b) * 180 / std::numbers::pi;
}

ItaClass classify_ita(double ita_deg) {
  for (const auto& bound : kItaBounds)
    if (ita_deg > bound.above_deg) return bound.ita_class;
  return ItaClass::dark;
}

SkinTone skin_tone(const Spectrum& reflectance, const Lab& lab_d65) {
  return skin_tone(reflectance.wavelengths(), reflectance.values(), lab_d65);
}

SkinTone skin_tone(std::span<const double> wavelength_nm, std::span<const double> reflectance, const Lab& lab_d65) {
  SkinTone tone;
  tone.ita_deg = individual_typology_angle(lab_d65);
  tone.ita_class = classify_ita(tone.ita_deg);
  const double red = interpolate(wavelength_nm, reflectance, kMelaninRedNm);
  const double green = interpolate(wavelength_nm, reflectance, kErythemaGreenNm);
  tone.melanin_index = hundred_log10(1, red);
  tone.erythema_index = hundred_log10(red, green);
  return tone;
}

}  // namespace skinspec
