#pragma once
// The spectral side of eq. 2 and eq. 6: the skin's reflectance R(lambda) from the two-layer
// model with its pigments scaled or its parameters changed, and the tristimulus values of the
// body term R E and of the specular term E under an illuminant.

#include <expected>
#include <span>
#include <string>

#include "skinspec/fit/model.hpp"
#include "skinspec/fit/optics.hpp"
#include "skinspec/spectral/colour.hpp"

namespace skinspec::render {

// Multipliers of the four pigment weights: "melanin x 4" is {4, 1, 1, 1}.
struct PigmentScales {
  double melanin = 1, oxyhemoglobin = 1, deoxyhemoglobin = 1, bilirubin = 1;
};
inline constexpr double kMaxPigmentScale = 100;

// A model's parameters with each pigment multiplied by its scale (in the extended model, the
// oxy- and deoxy-haemoglobin its total haemoglobin and saturation stand for); an error when a
// scale is negative, above kMaxPigmentScale or not finite, or a parameter lies outside the
// range its equations hold for.
std::expected<Params, std::string> scaled_params(ModelKind model, const Params& params, const PigmentScales& scales);

// One of a model's own parameters changed for a render: an amount (an absorber, such as
// melanin) multiplied by a factor, or any parameter set to a value (an oxygen saturation of
// 0.6). A fraction is set, never scaled: twice a saturation means nothing.
struct ParamChange {
  enum class Kind { scale, value };
  std::size_t index = 0;  // in the model's ParamSpec table
  Kind kind = Kind::scale;
  double amount = 1;  // the factor (0..kMaxPigmentScale), or the value (within the domain)
};

// The change of `model`'s parameter `index`, checked: an error when the model has no such
// parameter, a factor is given for one that is not an amount or lies outside 0..kMaxPigmentScale,
// or a value lies outside the range the parameter's equations hold for (ParamSpec's domain).
std::expected<ParamChange, std::string> param_change(ModelKind model, std::size_t index, ParamChange::Kind kind,
                                                     double amount);

// `params` with each change applied; a scaled amount is held to its parameter's domain. An
// error when `params` are not the model's or lie outside its domains, or a change is not valid
// (param_change).
std::expected<Params, std::string> changed_params(ModelKind model, const Params& params,
                                                  std::span<const ParamChange> changes);

// R(lambda) on 380-780 nm every 1 nm, in optics' model. Without the lateral-loss correction:
// that models light an instrument's aperture misses, while an eye looking at a hand sees all
// of it.
Spectrum skin_reflectance_spectrum(const SkinOptics& optics, const Site& site, const Params& params);

// Eq. 6 applied to the two spectra of eq. 2. Because F has no wavelength dependence here (one
// refractive index) and every light has the illuminant's spectrum, Y(lambda) of a pixel is
// body R(lambda) E(lambda) + specular E(lambda), and its XYZ is body * body_xyz +
// specular * specular_xyz: the integral is done once per image, exactly, at 1 nm.
// Normalised so that a perfect white diffuser (R = 1) lit at unit weight has Y = 1.
struct SpectralColours {
  Xyz body;      // XYZ of R(lambda) E(lambda)
  Xyz specular;  // XYZ of E(lambda): the illuminant's white
};
SpectralColours spectral_colours(const Colorimetry& colorimetry, const Spectrum& reflectance,
                                 const Spectrum& illuminant);

}  // namespace skinspec::render
