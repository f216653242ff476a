#include "prepared_model.hpp"

#include <algorithm>

namespace skinspec::detail {

PreparedModel::PreparedModel(const SkinOptics& optics, const Site& site, std::span<const double> grid_nm,
                             bool lateral_diffusion, const ColourWeighting& d65_weighting)
    : model(optics, site, grid_nm, lateral_diffusion),
      columns(model),
      bounds(bounds_of(model)),
      coarse(coarse_layers(model, std::vector<bool>(model.param_count(), false), Params(model.param_count(), 0.0))),
      d65(Colorimetry::on_samples(grid_nm, d65_weighting)) {}

std::shared_ptr<const PreparedModel> ModelCache::get(const SkinOptics& optics, const Site& site,
                                                     std::span<const double> grid_nm, bool lateral_diffusion) {
  const auto matches = [&](const Entry& e) {
    return e.model == optics.model() && e.lateral_diffusion == lateral_diffusion && e.site.name == site.name &&
           e.site.epidermis_mm == site.epidermis_mm && e.site.dermis_mm == site.dermis_mm &&
           e.site.stratum_corneum_mm == site.stratum_corneum_mm && std::ranges::equal(e.grid_nm, grid_nm);
  };
  {
    const std::lock_guard lock(mutex_);
    const auto it = std::ranges::find_if(entries_, matches);
    if (it != entries_.end()) return it->prepared;
  }
  // Built outside the lock: two threads may both build the same one, and one copy is kept.
  auto prepared = std::make_shared<const PreparedModel>(optics, site, grid_nm, lateral_diffusion, d65_);
  const std::lock_guard lock(mutex_);
  if (std::ranges::none_of(entries_, matches)) {
    if (entries_.size() == kCapacity) entries_.erase(entries_.begin());
    entries_.push_back({optics.model(), site, {grid_nm.begin(), grid_nm.end()}, lateral_diffusion, prepared});
  }
  return prepared;
}

}  // namespace skinspec::detail
