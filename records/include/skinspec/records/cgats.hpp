#pragma once
// Reflectance spectra as CGATS text in the form ArgyllCMS writes and reads (.ti3, .sp,
// .cgats): keywords SPECTRAL_BANDS, SPECTRAL_START_NM, SPECTRAL_END_NM and SPECTRAL_NORM describe
// one even grid, and each set (row) holds one spectrum in the fields SPEC_nnn, one per band,
// beside any others (SAMPLE_ID, SAMPLE_NAME, XYZ_X ...). docs/store.md, "Export", gives the
// layout skinspec writes.

#include <cstddef>
#include <expected>
#include <iosfwd>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "skinspec/store/store.hpp"

namespace skinspec::records {

// One set of a spectral table.
struct CgatsSpectrum {
  std::string sample_id;  // SAMPLE_ID, else SAMPLE_NAME, else the set's number from 1
  std::string sample_name;
  std::string instrument;  // the table's TARGET_INSTRUMENT (ArgyllCMS) or INSTRUMENT, if any
  std::size_t line = 0;    // where the set begins in the text, from 1
  std::vector<double> wavelength_nm;
  std::vector<double> reflectance;                          // the SPEC_nnn values over SPECTRAL_NORM (1 where absent)
  std::vector<std::pair<std::string, std::string>> fields;  // every field of the set, as written
};

struct CgatsError {
  std::size_t line = 0;  // from 1; 0 for the text as a whole
  std::string message;
};

// Every spectral table of `text`, in order. Tables without SPECTRAL_BANDS are skipped; a
// spectral table with a missing band, a value that is not a number, a set with too few or too
// many values, or a count that disagrees with the sets is an error at its line.
std::expected<std::vector<CgatsSpectrum>, CgatsError> parse_cgats(std::string_view text);

// A session's reflectance spectra as CTI3 text: one table per wavelength grid, one set per
// measurement that has a reflectance (SAMPLE_ID its id, SAMPLE_NAME its label), values in
// percent with SPECTRAL_NORM 100. A grid that is not even or not on whole nanometres cannot be
// named by SPEC_nnn fields: an error naming the measurement.
std::expected<void, std::string> write_cgats(const store::SessionDetail& detail, std::ostream& out);

}  // namespace skinspec::records
