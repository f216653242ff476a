#include "map_jobs.hpp"

#include <fmt/format.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <charconv>
#include <fstream>
#include <nlohmann/json.hpp>

#include "fit_jobs.hpp"
#include "job_updates.hpp"
#include "skinspec/maps/map_run.hpp"

namespace skinspec::api {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr std::string_view kScratchPrefix = "skinspecd-map-";

ApiError unprocessable(std::string code, std::string message) {
  return {ErrorKind::unprocessable, std::move(code), std::move(message)};
}
ApiError forbidden(std::string message) { return {ErrorKind::forbidden, "outside_data_dir", std::move(message)}; }

fs::path work_dir_of(const MapFiles& files) {
  return files.work_dir.empty() ? fs::temp_directory_path() : files.work_dir;
}

std::expected<ScratchDir, ApiError> new_scratch(const MapFiles& files) {
  static std::atomic<unsigned> made{0};
  std::error_code error;
  const fs::path work = work_dir_of(files);
  fs::create_directories(work, error);
  const fs::path path = work / fmt::format("{}{}-{}", kScratchPrefix, ::getpid(), ++made);
  if (!fs::create_directory(path, error) || error)
    return std::unexpected(
        ApiError{ErrorKind::internal, "",
                 fmt::format("{} cannot be made: {}", path.string(), error ? error.message() : "it exists")});
  return ScratchDir(path);
}

// Whether `path`, every link followed, lies inside the directory `root` (itself canonical).
bool inside(const fs::path& path, const fs::path& root) {
  std::error_code error;
  const fs::path real = fs::canonical(path, error);
  if (error) return false;
  const fs::path relative = real.lexically_relative(root);
  return !relative.empty() && *relative.begin() != "..";
}

// The cube a path names inside the data directory.
std::expected<fs::path, ApiError> confined(const std::string& given, const MapFiles& files) {
  if (files.data_dir.empty())
    return std::unexpected(forbidden("this skinspecd names no data directory (--data-dir): upload the cube instead"));
  const fs::path relative(given);
  if (given.empty() || relative.is_absolute() ||
      std::ranges::any_of(relative, [](const fs::path& part) { return part == ".."; }))
    return std::unexpected(forbidden(fmt::format("'{}' is not a relative path inside the data directory", given)));
  std::error_code error;
  const fs::path root = fs::canonical(files.data_dir, error);
  if (error) return std::unexpected(ApiError{ErrorKind::unavailable, "", "the data directory cannot be read"});
  const fs::path full = root / relative;
  if (!fs::exists(full, error))
    return std::unexpected(
        unprocessable("no_such_cube", fmt::format("'{}': no such file in the data directory", given)));
  if (!inside(full, root))
    return std::unexpected(forbidden(fmt::format("'{}' leads outside the data directory", given)));
  return full;
}

// Refused when a file the cube named `path` is read from lies outside the data directory (a
// header inside whose data file is a link to one outside).
std::optional<ApiError> files_outside(const maps::CubeInfo& info, const MapFiles& files, const std::string& path) {
  const fs::path root = fs::canonical(files.data_dir);
  for (const auto& file : info.files)
    if (!inside(file, root))
      return forbidden(
          fmt::format("'{}' is read from {}, outside the data directory", path, fs::path(file).filename().string()));
  return std::nullopt;
}

// The uploaded file unpacked into the scratch directory: the cube's file.
std::expected<std::string, ApiError> unpack(const MapAsk& ask, const std::string& name, const ScratchDir& scratch) {
  const fs::path file = scratch.path() / ("upload" + fs::path(name).extension().string());
  {
    std::ofstream out(file, std::ios::binary);
    out.write(ask.upload.data(), static_cast<std::streamsize>(ask.upload.size()));
    if (!out.flush()) return std::unexpected(ApiError{ErrorKind::internal, "", "the upload cannot be kept on disk"});
  }
  const fs::path unpacked = scratch.path() / "cube";
  fs::create_directory(unpacked);
  auto cube = maps::cube_of_upload(file.string(), unpacked.string(), name);
  if (!cube) return std::unexpected(unprocessable("bad_cube", cube.error().what()));
  return *cube;
}

// A cube's error as the one who sent it knows the file: by its name, not the scratch path.
ApiError bad_cube(const maps::CubeError& error, const std::string& shown) {
  return unprocessable("bad_cube", maps::CubeError{shown, error.field, error.message}.what());
}

std::expected<void, ApiError> checked_name(const std::string& name) {
  const bool ok = !name.empty() && name.size() <= 100 && name.front() != '.' &&
                  std::ranges::all_of(
                      name, [](unsigned char ch) { return std::isalnum(ch) || ch == '_' || ch == '-' || ch == '.'; });
  if (!ok)
    return std::unexpected(unprocessable(
        "invalid_value", "'name' must be 1 to 100 letters, digits, '_', '-' or '.', not starting with '.'"));
  return {};
}

// A white or dark panel's cube named in the data directory: its mean spectrum.
std::expected<std::vector<double>, ApiError> panel_of(const std::string& path, const MapFiles& files,
                                                      const maps::CubeInfo& mapped) {
  auto found = confined(path, files);
  if (!found) return std::unexpected(found.error());
  auto panel = maps::Cube::open(found->string());
  if (!panel) return std::unexpected(bad_cube(panel.error(), path));
  if (auto outside = files_outside(panel->info(), files, path)) return std::unexpected(*outside);
  auto mean = maps::panel_spectrum(*panel, mapped);
  if (!mean) return std::unexpected(bad_cube(mean.error(), path));
  return std::move(*mean);
}

std::expected<std::optional<maps::Radiometry>, ApiError> radiometry_of(const maps::Cube& cube, const MapAsk& ask,
                                                                       const MapFiles& files,
                                                                       const std::string& shown) {
  if (!ask.white_roi && ask.white.empty()) {
    if (!ask.dark.empty())
      return std::unexpected(
          unprocessable("invalid_value", "'dark' is for radiance cubes: give 'white' or 'white_roi'"));
    return std::nullopt;
  }
  if (ask.white_roi && !ask.white.empty())
    return std::unexpected(unprocessable("invalid_value", "give 'white' or 'white_roi', not both"));
  if (!(ask.white_reflectance > 0 && ask.white_reflectance <= 1))
    return std::unexpected(unprocessable("out_of_range", "'white_reflectance' must be in (0, 1]"));
  const auto& info = cube.info();
  std::vector<double> white, dark;
  if (ask.white_roi) {
    auto mean = maps::mean_spectrum(cube, *ask.white_roi);
    if (!mean) return std::unexpected(bad_cube(mean.error(), shown));
    white = std::move(*mean);
  } else if (auto mean = panel_of(ask.white, files, info)) {
    white = std::move(*mean);
  } else {
    return std::unexpected(mean.error());
  }
  if (!ask.dark.empty()) {
    auto mean = panel_of(ask.dark, files, info);
    if (!mean) return std::unexpected(mean.error());
    dark = std::move(*mean);
  }
  auto r = maps::radiometry(info, white, std::vector<double>(info.bands, ask.white_reflectance), dark);
  if (!r) return std::unexpected(bad_cube(r.error(), shown));
  return std::optional(std::move(*r));
}

}  // namespace

