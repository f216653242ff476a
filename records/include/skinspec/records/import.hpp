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
// In CSV, values are reflectance as fractions or in percent (as Konica Minolta writes), as the
// scale asked for says, or auto (skinspec/spectral/reflectance_scale.hpp); as fractions each
// must lie from -0.05 (noise over black) to 1.5. A CGATS file gives its own scale
// (SPECTRAL_NORM). Fields may be quoted (RFC 4180); blank lines, and lines starting with '#'
// before the header, are skipped. A defect anywhere refuses the whole file, naming its line
// (and column).

#include <cstddef>
#include <expected>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "skinspec/spectral/reflectance_scale.hpp"
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
  store::SpectralSamples reflectance;     // as fractions
  std::optional<ReflectanceScale> scale;  // how a CSV file's values were read; none for CGATS
};

// Every spectrum of the file, or the first defect (InputError names `source`, the line and the
// column). A spectrum must have at least two wavelengths, strictly increasing. A scale other
// than auto is refused for CGATS.
std::expected<std::vector<ImportedSpectrum>, InputError> read_import(std::string_view bytes, std::string_view source,
                                                                     ImportFormat format,
                                                                     ScaleRequest scale = ScaleRequest::automatic);

}  // namespace skinspec::records
