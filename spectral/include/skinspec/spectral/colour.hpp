#pragma once
// Colorimetry: reflectance spectra to CIE XYZ under an illuminant (CIE 1931 2 degree observer),
// CIELAB, CIEDE2000 and sRGB (IEC 61966-2-1).

#include <array>
#include <expected>
#include <span>
#include <string_view>
#include <vector>

#include "skinspec/spectral/spectrum.hpp"
#include "skinspec/spectral/table.hpp"

namespace skinspec {

struct Xyz {
  double x = 0, y = 0, z = 0;
};

struct Lab {
  double l = 0, a = 0, b = 0;
};

// An illuminant's power times each colour-matching function, at 1 nm over the observer's
// range, with the illuminant's white: computed once, it makes judging many spectra under one
// light a single pass each.
struct ColourWeighting {
  std::vector<double> x, y, z;
  Xyz white;
};

// A ColourWeighting carried onto one grid of samples: a weight per sample, so that the
// tristimulus values of any values on that grid are three dot products. Linear resampling is
// linear in the values, so these are the sums Colorimetry::xyz takes, each point's weight
// gathered onto the two samples it is interpolated from (the same to rounding).
struct SampledWeighting {
  std::vector<double> x, y, z;
  Xyz white;
};

class Colorimetry {
 public:
  // cmf: columns wavelength_nm, xbar, ybar, zbar. illuminants: wavelength_nm, D65, A.
  static std::expected<Colorimetry, InputError> from_tables(const Table& cmf, const Table& illuminants);

  // "D65" or "A"; an error naming the known ones otherwise.
  std::expected<Spectrum, std::string> illuminant(std::string_view name) const;

  // Tristimulus values of a reflectance under an illuminant, summed at 1 nm over the observer's
  // range (360-830 nm). Both spectra are resampled linearly and held constant past their ends.
  // Normalised so that the perfect reflecting diffuser has Y = 1.
  Xyz xyz(const Spectrum& reflectance, const Spectrum& illuminant) const;
  // The illuminant's white point (Y = 1).
  Xyz white(const Spectrum& illuminant) const;
  // CIELAB of a reflectance relative to the illuminant's white.
  Lab lab(const Spectrum& reflectance, const Spectrum& illuminant) const;

  ColourWeighting weighting(const Spectrum& illuminant) const;
  static Xyz xyz(const Spectrum& reflectance, const ColourWeighting& weighting);
  static Lab lab(const Spectrum& reflectance, const ColourWeighting& weighting);
  // For many spectra sampled alike: the weighting on their grid (`wavelength_nm` increasing, at
  // least two), and the colour of values on it (as many as the grid has).
  static SampledWeighting on_samples(std::span<const double> wavelength_nm, const ColourWeighting& weighting);
  static Xyz xyz(std::span<const double> values, const SampledWeighting& weighting);
  static Lab lab(std::span<const double> values, const SampledWeighting& weighting);
  // lab of two spectra on the same samples, to the bit, their sums taken side by side: a fit's
  // measured and fitted colours, where one sum after another waited on each addition.
  static std::array<Lab, 2> labs(std::span<const double> first, std::span<const double> second,
                                 const SampledWeighting& weighting);

 private:
  Spectrum xbar_, ybar_, zbar_, d65_, a_;
  Colorimetry(Spectrum xbar, Spectrum ybar, Spectrum zbar, Spectrum d65, Spectrum a)
      : xbar_(std::move(xbar)),
        ybar_(std::move(ybar)),
        zbar_(std::move(zbar)),
        d65_(std::move(d65)),
        a_(std::move(a)) {}
};

Lab xyz_to_lab(const Xyz& xyz, const Xyz& white);
// CIEDE2000 colour difference (kL = kC = kH = 1), after Sharma, Wu & Dalal (2005).
double delta_e2000(const Lab& reference, const Lab& sample);

// XYZ (Y = 1 for white) to linear sRGB with the IEC 61966-2-1 matrix; not clipped.
std::array<double, 3> xyz_to_linear_srgb(const Xyz& xyz);
// The IEC 61966-2-1 transfer curve, input clipped to [0, 1].
double srgb_encode(double linear);
double srgb_decode(double encoded);
// Linear sRGB to 8-bit codes, clipped and rounded.
std::array<int, 3> srgb_8bit(const std::array<double, 3>& linear);

}  // namespace skinspec
