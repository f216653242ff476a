#pragma once
// One cube mapped whole: read in blocks of lines (the next block read while one is fitted),
// each block judged, fitted and written, then the answer cube closed, its pictures drawn, the
// summary written and everything moved into place (MapWriter). What `skinspec map` and the
// service's map jobs both run.

#include <expected>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "skinspec/maps/map_writer.hpp"

namespace skinspec::maps {

struct MapRunOptions {
  MapOptions map;  // the model and site are map.fit's
  std::size_t block_lines = 32;
  MapFormat format = MapFormat::envi;
  bool pictures = true;
  std::string cube_label;  // how summary.json and the header name the cube; its file when empty
  // When set, every pixel's reflectance as fitted is written there too (float32 in native byte
  // order, pixel by pixel, as Cube::read_lines orders values): what the service keeps with a
  // map to show a pixel's measured spectrum beside its fit.
  std::filesystem::path reflectance_file;
};

struct MapProgress {
  std::size_t lines_done = 0, lines = 0;
  double seconds = 0;
  // Seconds left at the pace so far; none before the first block.
  std::optional<double> remaining_s() const;
};

// Told after every block of lines; returning false stops the map, which leaves nothing under a
// final name.
using MapObserver = std::function<bool(const MapProgress&)>;

struct MapRunError {
  enum class Kind {
    bad_cube,  // the cube's fault: its file and header field are in the message
    failed,    // writing the answers failed
  };
  Kind kind = Kind::failed;
  std::string message;
};

// Where a map's time went, in seconds of the clock on the wall.
struct MapTimings {
  double total = 0;    // from the first read to the files in their places
  double fitting = 0;  // until the last block was fitted (its reads and writes overlap the fitting)
  double closing = 0;  // the answer cube closed, summed up and drawn, the files moved into place
};

struct MapRun {
  bool stopped = false;                      // the observer stopped it: nothing was written
  std::vector<std::filesystem::path> files;  // in their final places
  std::string summary_json;
  MapTally tally;
  MapTimings timings;
};

// Maps `cube` into `dir` as NAME.map.*, NAME.summary.json and NAME.PARAMETER.png.
std::expected<MapRun, MapRunError> run_map(const Fitter& fitter, const Cube& cube, const std::string& name,
                                           const std::filesystem::path& dir, const MapRunOptions& options,
                                           const MapObserver& observer = {});

}  // namespace skinspec::maps
