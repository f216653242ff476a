// The console's Maps page in a real headless Chromium, against a real skinspecd holding a map
// made through POST /api/v1/maps: the colour bar spans the API's range in the served colours, a
// hovered pixel shows the answer cube's value, a click plots the pixel's measured and fitted
// spectra, and a dragged rectangle's statistics are those of the cube's values inside it.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fmt/format.h>
#include <fstream>

#include "skinspec/client/http_client.hpp"
#include "skinspec/testkit/acquisition_rig.hpp"
#include "skinspec/testkit/store_samples.hpp"
#include "skinspec/spectral/spectra_csv.hpp"
#include "support/envi_cube.hpp"
#include "support/webdriver.hpp"

namespace skinspec::testing {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace skinspec::client;
using namespace std::chrono_literals;

const std::string kArtifacts = SKINSPEC_TEST_ARTIFACT_DIR;
constexpr std::size_t kLines = 12, kSamples = 16;

// The 50 measured NIST forearms (data/real-skin/) pixel after pixel, but for the first column,
// which is a grey card (not skin).
CubeValues forearms_cube() {
  std::ifstream in(std::string(SKINSPEC_TEST_DATA_DIR) + "/real-skin/nist_forearm_odd_subjects_379-781nm_3nm.csv");
  const std::string text{std::istreambuf_iterator<char>(in), {}};
  const auto forearms = parse_spectra_csv(text, "nist forearms");
  EXPECT_TRUE(forearms.has_value());
  if (!forearms) return {};
  const auto grid = forearms->front().spectrum.wavelengths();
  CubeValues cube{kLines, kSamples, grid.size(), {grid.begin(), grid.end()}, {}};
  cube.values.resize(kLines * kSamples * cube.bands);
  for (std::size_t l = 0; l < kLines; ++l)
    for (std::size_t s = 0; s < kSamples; ++s) {
      const auto values = (*forearms)[(l * kSamples + s) % forearms->size()].spectrum.values();
      for (std::size_t b = 0; b < cube.bands; ++b) cube.at(l, s, b) = s == 0 ? 0.3 : values[b];
    }
  return cube;
}

class WebMapsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!Browser::available())
      GTEST_SKIP() << "needs Debian's chromium and chromium-driver (scripts/setup installs them)";
    fs::create_directories(data_);
    write_envi(data_ / "face", forearms_cube(), {});
    rig_ = std::make_unique<AcquisitionRig>(rig_options(dir_.path().string(), {"--time-scale", "0"},
                                                        {"--data-dir", data_.string(), "--log-level", "warn"}));
    ASSERT_TRUE(rig_->ready()) << rig_->logs();
    const auto accepted = http_request(rig_->port, "POST", "/api/v1/maps", R"({"path": "face.hdr"})");
    ASSERT_EQ(accepted.status, 202) << accepted.body;
    const json job = wait_for_job(rig_->port, accepted.json(), 120s);
    ASSERT_EQ(job["state"], "succeeded") << job.dump(2);
    id_ = job["result"]["map_id"].get<long long>();
    map_ = get_json(rig_->port, fmt::format("/api/v1/maps/{}", id_));
    const std::string data = http_request(rig_->port, "GET", fmt::format("/api/v1/maps/{}/cube", id_)).body;
    cube_.resize(data.size() / sizeof(float));
    std::memcpy(cube_.data(), data.data(), cube_.size() * sizeof(float));
    browser_ = std::make_unique<Browser>(dir_.file("chromium-profile"), 1400, 1600);
    ASSERT_TRUE(browser_->ready());
    browser_->open(fmt::format("http://127.0.0.1:{}/#/maps/{}", rig_->port, id_));
    ASSERT_FALSE(browser_->find("#colour-bar").empty());
  }
  // The answer cube's value of band `name` at a pixel (band-interleaved by line).
  float value(const std::string& name, std::size_t x, std::size_t y) const {
    const auto& bands = map_["bands"];
    std::size_t b = 0;
    while (bands[b]["name"] != name) ++b;
    return cube_[(y * bands.size() + b) * kSamples + x];
  }
  float mask(std::size_t x, std::size_t y) const { return value("mask", x, y); }
  // A mouse event of `type` at the middle of pixel (x, y) of the map's canvas.
  void mouse(const std::string& type, std::size_t x, std::size_t y) {
    browser_->run(
        "const [type, x, y, samples, lines] = arguments; const c = document.getElementById('map-canvas');"
        "const b = c.getBoundingClientRect();"
        "c.dispatchEvent(new MouseEvent(type, {bubbles: true, clientX: b.left + (x + 0.5) * b.width / samples,"
        " clientY: b.top + (y + 0.5) * b.height / lines}));",
        json::array({type, x, y, kSamples, kLines}));
  }
  json data_of(const std::string& css) {
    return browser_->run(
        "const e = document.querySelector(arguments[0]); return e ? Object.assign({}, e.dataset) : null;",
        json::array({css}));
  }
  double number(const json& text) { return std::stod(text.get<std::string>()); }

  ScratchDirectory dir_;
  fs::path data_ = dir_.path() / "data";
  std::unique_ptr<AcquisitionRig> rig_;
  std::unique_ptr<Browser> browser_;
  long long id_ = 0;
  json map_;
  std::vector<float> cube_;
};

