#include "prepared_model.hpp"

#include <algorithm>
#include <atomic>

namespace skinspec::detail {

PreparedModel::PreparedModel(const SkinOptics& optics, const Site& site, std::span<const double> grid_nm,
                             bool lateral_diffusion, const ColourWeighting& d65_weighting)
    : model(optics, site, grid_nm, lateral_diffusion),
      columns(model),
      bounds(bounds_of(model)),
      coarse(coarse_layers(model, std::vector<bool>(model.param_count(), false), Params(model.param_count(), 0.0))),
      d65(Colorimetry::on_samples(grid_nm, d65_weighting)) {}

namespace {

std::uint64_t next_cache_id() {
  static std::atomic<std::uint64_t> last{0};
  return ++last;
}

}  // namespace

ModelCache::ModelCache(ColourWeighting d65) : id_(next_cache_id()), d65_(std::move(d65)) {}

bool ModelCache::Entry::matches(ModelKind m, const Site& s, std::span<const double> grid, bool lateral) const {
  return model == m && lateral_diffusion == lateral && site.name == s.name && site.epidermis_mm == s.epidermis_mm &&
         site.dermis_mm == s.dermis_mm && site.stratum_corneum_mm == s.stratum_corneum_mm &&
         std::ranges::equal(grid_nm, grid);
}

const PreparedModel& ModelCache::get(const SkinOptics& optics, const Site& site, std::span<const double> grid_nm,
                                     bool lateral_diffusion) {
  struct Last {
    std::uint64_t cache = 0;
    Entry entry;
  };
  thread_local Last last;
  if (last.cache != id_ || !last.entry.matches(optics.model(), site, grid_nm, lateral_diffusion))
    last = {id_,
            {optics.model(),
             site,
             {grid_nm.begin(), grid_nm.end()},
             lateral_diffusion,
             shared_get(optics, site, grid_nm, lateral_diffusion)}};
  return *last.entry.prepared;
}

std::shared_ptr<const PreparedModel> ModelCache::shared_get(const SkinOptics& optics, const Site& site,
                                                            std::span<const double> grid_nm, bool lateral_diffusion) {
  const auto matches = [&](const Entry& e) { return e.matches(optics.model(), site, grid_nm, lateral_diffusion); };
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