ScratchDir& ScratchDir::operator=(ScratchDir&& other) noexcept {
  if (this != &other) {
    ScratchDir gone(std::move(*this));
    path_ = std::exchange(other.path_, {});
  }
  return *this;
}

ScratchDir::~ScratchDir() {
  std::error_code ignored;
  if (!path_.empty()) fs::remove_all(path_, ignored);
}

std::expected<MapRequest, ApiError> prepare_map(MapAsk ask, const MapFiles& files, const Fitter& fitter) {
  MapRequest request;
  request.session_id = ask.session_id;
  request.model = ask.model;
  request.site = ask.site;
  if (auto known = fitter.optics(ask.model).site(ask.site); !known)
    return std::unexpected(unprocessable("unknown_site", known.error()));
  const bool uploaded = ask.path.empty();
  request.source = uploaded ? "upload" : ask.path;
  request.name = !ask.name.empty() ? ask.name : uploaded ? "upload" : fs::path(ask.path).stem().string();
  if (auto ok = checked_name(request.name); !ok) return std::unexpected(ok.error());
  auto scratch = new_scratch(files);
  if (!scratch) return std::unexpected(scratch.error());
  request.scratch = std::move(*scratch);
  std::string shown = ask.path;
  if (uploaded) {
    shown = ask.name.empty() ? "upload" : ask.name;
    auto cube = unpack(ask, shown, request.scratch);
    if (!cube) return std::unexpected(cube.error());
    request.cube = *cube;
    request.upload_bytes = ask.upload.size();
  } else {
    auto cube = confined(ask.path, files);
    if (!cube) return std::unexpected(cube.error());
    request.cube = cube->string();
  }
  auto cube = maps::Cube::open(request.cube);
  if (!cube) return std::unexpected(bad_cube(cube.error(), shown));
  if (!uploaded)
    if (auto outside = files_outside(cube->info(), files, ask.path)) return std::unexpected(*outside);
  if (auto covered = maps::check_coverage(cube->info()); !covered)
    return std::unexpected(bad_cube(covered.error(), shown));
  auto radiance = radiometry_of(*cube, ask, files, shown);
  if (!radiance) return std::unexpected(radiance.error());
  request.radiance = std::move(*radiance);
  request.pixels = cube->info().lines * cube->info().samples;
  return request;
}

void remove_abandoned_map_work(const MapFiles& files) {
  std::error_code error;
  for (const auto& entry : fs::directory_iterator(work_dir_of(files), error)) {
    const std::string name = entry.path().filename().string();
    if (!name.starts_with(kScratchPrefix) || !entry.is_directory(error)) continue;
    const std::string_view rest = std::string_view(name).substr(kScratchPrefix.size());
    pid_t pid = 0;
    const auto [end, parsed] = std::from_chars(rest.data(), rest.data() + rest.size(), pid);
    if (parsed != std::errc() || end == rest.data() || *end != '-' || pid <= 0) continue;
    if (::kill(pid, 0) == 0 || errno != ESRCH) continue;  // alive, or not ours to judge
    fs::remove_all(entry.path(), error);
  }
}

