#include "skinspec/render/skin_colour.hpp"

#include <cmath>
#include <fmt/format.h>

#include "skinspec/fit/fitter.hpp"

namespace skinspec::render {

std::expected<Params, std::string> scaled_params(const Params& params, const PigmentScales& scales) {
  for (int p = 0; p < kParamCount; ++p)
    if (!(params[p] >= kLowerBounds[p] && params[p] <= kUpperBounds[p]))
      return std::unexpected(
          fmt::format("{} = {} is outside {}..{}", kParamNames[p], params[p], kLowerBounds[p], kUpperBounds[p]));
  const std::pair<Param, double> factors[] = {{kMelanin, scales.melanin},
                                              {kOxyhemoglobin, scales.oxyhemoglobin},
                                              {kDeoxyhemoglobin, scales.deoxyhemoglobin},
                                              {kBilirubin, scales.bilirubin}};
  Params out = params;
  for (const auto& [p, factor] : factors) {
    if (!(factor >= 0 && factor <= kMaxPigmentScale))
      return std::unexpected(
          fmt::format("the scale of {} must be 0..{}, not {}", kParamNames[p], kMaxPigmentScale, factor));
    out[p] *= factor;
  }
  return out;
}

Spectrum skin_reflectance_spectrum(const SkinOptics& optics, const Site& site, const Params& params) {
  const auto grid = Spectrum::uniform_grid(SkinOptics::kFirstNm, SkinOptics::kLastNm, 1);
  const SkinModel model(optics, site, grid, false);
  return *Spectrum::create(grid, model.reflectance(params));
}

SpectralColours spectral_colours(const Colorimetry& colorimetry, const Spectrum& reflectance,
                                 const Spectrum& illuminant) {
  const ColourWeighting weighting = colorimetry.weighting(illuminant);
  return {Colorimetry::xyz(reflectance, weighting), weighting.white};
}

}  // namespace skinspec::render
