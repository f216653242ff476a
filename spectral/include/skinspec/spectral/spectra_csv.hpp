#pragma once
// The spectra file format read by `skinspec fit` and `skinspec colour`: CSV with a header whose
// first column is `wavelength_nm`, then one column per spectrum (its name), one row per
// wavelength. Blank lines and lines starting with '#' (comments) are ignored. Every defect is reported with line and
// column.

#include <expected>
#include <string>
#include <string_view>
#include <vector>

#include "skinspec/spectral/spectrum.hpp"
#include "skinspec/spectral/table.hpp"

namespace skinspec {

struct NamedSpectrum {
  std::string name;
  Spectrum spectrum;
};

struct SpectraLimits {
  double min_value = 0.0;  // reflectance below this is refused
  double max_value = 1.5;  // and above this
  double must_cover_from_nm = 400.0;
  double must_cover_to_nm = 700.0;
};

// Parses bytes (`source` names them in errors: a file name or "<stdin>").
// Refused: an empty input, a missing header or one whose first column is not wavelength_nm,
// duplicated or empty column names, fewer than 2 columns, rows with a different cell count,
// non-numeric, NaN or infinite cells, wavelengths that do not strictly increase, fewer than
// two rows, a grid that does not cover [must_cover_from_nm, must_cover_to_nm], values outside
// [min_value, max_value].
std::expected<std::vector<NamedSpectrum>, InputError> parse_spectra_csv(std::string_view bytes, std::string_view source,
                                                                        const SpectraLimits& limits = {});

}  // namespace skinspec
