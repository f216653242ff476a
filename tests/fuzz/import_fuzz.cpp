// libFuzzer target: arbitrary bytes into the importers of other programs' spectra files
// (records/import.hpp: CSV by columns or by rows, CGATS) and the CGATS reader beneath. Besides
// not crashing, whatever is accepted must be what the formats promise: at least one spectrum,
// each with a sample id and at least two wavelengths, strictly increasing, and reflectances
// from -0.05 to 1.5; sample ids and instruments UTF-8 without NUL, as the store keeps text. A
// refusal names a line of the input. Build and run with scripts/fuzz.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string_view>

#include "skinspec/records/cgats.hpp"
#include "skinspec/records/import.hpp"
#include "skinspec/spectral/utf8.hpp"

namespace {

using namespace skinspec;

void require(bool condition, const char* invariant) {
  if (!condition) {
    std::fprintf(stderr, "import invariant broken: %s\n", invariant);
    std::abort();
  }
}

std::size_t line_count(std::string_view bytes) {
  std::size_t ends = 0;
  for (const char c : bytes) ends += c == '\n';
  return ends + 1;
}

bool storable_text(std::string_view text) { return utf8::is_valid(text) && text.find('\0') == std::string_view::npos; }

void check_import(std::string_view bytes, records::ImportFormat format) {
  const auto read = records::read_import(bytes, "fuzz", format);
  if (!read) {
    require(!read.error().message.empty(), "an error has a message");
    require(read.error().line <= line_count(bytes), "an error names a line of the input");
    return;
  }
  require(!read->empty(), "at least one spectrum");
  for (const auto& s : *read) {
    require(!s.sample_id.empty() || format == records::ImportFormat::cgats, "a CSV spectrum has a sample id");
    require(storable_text(s.sample_id) && storable_text(s.instrument), "text the store keeps");
    require(s.line >= 1 && s.line <= line_count(bytes), "a spectrum's line is in the input");
    const auto& r = s.reflectance;
    require(r.wavelength_nm.size() >= 2 && r.values.size() == r.wavelength_nm.size(), "two or more samples");
    for (std::size_t i = 0; i < r.values.size(); ++i) {
      require(std::isfinite(r.wavelength_nm[i]), "finite wavelengths");
      require(i == 0 || r.wavelength_nm[i] > r.wavelength_nm[i - 1], "wavelengths strictly increase");
      require(r.values[i] >= -0.05 && r.values[i] <= 1.5, "reflectances");
    }
  }
}

void check_cgats(std::string_view bytes) {
  const auto read = records::parse_cgats(bytes);
  if (!read) {
    require(read.error().line <= line_count(bytes), "a CGATS error names a line of the input");
    return;
  }
  for (const auto& s : *read) {
    require(s.wavelength_nm.size() == s.reflectance.size(), "a value per band");
    for (const double v : s.reflectance) require(std::isfinite(v), "finite values");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  check_import(bytes, records::ImportFormat::csv);
  check_import(bytes, records::ImportFormat::cgats);
  check_import(bytes, records::recognise_import_format(bytes));
  check_cgats(bytes);
  return 0;
}
