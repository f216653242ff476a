#include "skinspec/fit/model.hpp"

#include <algorithm>
#include <limits>

namespace skinspec {

SkinModel::SkinModel(const SkinOptics& optics, const Site& site, std::span<const double> grid_nm,
                     bool lateral_diffusion)
    : kind_(optics.model()),
      grid_(grid_nm.begin(), grid_nm.end()),
      geometry_{site, lateral_diffusion ? optics.constants().lateral_radius_mm : 0.0,
                optics.constants().vessel_radius_um / 1000} {
  const LayerOptics o = optics.optics().resampled(grid_nm);
  at_.resize(grid_.size());
  for (std::size_t i = 0; i < grid_.size(); ++i)
    at_[i] = {o.Ke[i],  o.Se[i], o.Kd[i],
              o.Sd[i],  o.Km[i], o.Kh[i],
              o.Kdh[i], o.Kb[i], std::log(grid_[i] / kScatteringPivotNm)};
  if (site.stratum_corneum_mm > 0) with_stratum_corneum(site.stratum_corneum_mm);
}

// The stratum corneum is keratinised epidermis without melanin or blood: the epidermis's
// baseline absorption and scattering (docs/model.md, "Body sites").
void SkinModel::with_stratum_corneum(double thickness_mm) {
  for (OpticsAt& o : at_) {
    const auto corneum = kubelka_layer(o.Ke, o.Se, thickness_mm);
    o.corneum_r = corneum.r;
    o.corneum_t2 = corneum.t * corneum.t;
  }
}

[[gnu::flatten]] std::vector<double> SkinModel::reflectance(const Params& p) const {
  std::vector<double> r(size());
  for (std::size_t i = 0; i < size(); ++i) r[i] = reflectance_at(i, p.data());
  return r;
}

namespace {

// The smallest ratio baseline / absorber over the grid; -1 when the absorber is nowhere.
template <typename Absorber>
double lowest_ratio(const std::vector<OpticsAt>& at, double OpticsAt::*baseline, Absorber absorber) {
  double ratio = std::numeric_limits<double>::infinity();
  for (const auto& o : at)
    if (absorber(o) > 0) ratio = std::min(ratio, o.*baseline / absorber(o));
  return ratio;
}

}  // namespace

Params SkinModel::lowest_safe_weights() const {
  // Shares of the baseline absorption each absorber may take away: melanin alone in the
  // epidermis, the dermis's absorbers together.
  constexpr double kEpidermisShare = 0.5, kDermisShare = 0.25;
  Params lowest(param_count(), 0.0);
  const auto set = [&](int param, double ratio, double share) {
    lowest[static_cast<std::size_t>(param)] = std::isfinite(ratio) ? -share * ratio : -1.0;
  };
  const auto column = [](double OpticsAt::*member) { return [member](const OpticsAt& o) { return o.*member; }; };
  if (kind_ == ModelKind::paper) {
    set(kMelanin, lowest_ratio(at_, &OpticsAt::Ke, column(&OpticsAt::Km)), kEpidermisShare);
    set(kOxyhemoglobin, lowest_ratio(at_, &OpticsAt::Kd, column(&OpticsAt::Kh)), kDermisShare);
    set(kDeoxyhemoglobin, lowest_ratio(at_, &OpticsAt::Kd, column(&OpticsAt::Kdh)), kDermisShare);
    set(kBilirubin, lowest_ratio(at_, &OpticsAt::Kd, column(&OpticsAt::Kb)), kDermisShare);
    return lowest;
  }
  const auto blood = [](const OpticsAt& o) { return std::max(o.Kh, o.Kdh); };
  set(kMelanin, lowest_ratio(at_, &OpticsAt::Ke, column(&OpticsAt::Km)), kEpidermisShare);
  set(kTotalHemoglobin, lowest_ratio(at_, &OpticsAt::Kd, blood), kDermisShare);
  set(kBilirubin, lowest_ratio(at_, &OpticsAt::Kd, column(&OpticsAt::Kb)), kDermisShare);
  return lowest;
}

}  // namespace skinspec
