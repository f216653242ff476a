#pragma once
// What a fit needs that depends on the model, the site and the samples' wavelengths but not on
// the measured values (private to fit/): the model on that grid, its columns, the solver's
// bounds, the coarse search's layers and the colour weighting on the grid. Building them cost about as much as a third
// of a fit; a batch of spectra from one instrument shares one grid, so each Fitter keeps the few it built last
// (ModelCache) and its fits share them.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <utility>
#include <vector>

#include "skinspec/fit/model.hpp"
#include "skinspec/spectral/colour.hpp"
#include "solver.hpp"
#include "spectrum_model.hpp"

namespace skinspec::detail {

struct PreparedModel {
  PreparedModel(const SkinOptics& optics, const Site& site, std::span<const double> grid_nm, bool lateral_diffusion,
                const ColourWeighting& d65);
  PreparedModel(const PreparedModel&) = delete;  // `columns` refers to `model`
  PreparedModel& operator=(const PreparedModel&) = delete;

  SkinModel model;
  SpectrumModel columns;
  Bounds bounds;
  CoarseLayers coarse;   // with no parameter held
  SampledWeighting d65;  // for the fit's colour difference
};

// The prepared models of the last few (model, site, grid, lateral diffusion) a Fitter fitted;
// safe to use from several threads at once. Bounded, so that memory stays flat however many
// grids pass through.
class ModelCache {
 public:
  // Every model it prepares judges colour under `d65` (the Fitter's).
  explicit ModelCache(ColourWeighting d65);

  // Valid until the calling thread's next get. Each thread keeps what it got last, and whom
  // from, beside the shared entries: fits on one thread mostly share a grid, and threads that
  // took the lock and a share of the same entry for every fit waited on each other's cache
  // lines (2 % of a map's time on two cores). So a thread holds one prepared model after its
  // cache is gone, until it gets another.
  const PreparedModel& get(const SkinOptics& optics, const Site& site, std::span<const double> grid_nm,
                           bool lateral_diffusion);

 private:
  static constexpr std::size_t kCapacity = 8;
  struct Entry {
    ModelKind model;
    Site site;
    std::vector<double> grid_nm;
    bool lateral_diffusion;
    std::shared_ptr<const PreparedModel> prepared;

    bool matches(ModelKind m, const Site& s, std::span<const double> grid, bool lateral) const;
  };
  std::shared_ptr<const PreparedModel> shared_get(const SkinOptics& optics, const Site& site,
                                                  std::span<const double> grid_nm, bool lateral_diffusion);

  // Unlike its address, never reused: tells a thread's last entry from this cache from one it
  // kept from a cache destroyed before.
  const std::uint64_t id_;
  const ColourWeighting d65_;
  std::mutex mutex_;
  std::vector<Entry> entries_;  // most recently built last
};

}  // namespace skinspec::detail
