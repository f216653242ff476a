// `skinspec map` through the built program: a cube written by Debian's python3-spectral (SPy)
// maps exactly as the same cube written here; a bad cube ends with exit 2 naming the file and
// the header field, and leaves nothing under the output's names; SIGINT and SIGTERM stop a map
// cleanly.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fmt/format.h>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <unistd.h>

#include "skinspec/testkit/process.hpp"
#include "support/envi_cube.hpp"
#include "support/png_reader.hpp"

namespace skinspec {
namespace {

namespace fs = std::filesystem;
using testing::CubeValues;
using ::testing::HasSubstr;

constexpr int kBadInput = 2;

testing::ProcessResult skinspec(const std::vector<std::string>& args) {
  return testing::run_process(SKINSPEC_TEST_BIN_DIR "/skinspec", args);
}

using testing::lines_of;

std::string bytes_of(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

using testing::skin_cube;

class MapCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("map_cli_test-" + std::to_string(::getpid()) + "-" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  // The names left in the output directory, hidden ones included.
  std::vector<std::string> left_in(const fs::path& out) const {
    std::vector<std::string> names;
    if (fs::exists(out))
      for (const auto& entry : fs::directory_iterator(out)) names.push_back(entry.path().filename().string());
    return names;
  }
  // A map of a large cube into DIR/out, sent `signal` once it is under way (its hidden
  // directory exists), and how it ended.
  testing::ProcessResult map_stopped_by(int signal) {
    write_envi(dir_ / "large", skin_cube(400, 300), {});
    const fs::path out = dir_ / "out";
    testing::BackgroundProcess map(SKINSPEC_TEST_BIN_DIR "/skinspec",
                                   {"map", (dir_ / "large.hdr").string(), "-o", out.string(), "--block-lines", "4"});
    EXPECT_TRUE(map.started()) << map.start_error();
    if (!map.started()) return {};
    for (int i = 0; i < 200 && left_in(out).empty(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    EXPECT_FALSE(left_in(out).empty()) << "the map never started";
    map.send_signal(signal);
    return map.wait(std::chrono::seconds(30));
  }
  fs::path dir_;
};

TEST_F(MapCli, ACubeWrittenBySpyMapsAsTheSameCubeWrittenHere) {
  const CubeValues cube = skin_cube(4, 6);
  write_envi(dir_ / "here", cube, {});
  // SPy writes BIP float32 with its own header layout (and a lowercase "wavelength units").
  std::string script =
      "import numpy, sys\nimport spectral.io.envi as envi\n"
      "cube = numpy.fromfile(sys.argv[1], dtype='<f4').reshape(" +
      std::to_string(cube.lines) + ", " + std::to_string(cube.samples) + ", " + std::to_string(cube.bands) +
      ")\n"  // BIL on disk: reorder below
      "cube = cube.reshape(" +
      std::to_string(cube.lines) + ", " + std::to_string(cube.bands) + ", " + std::to_string(cube.samples) +
      ").transpose(0, 2, 1)\n"
      "envi.save_image(sys.argv[2], cube, dtype=numpy.float32, interleave='bip', force=True,\n"
      "  metadata={'wavelength': [float(w) for w in sys.argv[3].split(',')], 'wavelength units': 'nm'})\n";
  std::string wavelengths;
  for (const double w : cube.wavelength_nm) wavelengths += (wavelengths.empty() ? "" : ",") + std::to_string(w);
  const auto spy = testing::run_process(
      "/usr/bin/python3", {"-c", script, (dir_ / "here.img").string(), (dir_ / "spy.hdr").string(), wavelengths});
  ASSERT_EQ(spy.exit_status, 0) << spy.describe();
  const auto here = skinspec({"map", (dir_ / "here.hdr").string(), "-o", (dir_ / "out").string()});
  ASSERT_EQ(here.exit_status, 0) << here.describe();
  const auto theirs = skinspec({"map", (dir_ / "spy.hdr").string(), "-o", (dir_ / "out").string()});
  ASSERT_EQ(theirs.exit_status, 0) << theirs.describe();
  const std::string mine = bytes_of(dir_ / "out" / "here.map.img");
  EXPECT_EQ(mine.size(), cube.lines * cube.samples * 19 * sizeof(float));
  EXPECT_EQ(bytes_of(dir_ / "out" / "spy.map.img"), mine);
  const auto summary = nlohmann::json::parse(bytes_of(dir_ / "out" / "here.summary.json"));
  EXPECT_EQ(summary["pixels"]["skin"], 24) << summary.dump(2);
  EXPECT_THAT(bytes_of(dir_ / "out" / "here.map.hdr"), HasSubstr("melanin_stderr"));
}

// HDF5 as h5py writes it (C order, the wavelengths in µm with their unit) and as MATLAB v7.3
// does (column order, a MATLAB_class attribute, nm): both map as the same cube written as ENVI.
TEST_F(MapCli, Hdf5CubesInCAndMatlabOrderMapAsTheEnviCube) {
  const CubeValues cube = skin_cube(4, 6);
  write_envi(dir_ / "here", cube, {});
  const std::string script =
      "import numpy, sys, h5py\n"
      "lines, samples, bands = " +
      fmt::format("{}, {}, {}", cube.lines, cube.samples, cube.bands) +
      "\n"
      "bil = numpy.fromfile(sys.argv[1], dtype='<f4').reshape(lines, bands, samples)\n"
      "cube = bil.transpose(0, 2, 1)  # lines, samples, bands\n"
      "wl = numpy.array([float(w) for w in sys.argv[4].split(',')])\n"
      "with h5py.File(sys.argv[2], 'w') as f:\n"
      "    f['cube'] = cube\n"
      "    f['wavelength'] = wl / 1000\n"
      "    f['wavelength'].attrs['units'] = 'um'\n"
      "with h5py.File(sys.argv[3], 'w') as f:\n"
      "    f['hsi'] = numpy.ascontiguousarray(cube.transpose(2, 1, 0))  # MATLAB's column order\n"
      "    f['hsi'].attrs['MATLAB_class'] = numpy.bytes_('single')\n"
      "    f['wl'] = wl.reshape(1, -1)[0]\n";
  std::string wavelengths;
  for (const double w : cube.wavelength_nm) wavelengths += (wavelengths.empty() ? "" : ",") + std::to_string(w);
  const auto h5 = testing::run_process("/usr/bin/python3",
                                       {"-c", script, (dir_ / "here.img").string(), (dir_ / "c_order.h5").string(),
                                        (dir_ / "matlab.mat").string(), wavelengths});
  ASSERT_EQ(h5.exit_status, 0) << h5.describe();
  const fs::path out = dir_ / "out";
  for (const char* file : {"here.hdr", "c_order.h5", "matlab.mat"}) {
    const auto run = skinspec({"map", (dir_ / file).string(), "-o", out.string()});
    ASSERT_EQ(run.exit_status, 0) << file << ": " << run.describe();
  }
  const std::string envi = bytes_of(out / "here.map.img");
  EXPECT_EQ(bytes_of(out / "c_order.map.img"), envi);
  EXPECT_EQ(bytes_of(out / "matlab.map.img"), envi);
}

TEST_F(MapCli, ABadCubeExitsWithStatus2NamingTheFileAndFieldAndWritesNothing) {
  for (const auto& bad : testing::write_bad_cubes(dir_)) {
    const fs::path header = dir_ / (bad.name + ".hdr"), out = dir_ / ("out-" + bad.name);
    const auto run = skinspec({"map", header.string(), "-o", out.string()});
    EXPECT_EQ(run.exit_status, kBadInput) << bad.name << ": " << run.describe();
    EXPECT_THAT(run.err, HasSubstr(header.string() + ": " + bad.field)) << bad.name;
    EXPECT_THAT(left_in(out), ::testing::IsEmpty()) << bad.name;
  }
}

// GDAL and the libraries it needs are loaded only to read or write a cube: a command that does
// not (here --version) starts without them, and `skinspec map` loads the module that has them.
TEST_F(MapCli, GdalIsLoadedOnlyByACommandThatReadsACube) {
  const auto loaded = [](const testing::ProcessResult& run, std::string_view library) {
    return std::ranges::any_of(lines_of(run.err), [&](const std::string& line) {
      return line.find("file=") != std::string::npos && line.find(library) != std::string::npos;
    });
  };
  const testing::ProcessOptions traced{std::nullopt, std::chrono::seconds(120), {"LD_DEBUG=files"}};
  const auto version = testing::run_process(SKINSPEC_TEST_BIN_DIR "/skinspec", {"--version"}, traced);
  ASSERT_EQ(version.exit_status, 0) << version.describe();
  EXPECT_FALSE(loaded(version, "libgdal")) << version.err;
  EXPECT_FALSE(loaded(version, "libskinspec-gdal")) << version.err;

  write_envi(dir_ / "small", skin_cube(4, 3), {});
  const auto map = testing::run_process(SKINSPEC_TEST_BIN_DIR "/skinspec",
                                        {"map", (dir_ / "small.hdr").string(), "-o", (dir_ / "out").string()}, traced);
  ASSERT_EQ(map.exit_status, 0) << map.describe();
  EXPECT_TRUE(loaded(map, "libskinspec-gdal.so")) << map.err;
  EXPECT_TRUE(loaded(map, "libgdal")) << map.err;
}

// A skinspec installed without its GDAL module says so, and exits as for a fault of its own
// (1), not of the cube (2); it writes nothing.
TEST_F(MapCli, WithoutItsGdalModuleAMapSaysSoAndWritesNothing) {
  fs::create_directories(dir_ / "bin");
  fs::copy_file(SKINSPEC_TEST_BIN_DIR "/skinspec", dir_ / "bin" / "skinspec");
  write_envi(dir_ / "small", skin_cube(4, 3), {});
  const auto run = testing::run_process((dir_ / "bin" / "skinspec").string(),
                                        {"map", (dir_ / "small.hdr").string(), "-o", (dir_ / "out").string()});
  EXPECT_EQ(run.exit_status, 1) << run.describe();
  EXPECT_THAT(run.err, HasSubstr("GDAL module")) << run.err;
  EXPECT_THAT(run.err, HasSubstr((dir_ / "lib" / "skinspec" / "libskinspec-gdal.so").string())) << run.err;
  EXPECT_THAT(left_in(dir_ / "out"), ::testing::IsEmpty());
}

TEST_F(MapCli, SigintStopsAMapAndLeavesNothingUnderItsNames) {
  const auto result = map_stopped_by(SIGINT);
  EXPECT_EQ(result.exit_status, 128 + SIGINT) << result.describe();
  EXPECT_THAT(result.err, HasSubstr("stopped by SIGINT"));
  EXPECT_THAT(left_in(dir_ / "out"), ::testing::IsEmpty());
}

// A map killed outright leaves its hidden directory; mapping the cube again removes it, but not
// the directory of a map whose process still runs.
TEST_F(MapCli, AMapKilledOutrightIsClearedAwayByTheNextMapOfItsCube) {
  write_envi(dir_ / "face", skin_cube(3, 4), {});
  const fs::path out = dir_ / "out";
  const fs::path abandoned = out / ".face.partial-2147483646",
                 running = out / fmt::format(".face.partial-{}", ::getpid());
  for (const auto& partial : {abandoned, running}) {
    fs::create_directories(partial);
    std::ofstream(partial / "face.map.img") << "half";
  }
  const auto run = skinspec({"map", (dir_ / "face.hdr").string(), "-o", out.string()});
  ASSERT_EQ(run.exit_status, 0) << run.describe();
  EXPECT_FALSE(fs::exists(abandoned));
  EXPECT_TRUE(fs::exists(running / "face.map.img"));
  EXPECT_TRUE(fs::exists(out / "face.map.img"));
}

// A scheduler's time limit (Slurm sends SIGTERM) stops a map as cleanly.
TEST_F(MapCli, SigtermStopsAMapAndLeavesNothingUnderItsNames) {
  const auto result = map_stopped_by(SIGTERM);
  EXPECT_EQ(result.exit_status, 128 + SIGTERM) << result.describe();
  EXPECT_THAT(left_in(dir_ / "out"), ::testing::IsEmpty());
  std::ofstream(dir_ / "a-file") << "x";
  const auto not_a_directory = skinspec({"map", (dir_ / "large.hdr").string(), "-o", (dir_ / "a-file").string()});
  EXPECT_EQ(not_a_directory.exit_status, kBadInput) << not_a_directory.describe();
}

// The floats of an ENVI map (a band per quantity, band-interleaved by line).
std::vector<float> floats_of(const fs::path& file) {
  const std::string bytes = bytes_of(file);
  std::vector<float> values(bytes.size() / sizeof(float));
  std::memcpy(values.data(), bytes.data(), values.size() * sizeof(float));
  return values;
}

TEST_F(MapCli, ARadianceCubeWithAWhiteRegionAndADarkMapsAsItsReflectance) {
  // Line 0 is the white panel (reflectance 0.99); the rest is skin. The light rises towards
  // the red; the dark is a constant offset.
  CubeValues reflectance = skin_cube(5, 6);
  for (std::size_t s = 0; s < reflectance.samples; ++s)
    for (std::size_t b = 0; b < reflectance.bands; ++b) reflectance.at(0, s, b) = 0.99;
  CubeValues radiance = reflectance, dark{2, 2, reflectance.bands, reflectance.wavelength_nm, {}};
  constexpr double kDark = 40;
  for (std::size_t l = 0; l < radiance.lines; ++l)
    for (std::size_t s = 0; s < radiance.samples; ++s)
      for (std::size_t b = 0; b < radiance.bands; ++b)
        radiance.at(l, s, b) = reflectance.at(l, s, b) * (500 + 2 * radiance.wavelength_nm[b]) + kDark;
  dark.values.assign(2 * 2 * dark.bands, kDark);
  write_envi(dir_ / "reflectance", reflectance, {});
  write_envi(dir_ / "radiance", radiance, {});
  write_envi(dir_ / "dark", dark, {});
  const auto by_reflectance = skinspec({"map", (dir_ / "reflectance.hdr").string(), "-o", (dir_ / "out").string()});
  ASSERT_EQ(by_reflectance.exit_status, 0) << by_reflectance.describe();
  const auto by_radiance = skinspec({"map", (dir_ / "radiance.hdr").string(), "-o", (dir_ / "out").string(),
                                     "--white-roi", "0,0,6,1", "--dark", (dir_ / "dark.hdr").string()});
  ASSERT_EQ(by_radiance.exit_status, 0) << by_radiance.describe();
  const auto expected = floats_of(dir_ / "out" / "reflectance.map.img");
  const auto got = floats_of(dir_ / "out" / "radiance.map.img");
  ASSERT_EQ(got.size(), expected.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    if (std::isnan(expected[i])) {
      EXPECT_TRUE(std::isnan(got[i])) << i;
    } else {
      EXPECT_NEAR(got[i], expected[i], 1e-3 * std::abs(static_cast<double>(expected[i])) + 1e-6) << i;
    }
  }
  // Without a white, --dark is refused; a white region outside the cube names it.
  const auto no_white = skinspec(
      {"map", (dir_ / "radiance.hdr").string(), "-o", (dir_ / "o2").string(), "--dark", (dir_ / "dark.hdr").string()});
  EXPECT_EQ(no_white.exit_status, kBadInput) << no_white.describe();
  const auto outside =
      skinspec({"map", (dir_ / "radiance.hdr").string(), "-o", (dir_ / "o3").string(), "--white-roi", "4,4,6,6"});
  EXPECT_EQ(outside.exit_status, kBadInput) << outside.describe();
  EXPECT_THAT(outside.err, HasSubstr("not inside"));
  EXPECT_THAT(left_in(dir_ / "o2"), ::testing::IsEmpty());
  EXPECT_THAT(left_in(dir_ / "o3"), ::testing::IsEmpty());
}

TEST_F(MapCli, AFloatTiffMapHoldsWhatTheEnviMapHoldsAndEachParameterHasAPicture) {
  write_envi(dir_ / "face", skin_cube(6, 5), {});
  const auto envi = skinspec({"map", (dir_ / "face.hdr").string(), "-o", (dir_ / "envi").string()});
  ASSERT_EQ(envi.exit_status, 0) << envi.describe();
  const auto tiff = skinspec({"map", (dir_ / "face.hdr").string(), "-o", (dir_ / "tiff").string(), "--format", "tiff"});
  ASSERT_EQ(tiff.exit_status, 0) << tiff.describe();
  EXPECT_TRUE(fs::exists(dir_ / "tiff" / "face.map.tif"));
  // Each summary is computed from the cube as written and read back.
  auto from_envi = nlohmann::json::parse(bytes_of(dir_ / "envi" / "face.summary.json"));
  auto from_tiff = nlohmann::json::parse(bytes_of(dir_ / "tiff" / "face.summary.json"));
  EXPECT_EQ(from_tiff["parameters"], from_envi["parameters"]);
  EXPECT_EQ(from_tiff["pixels"], from_envi["pixels"]);
  for (const char* parameter : {"surface_reflectance", "melanin", "total_hemoglobin", "oxygen_saturation", "bilirubin",
                                "dermis_scattering", "dermis_scattering_power"}) {
    const auto png = testing::decode_png(bytes_of(dir_ / "envi" / fmt::format("face.{}.png", parameter)));
    ASSERT_TRUE(png) << parameter;
    EXPECT_GE(png->height, 256) << parameter;
    EXPECT_GT(png->width, png->height) << parameter;  // the map, then the colour bar beside it
  }
}

TEST_F(MapCli, ShardsSplitTheCubesTheSameWayInEveryTask) {
  for (const char* name : {"c", "a", "b"}) write_envi(dir_ / name, skin_cube(1, 2), {});
  const auto mapped = [&](const std::vector<std::string>& extra, const std::vector<std::string>& environment) {
    std::vector<std::string> args = {
        "map", (dir_ / "c.hdr").string(), (dir_ / "a.hdr").string(), (dir_ / "b.hdr").string(),
        "-o",  (dir_ / "out").string()};
    args.insert(args.end(), extra.begin(), extra.end());
    testing::ProcessOptions options;
    options.environment = environment;
    const auto run = testing::run_process(SKINSPEC_TEST_BIN_DIR "/skinspec", args, options);
    EXPECT_EQ(run.exit_status, 0) << run.describe();
    std::vector<std::string> cubes;
    for (const auto& line : lines_of(run.out))
      if (line.ends_with(".summary.json")) cubes.push_back(fs::path(line).stem().stem().string());
    return cubes;
  };
  EXPECT_EQ(mapped({"--shard", "0/2"}, {}), (std::vector<std::string>{"a", "c"}));
  EXPECT_EQ(mapped({"--shard", "1/2"}, {}), (std::vector<std::string>{"b"}));
  EXPECT_EQ(mapped({}, {"SLURM_ARRAY_TASK_ID=4", "SLURM_ARRAY_TASK_COUNT=2", "SLURM_ARRAY_TASK_MIN=3"}),
            (std::vector<std::string>{"b"}));
  EXPECT_EQ(mapped({}, {}), (std::vector<std::string>{"a", "b", "c"}));
  const auto bad = skinspec({"map", (dir_ / "a.hdr").string(), "-o", (dir_ / "out").string(), "--shard", "2/2"});
  EXPECT_EQ(bad.exit_status, kBadInput) << bad.describe();
  fs::create_directories(dir_ / "other");
  write_envi(dir_ / "other" / "a", skin_cube(1, 2), {});
  const auto twice =
      skinspec({"map", (dir_ / "a.hdr").string(), (dir_ / "other" / "a.hdr").string(), "-o", (dir_ / "out2").string()});
  EXPECT_EQ(twice.exit_status, kBadInput) << twice.describe();
  EXPECT_THAT(twice.err, HasSubstr("would both be mapped"));
}

}  // namespace
}  // namespace skinspec
