// libFuzzer target: an ENVI header and its data file, from one input (the header up to the first
// NUL byte, the data after it), opened and read by maps::Cube through GDAL in memory
// (/vsimem/). Besides not crashing, a cube that opens must be one a map can use: as many
// increasing, finite wavelengths as bands, a positive scale, and every line readable as its
// size says. Build and run with scripts/fuzz.

#include <cpl_vsi.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string_view>

#include "skinspec/maps/cube.hpp"
#include "skinspec/maps/mapper.hpp"

namespace {

void require(bool condition, const char* invariant) {
  if (!condition) {
    std::fprintf(stderr, "cube invariant broken: %s\n", invariant);
    std::abort();
  }
}

void put(const char* path, std::string_view bytes) {
  VSILFILE* file = VSIFOpenL(path, "wb");
  VSIFWriteL(bytes.data(), 1, bytes.size(), file);
  VSIFCloseL(file);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  const auto split = input.find('\0');
  put("/vsimem/fuzz.hdr", input.substr(0, split));
  put("/vsimem/fuzz.img", split == std::string_view::npos ? std::string_view{} : input.substr(split + 1));
  const auto cube = skinspec::maps::Cube::open("/vsimem/fuzz.img");
  if (cube) {
    const auto& info = cube->info();
    require(info.wavelength_nm.size() == info.bands, "a wavelength a band");
    require(std::ranges::all_of(info.wavelength_nm, [](double w) { return std::isfinite(w); }), "finite wavelengths");
    require(std::ranges::adjacent_find(info.wavelength_nm, std::ranges::greater_equal{}) == info.wavelength_nm.end(),
            "increasing wavelengths");
    require(info.reflectance_scale > 0, "a positive scale");
    if (info.lines > 0) {
      const auto lines = cube->read_lines(0, std::min<std::size_t>(info.lines, 4));
      require(!lines || lines->size() == std::min<std::size_t>(info.lines, 4) * info.samples * info.bands,
              "a line's size");
    }
    (void)skinspec::maps::check_coverage(info);
  }
  VSIUnlink("/vsimem/fuzz.hdr");
  VSIUnlink("/vsimem/fuzz.img");
  return 0;
}
