// `skinspec map` through the built program: a cube written by Debian's python3-spectral (SPy)
// maps exactly as the same cube written here; a bad cube ends with exit 2 naming the file and
// the header field, and leaves nothing under the output's names; SIGINT stops a map cleanly.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <thread>
#include <unistd.h>

#include "skinspec/testkit/process.hpp"
#include "support/envi_cube.hpp"

namespace skinspec {
namespace {

namespace fs = std::filesystem;
using testing::CubeValues;
using ::testing::HasSubstr;

constexpr int kBadInput = 2;
constexpr int kInterrupted = 130;

testing::ProcessResult skinspec(const std::vector<std::string>& args) {
  return testing::run_process(SKINSPEC_TEST_BIN_DIR "/skinspec", args);
}

std::string bytes_of(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

// Skin-like spectra (rising towards the red, a haemoglobin dip near 560 nm), varied per pixel.
CubeValues skin_cube(std::size_t lines, std::size_t samples) {
  CubeValues cube{lines, samples, 0, {}, {}};
  for (double nm = 400; nm <= 760; nm += 5) cube.wavelength_nm.push_back(nm);
  cube.bands = cube.wavelength_nm.size();
  cube.values.resize(lines * samples * cube.bands);
  std::mt19937 random(3900);
  std::uniform_real_distribution vary(-0.03, 0.03);
  for (std::size_t l = 0; l < lines; ++l)
    for (std::size_t s = 0; s < samples; ++s) {
      const double shift = vary(random);
      for (std::size_t b = 0; b < cube.bands; ++b) {
        const double nm = cube.wavelength_nm[b];
        const double rise = 0.18 + 0.42 / (1 + std::exp(-(nm - 590) / 18));
        const double dip = 0.06 * std::exp(-std::pow((nm - 560) / 25, 2));
        cube.at(l, s, b) = std::round((rise - dip + shift) * 4096) / 4096;
      }
    }
  return cube;
}

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

TEST_F(MapCli, ABadCubeExitsWithStatus2NamingTheFileAndFieldAndWritesNothing) {
  struct Case {
    std::string name, from, to, field;
  };
  const CubeValues cube = skin_cube(3, 3);
  for (const Case& c :
       std::vector<Case>{{"type", "data type = 4", "data type = 99", "data type"},
                         {"sizes", "samples = 3", "samples = 4", "lines"},
                         {"decreasing", "wavelength = {400, 405", "wavelength = {405, 400", "wavelength"},
                         {"narrow", "wavelength = {400", "wavelength = {500", "wavelength"}}) {
    const auto header = write_envi(dir_ / c.name, cube, {});
    std::string text = bytes_of(header);
    text.replace(text.find(c.from), c.from.size(), c.to);
    if (c.name == "narrow") {  // every band 100 nm further: 500-860 nm
      std::string list = "wavelength = {";
      for (std::size_t b = 0; b < cube.bands; ++b) list += (b ? ", " : "") + std::to_string(500 + 5 * b);
      text = text.substr(0, text.find("wavelength = {")) + list + "}\n";
    }
    std::ofstream(header) << text;
    const fs::path out = dir_ / ("out-" + c.name);
    const auto run = skinspec({"map", header.string(), "-o", out.string()});
    EXPECT_EQ(run.exit_status, kBadInput) << c.name << ": " << run.describe();
    EXPECT_THAT(run.err, HasSubstr(header.string() + ": " + c.field)) << c.name;
    EXPECT_THAT(left_in(out), ::testing::IsEmpty()) << c.name;
  }
  const auto truncated = write_envi(dir_ / "truncated", cube, {});
  fs::resize_file(dir_ / "truncated.img", fs::file_size(dir_ / "truncated.img") / 2);
  const auto run = skinspec({"map", truncated.string(), "-o", (dir_ / "out-truncated").string()});
  EXPECT_EQ(run.exit_status, kBadInput) << run.describe();
  EXPECT_THAT(run.err, HasSubstr(truncated.string() + ": lines"));
  EXPECT_THAT(left_in(dir_ / "out-truncated"), ::testing::IsEmpty());
}

TEST_F(MapCli, SigintStopsAMapAndLeavesNothingUnderItsNames) {
  write_envi(dir_ / "large", skin_cube(400, 300), {});
  const fs::path out = dir_ / "out";
  testing::BackgroundProcess map(SKINSPEC_TEST_BIN_DIR "/skinspec",
                                 {"map", (dir_ / "large.hdr").string(), "-o", out.string(), "--block-lines", "4"});
  ASSERT_TRUE(map.started()) << map.start_error();
  // Wait until the map is under way: its hidden directory exists.
  for (int i = 0; i < 200 && left_in(out).empty(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_FALSE(left_in(out).empty());
  map.send_signal(SIGINT);
  const auto result = map.wait(std::chrono::seconds(30));
  EXPECT_EQ(result.exit_status, kInterrupted) << result.describe();
  EXPECT_THAT(result.err, HasSubstr("interrupted"));
  EXPECT_THAT(left_in(out), ::testing::IsEmpty());
}

}  // namespace
}  // namespace skinspec
