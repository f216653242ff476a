#include "skinspec/render/skin_colour.hpp"

#include <cmath>
#include <fmt/format.h>

#include "skinspec/fit/fitter.hpp"

namespace skinspec::render {

namespace {

std::expected<void, std::string> check_scale(std::string_view pigment, double factor) {
  if (factor >= 0 && factor <= kMaxPigmentScale) return {};
  return std::unexpected(fmt::format("the scale of {} must be 0..{}, not {}", pigment, kMaxPigmentScale, factor));
}

}  // namespace

std::expected<Params, std::string> scaled_params(ModelKind model, const Params& params, const PigmentScales& scales) {
  const auto specs = model_spec(model).params;
  if (params.size() != specs.size())
    return std::unexpected(
        fmt::format("{} parameters for the {} model, which has {}", params.size(), to_string(model), specs.size()));
  for (std::size_t p = 0; p < specs.size(); ++p)
    if (!(params[p] >= specs[p].domain_lower && params[p] <= specs[p].domain_upper))
      return std::unexpected(fmt::format("{} = {} is outside {}..{}", specs[p].name, params[p], specs[p].domain_lower,
                                         specs[p].domain_upper));
  const std::pair<std::string_view, double> factors[] = {{"melanin", scales.melanin},
                                                         {"oxyhemoglobin", scales.oxyhemoglobin},
                                                         {"deoxyhemoglobin", scales.deoxyhemoglobin},
                                                         {"bilirubin", scales.bilirubin}};
  for (const auto& [pigment, factor] : factors)
    if (auto ok = check_scale(pigment, factor); !ok) return std::unexpected(ok.error());
  Params out = params;
  out[kMelanin] *= scales.melanin;
  out[kBilirubin] *= scales.bilirubin;
  if (model == ModelKind::paper) {
    out[kOxyhemoglobin] *= scales.oxyhemoglobin;
    out[kDeoxyhemoglobin] *= scales.deoxyhemoglobin;
    return out;
  }
  const double oxy = params[kTotalHemoglobin] * params[kOxygenSaturation] * scales.oxyhemoglobin;
  const double deoxy = params[kTotalHemoglobin] * (1 - params[kOxygenSaturation]) * scales.deoxyhemoglobin;
  out[kTotalHemoglobin] = oxy + deoxy;
  if (oxy + deoxy > 0) out[kOxygenSaturation] = oxy / (oxy + deoxy);
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
