#pragma once
// Writing a map: the answer cube as ENVI float32 (band-interleaved by line, band names and
// units in the header) and summary.json, into a directory. Everything is written under a
// hidden directory beside the final files and moved into place only when complete, so an
// interrupted map leaves nothing under a final name (docs/maps.md, "Output").

#include <array>
#include <expected>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "skinspec/maps/cube.hpp"
#include "skinspec/maps/mapper.hpp"

namespace skinspec::maps {

// The percentiles the summary gives of each parameter.
inline constexpr std::array<int, 5> kSummaryPercentiles = {5, 25, 50, 75, 95};

struct ParameterSummary {
  MapBand band;
  std::size_t determined_pixels = 0;
  std::array<double, kSummaryPercentiles.size()> percentiles{};  // NaN where none was determined
  // The values the picture's colour map spans: the 2nd and 98th percentiles (NaN as above).
  std::array<double, 2> picture_range{};
};

// The answer cube's format: ENVI (NAME.map.img and NAME.map.hdr) or a float TIFF (NAME.map.tif),
// float32 either way, with the band names and units.
enum class MapFormat { envi, tiff };

class MapWriter {
 public:
  // DIR is created if missing; `name` is the cube's stem (NAME.map.*, NAME.summary.json,
  // NAME.PARAMETER.png).
  static std::expected<MapWriter, std::string> create(const std::filesystem::path& dir, const std::string& name,
                                                      const CubeInfo& cube, std::vector<MapBand> bands,
                                                      MapFormat format = MapFormat::envi);
  ~MapWriter();  // removes what was not finished
  MapWriter(MapWriter&&) noexcept;
  MapWriter& operator=(MapWriter&&) noexcept;

  // Answers for `count` lines from `first`, as Mapper::map_lines gives them.
  std::expected<void, std::string> write_lines(std::size_t first, std::size_t count, std::span<const float> answers);
  // Closes the answer cube and reads it back one band at a time, so that memory stays bounded:
  // each parameter's percentiles over the pixels where it was determined and, with `pictures`,
  // its picture, NAME.PARAMETER.png, over the 2nd to 98th percentile.
  std::expected<std::vector<ParameterSummary>, std::string> close(ModelKind model, bool pictures);
  // Writes the summary (NAME.summary.json) and moves every file to its final name.
  std::expected<std::vector<std::filesystem::path>, std::string> finish(const std::string& summary_json);

 private:
  struct State;
  explicit MapWriter(std::unique_ptr<State> state);
  std::unique_ptr<State> state_;
};

}  // namespace skinspec::maps
