#include "skinspec/fit/model.hpp"

#include <algorithm>
#include <limits>

namespace skinspec {

SkinModel::SkinModel(const SkinOptics& optics, const Site& site, std::span<const double> grid_nm,
                     bool lateral_diffusion)
    : grid_(grid_nm.begin(), grid_nm.end()),
      site_(site),
      lateral_radius_mm_(lateral_diffusion ? optics.constants().lateral_radius_mm : 0.0) {
  const LayerOptics o = optics.optics().resampled(grid_nm);
  at_.resize(grid_.size());
  for (std::size_t i = 0; i < grid_.size(); ++i)
    at_[i] = {o.Ke[i], o.Se[i], o.Kd[i], o.Sd[i], o.Km[i], o.Kh[i], o.Kdh[i], o.Kb[i]};
}

std::vector<double> SkinModel::reflectance(const Params& p) const {
  std::vector<double> r(size());
  for (std::size_t i = 0; i < size(); ++i) r[i] = reflectance_at(i, p.data());
  return r;
}

Params SkinModel::lowest_safe_weights() const {
  // Shares of the baseline absorption each pigment may take away: melanin alone in the
  // epidermis, three pigments together in the dermis.
  constexpr double kEpidermisShare = 0.5, kDermisShare = 0.25;
  Params lowest{};
  lowest[kSurfaceReflectance] = 0;
  const auto bound = [&](int param, double OpticsAt::*baseline, double OpticsAt::*pigment, double share) {
    double ratio = std::numeric_limits<double>::infinity();
    for (const auto& o : at_)
      if (o.*pigment > 0) ratio = std::min(ratio, o.*baseline / o.*pigment);
    lowest[static_cast<std::size_t>(param)] = std::isfinite(ratio) ? -share * ratio : -1.0;
  };
  bound(kMelanin, &OpticsAt::Ke, &OpticsAt::Km, kEpidermisShare);
  bound(kOxyhemoglobin, &OpticsAt::Kd, &OpticsAt::Kh, kDermisShare);
  bound(kDeoxyhemoglobin, &OpticsAt::Kd, &OpticsAt::Kdh, kDermisShare);
  bound(kBilirubin, &OpticsAt::Kd, &OpticsAt::Kb, kDermisShare);
  return lowest;
}

}  // namespace skinspec
