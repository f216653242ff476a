#pragma once
// Skin maps: every pixel of a reflectance cube judged (is it skin that can be fitted?) and
// fitted with the skin model, each pixel starting from its fitted left neighbour's answer
// (docs/maps.md). The answers are a float cube with one band per quantity (map_bands).

#include <array>
#include <cstdint>
#include <expected>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "skinspec/fit/fitter.hpp"
#include "skinspec/maps/cube.hpp"
#include "skinspec/maps/map_band.hpp"

namespace skinspec::maps {

// Why a pixel was not fitted; `skin` for one that was. Stored as its number in the mask band.
enum class MaskReason : std::uint8_t {
  skin = 0,
  no_data = 1,     // NaN, or the cube's ignore value, in some band
  saturated = 2,   // the data type's largest value, or reflectance above 1, in some band
  too_dark = 3,    // mean reflectance over 420-680 nm below MapOptions::min_mean_reflectance
  not_skin = 4,    // spectral angle to every reference skin above MapOptions::max_spectral_angle
  not_fitted = 5,  // the fit refused the spectrum
};
inline constexpr std::array kMaskReasons = {MaskReason::skin,     MaskReason::no_data,  MaskReason::saturated,
                                            MaskReason::too_dark, MaskReason::not_skin, MaskReason::not_fitted};
std::string_view to_string(MaskReason reason);

// An error naming the cube's wavelength field when its bands do not cover the 420-680 nm a
// fit needs (kMinCoverFromNm, kMinCoverToNm).
std::expected<void, CubeError> check_coverage(const CubeInfo& cube);

// How a radiance cube becomes reflectance, band by band: (stored - dark) × gain, with gain the
// white panel's calibrated reflectance over (white - dark) (docs/maps.md, "Radiance cubes").
struct Radiometry {
  std::vector<double> dark, gain;
};

struct MapOptions {
  FitOptions fit;  // model, site, lateral diffusion (weights and starts are the mapper's)
  // Empty for a reflectance cube: stored values over its reflectance scale factor.
  std::optional<Radiometry> radiance;
  // The spectral-angle test against skin (docs/maps.md, "Which pixels are skin").
  double max_spectral_angle = 0.2;
  double min_mean_reflectance = 0.02;
  bool neighbour_starts = true;
  unsigned threads = 0;  // 0: one per core
};

// For each parameter its value and standard error (NaN where the spectrum does not determine
// it), then rmse, delta_e00_d65, iterations, termination (its number in termination_names()) and
// mask (a MaskReason's number).
std::vector<MapBand> map_bands(ModelKind model);

// How a block of lines went, added up over the cube for summary.json.
struct MapTally {
  std::array<std::size_t, kMaskReasons.size()> pixels{};  // by MaskReason
  std::size_t iterations = 0;                             // over the fitted pixels
  std::size_t started_from_neighbour = 0;
  std::size_t restarted = 0;  // a neighbour's start that ended worse, fitted again from the coarse search
  void add(const MapTally& other);
};

// A rectangle of a cube's pixels: from sample x, line y, w samples wide and h lines high.
struct Region {
  std::size_t x = 0, y = 0, w = 0, h = 0;
};

// The mean stored spectrum over a region of a cube (the whole cube when w or h is 0), read in
// blocks of lines. Errors: a region outside the cube, a pixel with NaN, the ignore value or the
// type's largest value (a saturated white).
std::expected<std::vector<double>, CubeError> mean_spectrum(const Cube& cube, Region region = {});

// The mean spectrum of a white or dark panel's own cube (every pixel), which must have the bands
// of the cube `mapped`: an error naming the panel's wavelength field otherwise.
std::expected<std::vector<double>, CubeError> panel_spectrum(const Cube& panel, const CubeInfo& mapped);

// The radiometry of a radiance cube from the white panel's mean spectrum, its calibrated
// reflectance on the cube's bands, and the dark's mean spectrum (empty: none). Errors name
// `white`: a band where the white is not above the dark.
std::expected<Radiometry, CubeError> radiometry(const CubeInfo& cube, const std::vector<double>& white,
                                                const std::vector<double>& white_reflectance,
                                                const std::vector<double>& dark);

class Mapper {
 public:
  Mapper(const Fitter& fitter, MapOptions options, const CubeInfo& cube);

  // Fits the lines of one block (values as Cube::read_lines gives them) and returns the answer
  // bands pixel by pixel: value (line, sample, band) at ((line - first) * samples + sample) *
  // map_bands().size() + band. Lines are fitted in parallel, each from its left end, so the
  // answers do not depend on the number of threads.
  std::vector<float> map_lines(std::span<const float> values, std::size_t lines, MapTally& tally) const;

  // The reflectance of every pixel of a block (values as Cube::read_lines gives them), in the
  // same order: the stored values over the scale, or through the radiometry; NaN for the
  // cube's ignore value.
  std::vector<float> reflectance_lines(std::span<const float> values) const;

  // The mask reason of one pixel's reflectance (stored values already divided by the scale)
  // and whether a stored value was the type's largest.
  MaskReason judge(std::span<const double> reflectance, bool clipped) const;

 private:
  void map_line(std::span<const float> line, std::span<float> out, MapTally& tally) const;
  double reflectance_of(double stored, std::size_t band) const;

  const Fitter& fitter_;
  MapOptions options_;
  CubeInfo cube_;
  std::vector<std::size_t> fitted_bands_;   // the cube's bands inside the model's range
  std::vector<double> fitted_nm_;           // their wavelengths
  std::vector<std::size_t> visible_bands_;  // those inside 420-680 nm, for brightness
  // The spectral-angle test's reference skins (light to dark), unit length on fitted_nm_: all of
  // them at each sample, so that judging a pixel takes every dot product in one pass. Empty
  // where the model cannot be evaluated (an unknown site); then nothing counts as skin.
  static constexpr std::size_t kReferenceSkins = 4;
  std::vector<std::array<double, kReferenceSkins>> references_;
  std::size_t band_count_;
};

}  // namespace skinspec::maps
