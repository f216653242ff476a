#pragma once
// How values are laid out in the database (docs/store.md, "Encoding"): spectra as BLOBs of
// little-endian IEEE-754 float64 (wavelength, value) pairs, times as integer microseconds
// since the Unix epoch, lists of text as JSON arrays, a job's error as a JSON object. Also the
// checks made before writing.

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "skinspec/store/types.hpp"

namespace skinspec::store::detail {

std::string encode_spectrum(const SpectralSamples& spectrum);
// `what` names the column in the error when the bytes cannot be a spectrum.
SpectralSamples decode_spectrum(std::string_view bytes, std::string_view what);

std::int64_t to_micros(Time time);
Time from_micros(std::int64_t micros);

std::string encode_text_list(const std::vector<std::string>& items);
std::vector<std::string> decode_text_list(std::string_view json, std::string_view what);

// A fit's parameters as the JSON array [{"name", "value", "standard_error"}], a standard error
// that is not finite as null (read back as infinity: the fit could not bound it).
std::string encode_fit_params(const std::vector<FitParam>& params);
std::vector<FitParam> decode_fit_params(std::string_view json, std::string_view what);

// A job's error as the JSON object {"code": "...", "message": "..."}.
std::string encode_job_error(const JobError& error);
JobError decode_job_error(std::string_view json, std::string_view what);

// Each throws Failure (invalid_argument) naming `what`.
void check_spectrum(const SpectralSamples& spectrum, std::string_view what, bool may_be_empty);
void check_json_object(std::string_view json, std::string_view what);
void check_not_empty(std::string_view text, std::string_view what);

}  // namespace skinspec::store::detail
