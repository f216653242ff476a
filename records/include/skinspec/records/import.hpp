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
#include <cstdint>
#include <expected>
#include <functional>
#include <memory>
#include <optional>
#include <span>
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

// A file's bytes as an import reads them, a piece at a time: `read(offset, into)` fills `into`
// from byte `offset` on and says how many bytes it gave (fewer than asked only at the end), or
// why it cannot read.
using ReadBytes = std::function<std::expected<std::size_t, std::string>(std::uint64_t offset, std::span<char> into)>;
// Bytes held in memory, which must outlive the reading.
ReadBytes bytes_in_memory(std::string_view bytes);
// A file read as it is needed, never held whole; or why it cannot be opened.
std::expected<ReadBytes, std::string> bytes_of_file(const std::string& path);

// A file's spectra, checked first as read_import checks them, then handed over one at a time in
// the file's order. A CSV file of one row per spectrum (the layout of large archives) is read a
// piece at a time twice, to check it and then to hand its spectra over, and never held whole;
// one of one column per spectrum, or a CGATS file, is read whole by read_import.
class SpectrumStream {
 public:
  virtual ~SpectrumStream() = default;
  virtual std::size_t size() const = 0;                       // how many spectra the file holds
  virtual std::optional<ReflectanceScale> scale() const = 0;  // how the values are read (none: CGATS)
  // The next spectrum, or nullopt after the last; or the defect that a file changed since it was
  // checked has, or why it can no longer be read.
  virtual std::expected<std::optional<ImportedSpectrum>, InputError> next() = 0;
};

// The file's spectra as a stream, or its first defect (as read_import says it, though a file
// with several defects may be refused for another one).
std::expected<std::unique_ptr<SpectrumStream>, InputError> stream_import(const ReadBytes& bytes,
                                                                         std::string_view source, ImportFormat format,
                                                                         ScaleRequest scale = ScaleRequest::automatic);

}  // namespace skinspec::records