TEST_F(WebMapsTest, TheColourBarSpansTheMapsRangeInTheServedColours) {
  const json range = map_["summary"]["parameters"]["melanin"]["picture_range"];
  const json bar = data_of("#colour-bar");
  ASSERT_TRUE(bar.is_object());
  EXPECT_EQ(number(bar["low"]), range[0].get<double>());
  EXPECT_EQ(number(bar["high"]), range[1].get<double>());
  EXPECT_NEAR(std::stod(browser_->text(browser_->find(".bar-high"))), range[1].get<double>(),
              1e-2 * std::abs(range[1].get<double>()));
  // The bar's top and bottom rows are the colour map's last and first colours.
  const json ends = browser_->run(
      "const c = document.querySelector('#colour-bar canvas').getContext('2d');"
      "const hex = (d) => '#' + [d[0], d[1], d[2]].map((v) => v.toString(16).padStart(2, '0')).join('');"
      "return [hex(c.getImageData(5, 0, 1, 1).data), hex(c.getImageData(5, 255, 1, 1).data)];");
  const json& colours = map_["colour_map"]["colours"];
  EXPECT_EQ(ends[0], colours.back());
  EXPECT_EQ(ends[1], colours.front());
  // Another parameter: its own range.
  browser_->run(
      "const s = document.getElementById('map-parameter'); s.value = arguments[0];"
      "s.dispatchEvent(new Event('change'));",
      json::array({"total_hemoglobin"}));
  const json other = map_["summary"]["parameters"]["total_hemoglobin"]["picture_range"];
  ASSERT_TRUE(other[0].is_number()) << map_["summary"].dump(2);
  EXPECT_NE(other, range);
  EXPECT_EQ(number(data_of("#colour-bar")["low"]), other[0].get<double>());
  EXPECT_EQ(number(data_of("#colour-bar")["high"]), other[1].get<double>());
  browser_->screenshot(kArtifacts + "/maps-colour-bar.png");
}

