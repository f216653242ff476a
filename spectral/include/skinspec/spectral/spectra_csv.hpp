#pragma once
// The spectra file format read by `skinspec fit` and `skinspec colour`: CSV with a header whose
// first column is `wavelength_nm`, then one column per spectrum (its name), one row per
// wavelength. Blank lines and lines starting with '#' (comments) are ignored. Values are
// fractions, or percent as the caller's scale says (auto: reflectance_scale.hpp). Every defect
// is reported with line and column.

#include <expected>
#include <string>
#include <string_view>
#include <vector>

#include "skinspec/spectral/reflectance_scale.hpp"
#include "skinspec/spectral/spectrum.hpp"
#include "skinspec/spectral/table.hpp"

namespace skinspec {

struct NamedSpectrum {
  std::string name;
  Spectrum spectrum;
};

struct SpectraLimits {
  double min_value = 0.0;  // reflectance below this is refused (as a fraction: after `scale`)
  double max_value = 1.5;  // and above this
  double must_cover_from_nm = 400.0;
  double must_cover_to_nm = 700.0;
  // How the values are written (reflectance_scale.hpp); fraction takes them as they are.
  ScaleRequest scale = ScaleRequest::fraction;
};

// The spectra of a file, and how its values were read.
struct SpectraFile {
  std::vector<NamedSpectrum> spectra;
  ScaleDecision scale;
};

// Parses bytes (`source` names them in errors: a file name or "<stdin>").
// Refused: an empty input, a missing header or one whose first column is not wavelength_nm,
// duplicated or empty column names, fewer than 2 columns, rows with a different cell count,
// non-numeric, NaN or infinite cells, wavelengths that do not strictly increase, fewer than
// two rows, a grid that does not cover [must_cover_from_nm, must_cover_to_nm], values outside
// [min_value, max_value] once divided as `scale` says (a spectrum on another scale than the
// rest, for auto: reflectance_scale.hpp).
std::expected<SpectraFile, InputError> parse_spectra_file(std::string_view bytes, std::string_view source,
                                                          const SpectraLimits& limits = {});
// The same, for callers that need not know the scale.
std::expected<std::vector<NamedSpectrum>, InputError> parse_spectra_csv(std::string_view bytes, std::string_view source,
                                                                        const SpectraLimits& limits = {});

}  // namespace skinspec
