#include "skinspec/fit/model.hpp"

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

}  // namespace skinspec
