// libFuzzer target: arbitrary bytes into the spectra CSV parser (with the fit's limits and with
// wide ones) and the data-table parser. Besides not crashing, whatever a parser accepts must be
// what its format promises: spectra on one strictly increasing grid that covers the limits, with
// finite values inside them, under unique non-empty UTF-8 names; a table's cells finite, its keys
// unique, its wavelengths increasing. Whatever it refuses, it refuses with a message that can go
// to a terminal as it is. Build and run with scripts/fuzz.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <set>
#include <string>
#include <string_view>

#include "skinspec/spectral/spectra_csv.hpp"
#include "skinspec/spectral/table.hpp"
#include "skinspec/spectral/utf8.hpp"

namespace {

using namespace skinspec;

// Stops the run so that libFuzzer keeps the input that broke an invariant.
void require(bool condition, const char* invariant) {
  if (!condition) {
    std::fprintf(stderr, "spectra/table invariant broken: %s\n", invariant);
    std::abort();
  }
}

bool printable_text(std::string_view text) {
  if (!utf8::is_valid(text)) return false;
  for (const char c : text)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) return false;
  return true;
}

std::size_t line_count(std::string_view bytes) {
  std::size_t ends = 0;
  for (const char c : bytes) ends += c == '\r' || c == '\n';
  return ends + 1;
}

// A refusal names a line of the input (or none), and its whole text is printable.
void check_error(const InputError& error, std::string_view bytes) {
  require(!error.message.empty(), "an error has a message");
  require(error.line <= line_count(bytes), "an error names a line of the input");
  require(printable_text(error.what()), "an error's text is printable UTF-8");
}

void check_spectra(std::string_view bytes, const SpectraLimits& limits) {
  const auto parsed = parse_spectra_csv(bytes, "fuzz.csv", limits);
  if (!parsed) {
    check_error(parsed.error(), bytes);
    return;
  }
  require(!parsed->empty(), "at least one spectrum");
  std::set<std::string> names;
  const auto grid = parsed->front().spectrum.wavelengths();
  for (const auto& [name, spectrum] : *parsed) {
    require(!name.empty() && utf8::is_valid(name), "a name is non-empty UTF-8");
    require(name != "wavelength_nm" && names.insert(name).second, "names are unique");
    require(name.find_first_of(" \t") != 0 && name.find_last_of(" \t") != name.size() - 1, "names are trimmed");
    require(spectrum.size() >= 2, "at least two samples");
    require(std::ranges::equal(spectrum.wavelengths(), grid), "one grid for every spectrum");
    for (std::size_t i = 0; i < spectrum.size(); ++i) {
      require(std::isfinite(spectrum.wavelengths()[i]), "finite wavelengths");
      require(i == 0 || spectrum.wavelengths()[i] > spectrum.wavelengths()[i - 1], "wavelengths strictly increase");
      const double value = spectrum.values()[i];
      require(std::isfinite(value) && value >= limits.min_value && value <= limits.max_value,
              "values finite and within the limits");
    }
    require(spectrum.covers(limits.must_cover_from_nm, limits.must_cover_to_nm), "the grid covers the limits");
  }
}

void check_table(std::string_view bytes) {
  const auto parsed = parse_table(bytes, "fuzz.csv", {});
  if (!parsed) {
    check_error(parsed.error(), bytes);
    return;
  }
  for (const auto key : {"title", "source", "licence", "units"}) require(!parsed->meta(key).empty(), "cited");
  require(parsed->rows() > 0 && !parsed->columns().empty(), "a header and rows");
  const bool spectral = parsed->columns().front() == "wavelength_nm";
  std::set<std::string> columns(parsed->columns().begin(), parsed->columns().end());
  require(columns.size() == parsed->columns().size(), "unique columns");
  for (const auto& column : parsed->columns()) require(utf8::is_valid(column), "UTF-8 column names");
  for (std::size_t c = spectral ? 0 : 1; c < parsed->columns().size(); ++c) {
    const auto values = parsed->column(parsed->columns()[c]);
    require(values.size() == parsed->rows(), "a value per row");
    for (std::size_t i = 0; i < values.size(); ++i) {
      require(std::isfinite(values[i]), "finite cells");
      require(!spectral || c != 0 || i == 0 || values[i] > values[i - 1], "wavelengths strictly increase");
    }
  }
  if (!spectral) {
    std::set<std::string> keys(parsed->keys().begin(), parsed->keys().end());
    require(keys.size() == parsed->rows(), "a unique key per row");
    for (const auto& key : parsed->keys()) require(!key.empty() && utf8::is_valid(key), "keys are UTF-8");
  }
}

void check_printable(std::string_view bytes) {
  const auto once = printable(bytes);
  require(printable_text(once), "printable() gives printable UTF-8");
  require(printable(once) == once, "printable() changes nothing the second time");
  require(utf8::is_valid(bytes) == !utf8::first_defect(bytes), "is_valid agrees with first_defect");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  check_spectra(bytes, {});
  check_spectra(bytes,
                {.min_value = -1e300, .max_value = 1e300, .must_cover_from_nm = 1e300, .must_cover_to_nm = -1e300});
  check_table(bytes);
  check_printable(bytes);
  return 0;
}
