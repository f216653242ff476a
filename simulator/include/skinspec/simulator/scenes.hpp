#pragma once
// What the simulated meter looks at: a scene is a spectral radiance on the meter's own grid
// (the PR-650's 380-780 nm every 4 nm, or the model's: MeterProfile::simulator_grid), made
// from a radiance spectrum, or from a reflectance under a lamp. And the meter's arithmetic on
// it: luminance, chromaticity and CCT with the CIE 1931 observer sampled on the same grid.

#include <array>
#include <expected>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "skinspec/drivers/meter_profile.hpp"
#include "skinspec/spectral/spectrum.hpp"
#include "skinspec/spectral/table.hpp"

namespace skinspec::simulator {

// The PR-650's grid: 380, 384, ..., 780 nm.
const std::vector<double>& native_grid();
// The wavelengths of a model's grid: first, first + step, ..., last.
std::vector<double> wavelengths(const drivers::Grid& grid);

// Luminous efficacy of radiation at 555 nm, lm/W.
inline constexpr double kKm = 683.0;
// cd/m2 per footlambert.
inline constexpr double kCandelaPerFootlambert = 3.4262591;

// The CIE 1931 2 degree colour-matching functions sampled on the meter's grid.
struct Observer {
  std::vector<double> xbar, ybar, zbar;
  std::vector<double> nm;  // the grid, evenly spaced
  // From data/colour/cie1931_2deg_cmf.csv (columns wavelength_nm, xbar, ybar, zbar).
  static std::expected<Observer, std::string> from_table(const Table& cmf,
                                                         std::span<const double> grid = native_grid());
  double step_nm() const { return nm.size() > 1 ? nm[1] - nm[0] : 1; }
};

// What the meter derives from a spectrum on the observer's grid (W/(sr m2 nm)), summing at its step.
struct Photometry {
  double X = 0, Y = 0, Z = 0;  // Y in cd/m2
  double x = 0, y = 0;         // CIE 1931
  double u = 0, v = 0;         // CIE 1976 u', v'
  double cct = 0;              // K (McCamy); 0 for black
  double duv = 0;              // distance from the Planckian locus in CIE 1960 uv, + above it
};
Photometry photometry(std::span<const double> radiance, const Observer& observer);
// The values of colour report `report` (1: Y,x,y; 2: X,Y,Z; 3: Y,u',v'; 4: Y,CCT,duv; 6: Y,x,y,u',v'),
// luminances in cd/m2 with `si_units`, else in footlamberts. Both families print the same.
std::vector<double> colour_report_values(const Photometry& p, int report, bool si_units);

// The colour tables of data/colour/: the observer and the illuminants D65 and A.
struct ColourData {
  Observer observer;
  Spectrum d65, a;
  // "D65" or "A"; an error naming the known ones otherwise.
  std::expected<Spectrum, std::string> illuminant(std::string_view name) const;
  // Reads colour/cie1931_2deg_cmf.csv and colour/cie_illuminants.csv; the observer on `grid`.
  static std::expected<ColourData, std::string> load(const DataReader& read,
                                                     std::span<const double> grid = native_grid());
};

struct Scene {
  std::string name;
  std::vector<double> radiance;  // W/(sr m2 nm), one value per point of the meter's grid
  double flicker_hz = 60.02;     // what F finds; 0 for a steady light (sync then fails)
};

// A radiance spectrum resampled onto the grid (ends held). Fails on negative values.
std::expected<Scene, std::string> scene_from_radiance(std::string name, const Spectrum& radiance,
                                                      std::span<const double> grid = native_grid());

// A lamp: its relative spectral power and how bright a perfect white diffuser is under it.
struct Lamp {
  std::string name;  // "A", "D65", a file name
  Spectrum power;
  double white_luminance = 100;  // cd/m2 of a reflectance of 1 everywhere
};

// The radiance a reflectance sends back under the lamp: R(l) S(l) k, with k such that a
// reflectance of 1 has the lamp's white luminance. On the observer's grid.
Scene scene_under_lamp(std::string name, const Spectrum& reflectance, const Lamp& lamp, const Observer& observer);

// Spectra CSV files (skinspec::parse_spectra_csv): one scene per column, named
// "<column>" (radiance in W/(sr m2 nm); reflectance 0-1.5) or "<column> under <lamp>".
std::expected<std::vector<Scene>, std::string> radiance_scenes(std::string_view csv, std::string_view source,
                                                               std::span<const double> grid = native_grid());
std::expected<std::vector<Scene>, std::string> reflectance_scenes(std::string_view csv, std::string_view source,
                                                                  const Lamp& lamp, const Observer& observer);
// The first column of a spectra CSV file as a lamp's relative power.
std::expected<Spectrum, std::string> illuminant_from_csv(std::string_view csv, std::string_view source);

}  // namespace skinspec::simulator