json map_bands_json(ModelKind model) {
  json out = json::array();
  for (const auto& band : maps::map_bands(model)) out.push_back({{"name", band.name}, {"unit", band.unit}});
  return out;
}

// ---- the jobs (FitJobs' map lane) ----

namespace {

// The answer cube's data read back from its file, piece by piece, for the store.
store::MapData data_of(const fs::path& file) {
  auto in = std::make_shared<std::ifstream>(file, std::ios::binary);
  std::error_code error;
  const auto size = static_cast<std::int64_t>(fs::file_size(file, error));
  return {error ? -1 : size, [in, file](std::int64_t offset, std::span<char> into) {
            in->clear();
            in->seekg(offset);
            in->read(into.data(), static_cast<std::streamsize>(into.size()));
            if (in->gcount() != static_cast<std::streamsize>(into.size()))
              throw std::runtime_error(fmt::format("{} cannot be read back", file.string()));
          }};
}

std::string text_of(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

}  // namespace

std::expected<store::CreatedJob, ApiError> FitJobs::submit_map(MapRequest request, const std::string& idempotency_key) {
  if (request.session_id) {
    if (auto session = store_.session(*request.session_id); !session)
      return std::unexpected(from_store_error(session.error()));
  }
  store::Job job;
  job.session_id = request.session_id;
  job.idempotency_key = idempotency_key;
  job.request = json{{"source", request.source},
                     {"name", request.name},
                     {"model", std::string(to_string(request.model))},
                     {"site", request.site},
                     {"radiance", request.radiance.has_value()},
                     {"bytes", request.upload_bytes},
                     {"pixels", request.pixels}}
                    .dump();
  return enqueue(JobKind::map, std::move(job), std::move(request));
}

void FitJobs::run_map(store::Id id, MapRequest& request) {
  using detail::failed;
  using detail::stopped_update;
  if (const auto why = board_.report(id, {0, JobPhase::reading})) return end_map(id, request, stopped_update(*why));
  auto cube = maps::Cube::open(request.cube);
  if (!cube) return end_map(id, request, failed(store::JobErrorCode::bad_file, cube.error().what()));
  maps::MapRunOptions options;
  options.map.fit.model = request.model;
  options.map.fit.site = request.site;
  options.map.radiance = request.radiance;
  options.cube_label = request.upload_bytes > 0 ? request.name : request.source;  // as the client knows it
  options.reflectance_file = request.scratch.path() / "reflectance.f32";
  const auto samples = static_cast<std::int64_t>(cube->info().samples);
  std::optional<store::JobErrorCode> why;  // the job was asked to stop
  const auto observer = [&](const maps::MapProgress& at) {
    JobProgress p{0, JobPhase::fitting};
    p.spectra_done = static_cast<std::int64_t>(at.lines_done) * samples;
    p.spectra_total = static_cast<std::int64_t>(request.pixels);
    p.remaining_s = at.remaining_s();
    why = board_.report(id, p);
    return !why;
  };
  const fs::path out = request.scratch.path() / "map";
  const auto run = maps::run_map(fitter_, *cube, request.name, out, options, observer);
  if (!run) {
    const bool bad = run.error().kind == maps::MapRunError::Kind::bad_cube;
    return end_map(id, request,
                   failed(bad ? store::JobErrorCode::bad_file : store::JobErrorCode::internal, run.error().message));
  }
  if (run->stopped) return end_map(id, request, stopped_update(why.value_or(store::JobErrorCode::stopped)));
  JobProgress storing{0, JobPhase::storing};
  storing.spectra_done = storing.spectra_total = static_cast<std::int64_t>(request.pixels);
  if (const auto stop = board_.report(id, storing)) return end_map(id, request, stopped_update(*stop));

  store::Map map;
  map.session_id = request.session_id;
  map.name = request.name;
  map.summary = run->summary_json;
  map.header = text_of(out / (request.name + ".map.hdr"));
  std::vector<store::MapPicture> pictures;
  for (const auto& band : maps::map_bands(request.model)) {
    const fs::path png = out / fmt::format("{}.{}.png", request.name, band.name);
    if (fs::exists(png)) pictures.push_back({band.name, text_of(png)});
  }
  const json result = {{"pixels_mapped", request.pixels}, {"total", request.pixels}};
  const auto stored = store_.complete_map_job(id, map, data_of(out / (request.name + ".map.img")),
                                              data_of(options.reflectance_file), pictures, result.dump());
  if (!stored)
    return end_map(id, request, failed(store::job_error_code_of(stored.error().kind), stored.error().message));
  request.scratch = ScratchDir();
  release(id);
}

void FitJobs::end_map(store::Id id, MapRequest& request, const store::JobUpdate& update) {
  request.scratch = ScratchDir();
  end(id, update);
}

}  // namespace skinspec::api
