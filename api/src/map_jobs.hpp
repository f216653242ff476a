#pragma once
// Skin maps as jobs (POST /api/v1/maps; docs/maps.md, "In the service"). The cube, uploaded or
// named by a path inside the data directory, is opened and checked before its job is queued,
// so that a bad cube is refused with a 4xx naming its file and header field. Each job works in
// a scratch directory of its own, removed when the job is done with; those of a program that
// was killed are removed by the next one to start.

#include <expected>
#include <filesystem>
#include <optional>
#include <string>

#include "skinspec/api/errors.hpp"
#include "skinspec/api/router.hpp"
#include "skinspec/fit/fitter.hpp"
#include "skinspec/maps/mapper.hpp"
#include "skinspec/store/types.hpp"

namespace skinspec::api {

// A map as asked for, before any check.
struct MapAsk {
  std::optional<store::Id> session_id;
  std::string name;  // the map's name; the cube's file stem when empty ("upload" for an upload)
  ModelKind model = kDefaultModel;
  std::string site = "forearm";
  // A radiance cube: the white panel, as a region of it or a cube of its own inside the data
  // directory, the panel's calibrated reflectance, and a dark cube there.
  std::optional<maps::Region> white_roi;
  std::string white, dark;
  double white_reflectance = 0.99;
  std::string path;    // a cube inside MapFiles::data_dir; empty for an upload
  std::string upload;  // the uploaded file: a TIFF, HDF5 or netCDF file, or a tar of an ENVI cube
};

// A directory of its own, removed with everything in it when its owner is destroyed.
class ScratchDir {
 public:
  ScratchDir() = default;
  explicit ScratchDir(std::filesystem::path path) : path_(std::move(path)) {}
  ScratchDir(ScratchDir&& other) noexcept : path_(std::exchange(other.path_, {})) {}
  ScratchDir& operator=(ScratchDir&& other) noexcept;
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  ~ScratchDir();
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

// A map checked and ready to run.
struct MapRequest {
  std::optional<store::Id> session_id;
  std::string name;
  std::string source;  // the path asked for, or "upload"
  ModelKind model = kDefaultModel;
  std::string site;
  std::string cube;  // the file to open
  std::optional<maps::Radiometry> radiance;
  std::size_t upload_bytes = 0;
  std::size_t pixels = 0;
  ScratchDir scratch;
};

// Checks what was asked and opens the cube: a path outside the data directory, or whose files
// lie outside it once symbolic links are followed, is forbidden (403); a cube that cannot be
// read, or does not cover 420-680 nm, is unprocessable (422), its file and field named.
std::expected<MapRequest, ApiError> prepare_map(MapAsk ask, const MapFiles& files, const Fitter& fitter);

// Removes the scratch directories of map jobs whose program is gone.
void remove_abandoned_map_work(const MapFiles& files);

// The bands of a map of `model`, for its views.
nlohmann::json map_bands_json(ModelKind model);

}  // namespace skinspec::api