TEST_F(WebMapsTest, AHoveredPixelShowsTheAnswerCubesValue) {
  mouse("mousemove", 5, 7);
  ASSERT_EQ(mask(5, 7), 0.0f);
  json shown = data_of("#map-hover");
  EXPECT_EQ(shown["x"], "5");
  EXPECT_EQ(shown["y"], "7");
  const float melanin = value("melanin", 5, 7);
  ASSERT_FALSE(std::isnan(melanin)) << "melanin is determined on these spectra";
  EXPECT_EQ(number(shown["value"]), static_cast<double>(melanin));
  mouse("mousemove", 0, 3);  // the grey card
  EXPECT_EQ(data_of("#map-hover")["value"], "not_skin");
  // The canvas draws the pixel in the colour the served map gives its value.
  const json range = map_["summary"]["parameters"]["melanin"]["picture_range"];
  const double lo = range[0].get<double>(), hi = range[1].get<double>();
  const double t = std::clamp((static_cast<double>(melanin) - lo) / (hi - lo), 0.0, 1.0);
  const json drawn = browser_->run(
      "const d = document.getElementById('map-canvas').getContext('2d').getImageData(5, 7, 1, 1).data;"
      "return '#' + [d[0], d[1], d[2]].map((v) => v.toString(16).padStart(2, '0')).join('');");
  EXPECT_EQ(drawn, map_["colour_map"]["colours"][static_cast<std::size_t>(std::lround(t * 255))]);
}

TEST_F(WebMapsTest, ARectanglesStatisticsAreThoseOfTheCubesValuesInsideIt) {
  mouse("mousedown", 9, 8);
  mouse("mousemove", 4, 6);
  mouse("mousemove", 0, 2);
  mouse("mouseup", 0, 2);
  const json shown = data_of("#region-table");
  ASSERT_TRUE(shown.is_object()) << "no region statistics shown";
  EXPECT_EQ(shown["x0"], "0");
  EXPECT_EQ(shown["y0"], "2");
  EXPECT_EQ(shown["x1"], "9");
  EXPECT_EQ(shown["y1"], "8");
  std::vector<double> values;
  std::size_t skin = 0;
  for (std::size_t y = 2; y <= 8; ++y)
    for (std::size_t x = 0; x <= 9; ++x) {
      if (mask(x, y) != 0) continue;
      ++skin;
      if (const float v = value("melanin", x, y); !std::isnan(v)) values.push_back(static_cast<double>(v));
    }
  ASSERT_GT(values.size(), 10u);
  EXPECT_EQ(shown["skin"], std::to_string(skin));
  EXPECT_EQ(skin, 7u * 9u) << "the grey column is not skin";
  EXPECT_EQ(shown["determined"], std::to_string(values.size()));
  double mean = 0;
  for (const double v : values) mean += v / static_cast<double>(values.size());
  double ss = 0;
  for (const double v : values) ss += (v - mean) * (v - mean);
  std::ranges::sort(values);
  EXPECT_NEAR(number(shown["mean"]), mean, 1e-12 * std::abs(mean));
  EXPECT_NEAR(number(shown["sd"]), std::sqrt(ss / static_cast<double>(values.size() - 1)), 1e-9 * std::abs(mean));
  EXPECT_EQ(number(shown["min"]), values.front());
  EXPECT_EQ(number(shown["max"]), values.back());
  browser_->screenshot(kArtifacts + "/maps-region.png");
}

TEST_F(WebMapsTest, AClickedPixelPlotsItsMeasuredAndFittedSpectra) {
  mouse("mousedown", 6, 4);
  mouse("mouseup", 6, 4);
  ASSERT_FALSE(browser_->find("#pixel-plot path[data-series='fitted']").empty());
  const json pixel = get_json(rig_->port, fmt::format("/api/v1/maps/{}/pixel?x=6&y=4", id_));
  const auto series = [&](const std::string& name) {
    return browser_
        ->run("return JSON.parse(document.querySelector(`#pixel-plot path[data-series='${arguments[0]}']`).dataset.y);",
              json::array({name}))
        .get<std::vector<double>>();
  };
  EXPECT_EQ(series("measured"), pixel["measured"].get<std::vector<double>>());
  EXPECT_EQ(series("fitted"), pixel["fit"]["fitted"].get<std::vector<double>>());
  EXPECT_EQ(pixel["mask"], "skin");
  browser_->screenshot(kArtifacts + "/maps-pixel.png");
}

}  // namespace
}  // namespace skinspec::testing
