#pragma once
// Reflectance spectra of other programs' files, read for import (docs/store.md, "Imports"):
//  - csv, one column per spectrum: a header whose first cell names the wavelength column
//    (wavelength_nm, wavelength, nm, "Wavelength (nm)"), then one column per spectrum, its
//    name the sample id; one row per wavelength. skinspec's own spectra files, and what
//    spectrometer software (Ocean Insight, Avantes) exports.
//  - csv, one row per spectrum: a header of text columns (the first is the sample id) followed
//    by wavelength columns ("400", "400nm", "400 nm"); one row per spectrum. What Konica
//    Minolta's CM-700d/CM-2600d software exports.
//  - cgats: ArgyllCMS's .ti3/.sp/.cgats spectral tables (cgats.hpp).
// In CSV, values are reflectance from 0 to 1; a file with any value above 1.5 holds percent
// (as Konica Minolta writes), every value of it is divided by 100, and each of its spectra must
// exceed 1.5 somewhere. Fields may be quoted (RFC 4180); blank lines, and lines starting with
// '#' before the header, are skipped. A defect anywhere refuses the whole file, naming its line
// (and column).

#include <cstddef>
#include <expected>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "skinspec/spectral/table.hpp"
#include "skinspec/store/types.hpp"

namespace skinspec::records {

enum class ImportFormat { csv, cgats };
std::string_view to_string(ImportFormat format);
std::optional<ImportFormat> parse_import_format(std::string_view text);
// CGATS when the text's first word is a CGATS file type and it has BEGIN_DATA, CSV otherwise.
ImportFormat recognise_import_format(std::string_view bytes);

struct ImportedSpectrum {
  std::string sample_id;
  std::size_t line = 0;  // where its values begin in the file, from 1
  std::string instrument;
  store::SpectralSamples reflectance;
};

// Every spectrum of the file, or the first defect (InputError names `source`, the line and the
// column). A spectrum must have at least two wavelengths, strictly increasing.
std::expected<std::vector<ImportedSpectrum>, InputError> read_import(std::string_view bytes, std::string_view source,
                                                                     ImportFormat format);

}  // namespace skinspec::records
