#pragma once
// Writing a map: the answer cube as ENVI float32 (band-interleaved by line, band names and
// units in the header) and summary.json, into a directory. Everything is written under a
// hidden directory beside the final files and moved into place only when complete, so an
// interrupted map leaves nothing under a final name (docs/maps.md, "Output").

#include <expected>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "skinspec/maps/cube.hpp"
#include "skinspec/maps/mapper.hpp"

namespace skinspec::maps {

class MapWriter {
 public:
  // DIR is created if missing; `name` is the cube's stem (NAME.map.hdr and NAME.map.img, NAME.summary.json).
  static std::expected<MapWriter, std::string> create(const std::filesystem::path& dir, const std::string& name,
                                                      const CubeInfo& cube, std::vector<MapBand> bands);
  ~MapWriter();  // removes what was not finished
  MapWriter(MapWriter&&) noexcept;
  MapWriter& operator=(MapWriter&&) noexcept;

  // Answers for `count` lines from `first`, as Mapper::map_lines gives them.
  std::expected<void, std::string> write_lines(std::size_t first, std::size_t count, std::span<const float> answers);
  // Closes the cube, writes the summary and moves the files to their final names.
  std::expected<std::vector<std::filesystem::path>, std::string> finish(const std::string& summary_json);

 private:
  struct State;
  explicit MapWriter(std::unique_ptr<State> state);
  std::unique_ptr<State> state_;
};

}  // namespace skinspec::maps
