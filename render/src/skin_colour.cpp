#include "skinspec/render/skin_colour.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>

#include "skinspec/fit/fitter.hpp"

namespace skinspec::render {

namespace {

std::expected<void, std::string> check_scale(std::string_view pigment, double factor) {
  if (factor >= 0 && factor <= kMaxPigmentScale) return {};
  return std::unexpected(fmt::format("the scale of {} must be 0..{}, not {}", pigment, kMaxPigmentScale, factor));
}

bool in_domain(const ParamSpec& spec, double value) { return value >= spec.domain_lower && value <= spec.domain_upper; }

// The model's parameters, each inside the range its equations hold for.
std::expected<void, std::string> check_params(ModelKind model, const Params& params) {
  const auto specs = model_spec(model).params;
  if (params.size() != specs.size())
    return std::unexpected(
        fmt::format("{} parameters for the {} model, which has {}", params.size(), to_string(model), specs.size()));
  for (std::size_t p = 0; p < specs.size(); ++p)
    if (!in_domain(specs[p], params[p]))
      return std::unexpected(fmt::format("{} = {} is outside {}..{}", specs[p].name, params[p], specs[p].domain_lower,
                                         specs[p].domain_upper));
  return {};
}

}  // namespace

std::expected<ParamChange, std::string> param_change(ModelKind model, std::size_t index, ParamChange::Kind kind,
                                                     double amount) {
  const auto specs = model_spec(model).params;
  if (index >= specs.size())
    return std::unexpected(fmt::format("the {} model has no parameter {}", to_string(model), index));
  const ParamSpec& spec = specs[index];
  if (kind == ParamChange::Kind::value) {
    if (in_domain(spec, amount)) return ParamChange{index, kind, amount};
    return std::unexpected(
        fmt::format("{} must be {}..{}, not {}", spec.name, spec.domain_lower, spec.domain_upper, amount));
  }
  if (!spec.absorber)
    return std::unexpected(fmt::format("{} is not an amount to scale; set its value instead", spec.name));
  if (auto ok = check_scale(spec.name, amount); !ok) return std::unexpected(ok.error());
  return ParamChange{index, kind, amount};
}

std::expected<Params, std::string> changed_params(ModelKind model, const Params& params,
                                                  std::span<const ParamChange> changes) {
  if (auto ok = check_params(model, params); !ok) return std::unexpected(ok.error());
  const auto specs = model_spec(model).params;
  Params out = params;
  for (const ParamChange& c : changes) {
    if (auto ok = param_change(model, c.index, c.kind, c.amount); !ok) return std::unexpected(ok.error());
    const ParamSpec& spec = specs[c.index];
    out[c.index] = c.kind == ParamChange::Kind::value
                       ? c.amount
                       : std::clamp(out[c.index] * c.amount, spec.domain_lower, spec.domain_upper);
  }
  return out;
}

std::expected<Params, std::string> scaled_params(ModelKind model, const Params& params, const PigmentScales& scales) {
  if (auto ok = check_params(model, params); !ok) return std::unexpected(ok.error());
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
