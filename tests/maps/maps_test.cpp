// Skin maps (maps/): a cube reads the same in every ENVI layout; a bad cube is refused naming
// its file and header field; a synthetic cube rendered by the forward model, with smooth known
// maps of every parameter, noise and a border that is not skin, is recovered pixel by pixel,
// with the answers `skinspec fit` gives for the same spectra, or better ones.

#include <gtest/gtest.h>

#include <gdal_priv.h>

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <filesystem>
#include <fstream>
#include <memory>
#include <random>
#include <span>
#include <string>
#include <unistd.h>

#include "skinspec/maps/colour_map.hpp"
#include "skinspec/maps/map_picture.hpp"
#include "skinspec/maps/mapper.hpp"
#include "skinspec/spectral/colour.hpp"
#include "support/data.hpp"
#include "support/envi_cube.hpp"

namespace skinspec::maps {
namespace {

namespace fs = std::filesystem;
using testing::CubeValues;
using testing::EnviLayout;
using testing::Interleave;

class MapsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("maps_test-" + std::to_string(::getpid()) + "-" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

std::vector<double> grid(double first, double last, double step) { return Spectrum::uniform_grid(first, last, step); }

// Values k / 1024 are exact in float32 and as uint16 counts with a scale factor of 1024, so
// every layout stores the very same reflectance.
CubeValues quantized_cube(std::size_t lines, std::size_t samples) {
  CubeValues cube{lines, samples, 0, grid(380, 780, 4), {}};
  cube.bands = cube.wavelength_nm.size();
  cube.values.resize(lines * samples * cube.bands);
  std::mt19937 random(39);
  for (std::size_t l = 0; l < lines; ++l)
    for (std::size_t s = 0; s < samples; ++s)
      for (std::size_t b = 0; b < cube.bands; ++b) {
        const double smooth = 0.2 + 0.45 * static_cast<double>(b) / static_cast<double>(cube.bands);
        cube.at(l, s, b) =
            std::round((smooth + 0.01 * std::uniform_real_distribution(-1.0, 1.0)(random)) * 1024) / 1024;
      }
  return cube;
}

std::vector<double> reflectance_of(const Cube& cube) {
  const auto stored = cube.read_lines(0, cube.info().lines);
  EXPECT_TRUE(stored) << stored.error().what();
  std::vector<double> out;
  if (stored)
    for (const float v : *stored) out.push_back(static_cast<double>(v) / cube.info().reflectance_scale);
  return out;
}

TEST_F(MapsTest, EveryLayoutReadsTheSameReflectance) {
  const CubeValues values = quantized_cube(5, 7);
  int written = 0;
  for (const Interleave interleave : {Interleave::bsq, Interleave::bil, Interleave::bip})
    for (const bool uint16 : {false, true})
      for (const bool big_endian : {false, true})
        for (const std::size_t offset : {std::size_t{0}, std::size_t{128}}) {
          const EnviLayout layout{interleave, uint16, uint16 ? 1024.0 : 1.0, big_endian, offset};
          const auto header = write_envi(dir_ / ("cube" + std::to_string(written++)), values, layout);
          const auto cube = Cube::open(header.string());
          ASSERT_TRUE(cube) << cube.error().what();
          EXPECT_EQ(cube->info().lines, 5u);
          EXPECT_EQ(cube->info().samples, 7u);
          EXPECT_EQ(cube->info().wavelength_nm, values.wavelength_nm);
          EXPECT_EQ(reflectance_of(*cube), values.values) << header;
          // Lines from the middle: where each lies in the file, in every layout.
          const auto middle = cube->read_lines(1, 3);
          ASSERT_TRUE(middle) << middle.error().what();
          const auto pixel = static_cast<std::ptrdiff_t>(values.samples * values.bands);
          EXPECT_TRUE(std::ranges::equal(*middle, std::span(values.values).subspan(pixel, 3 * pixel),
                                         [&](float stored, double value) {
                                           return static_cast<double>(stored) / cube->info().reflectance_scale == value;
                                         }))
              << header;
        }
  EXPECT_EQ(written, 24);
}

// A multi-band float TIFF, each band's centre in its GDAL metadata (as GDAL and ENVI write
// them), stored pixel by pixel or band by band, reads as the same cube written as ENVI.
TEST_F(MapsTest, AMultiBandFloatTiffReadsAsTheEnviCube) {
  const CubeValues values = quantized_cube(3, 4);
  const auto envi = Cube::open(write_envi(dir_ / "envi", values, {}).string());
  ASSERT_TRUE(envi) << envi.error().what();
  GDALAllRegister();
  // Each pixel's bands together (GDAL's default) and each band's plane whole.
  for (const char* interleave : {"INTERLEAVE=PIXEL", "INTERLEAVE=BAND"}) {
    const fs::path tiff = dir_ / (std::string(interleave) + ".tif");
    {
      GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
      ASSERT_NE(driver, nullptr);
      const char* options[] = {interleave, nullptr};
      std::unique_ptr<GDALDataset> out(driver->Create(tiff.c_str(), static_cast<int>(values.samples),
                                                      static_cast<int>(values.lines), static_cast<int>(values.bands),
                                                      GDT_Float32, const_cast<char**>(options)));
      ASSERT_NE(out, nullptr);
      for (std::size_t b = 0; b < values.bands; ++b) {
        std::vector<float> band(values.lines * values.samples);
        for (std::size_t p = 0; p < band.size(); ++p) band[p] = static_cast<float>(values.values[p * values.bands + b]);
        GDALRasterBand* raster = out->GetRasterBand(static_cast<int>(b + 1));
        ASSERT_EQ(raster->RasterIO(GF_Write, 0, 0, static_cast<int>(values.samples), static_cast<int>(values.lines),
                                   band.data(), static_cast<int>(values.samples), static_cast<int>(values.lines),
                                   GDT_Float32, 0, 0, nullptr),
                  CE_None);
        raster->SetMetadataItem("wavelength", fmt::format("{}", values.wavelength_nm[b]).c_str());
        raster->SetMetadataItem("wavelength_units", "nm");
      }
    }
    const auto cube = Cube::open(tiff.string());
    ASSERT_TRUE(cube) << cube.error().what();
    EXPECT_EQ(cube->info().wavelength_nm, values.wavelength_nm);
    EXPECT_EQ(reflectance_of(*cube), reflectance_of(*envi)) << interleave;
    const auto middle = cube->read_lines(1, 2), envi_middle = envi->read_lines(1, 2);
    ASSERT_TRUE(middle && envi_middle) << interleave;
    EXPECT_EQ(*middle, *envi_middle) << interleave;
  }
}

TEST_F(MapsTest, WavelengthsInMicrometresAreReadInNanometres) {
  CubeValues values = quantized_cube(2, 2);
  std::string list = "wavelength units = Micrometers\nwavelength = {";
  for (std::size_t b = 0; b < values.bands; ++b)
    list += (b ? ", " : "") + std::to_string(values.wavelength_nm[b] / 1000);
  const auto header = write_envi(dir_ / "um", values, {}, list + "}\n", false);
  const auto cube = Cube::open(header.string());
  ASSERT_TRUE(cube) << cube.error().what();
  for (std::size_t b = 0; b < values.bands; ++b)
    EXPECT_NEAR(cube->info().wavelength_nm[b], values.wavelength_nm[b], 1e-9);
}

// The error of opening a cube whose header or data file is damaged.
CubeError refusal(const fs::path& header) {
  const auto cube = Cube::open(header.string());
  EXPECT_FALSE(cube) << header << " was accepted";
  return cube ? CubeError{} : cube.error();
}

std::string replaced(const fs::path& file, const std::string& from, const std::string& to) {
  std::ifstream in(file);
  std::string text((std::istreambuf_iterator<char>(in)), {});
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  std::ofstream(file) << text;
  return text;
}

// A raw file cut short after the cube was opened is an error when its lines are read, not zeros.
TEST_F(MapsTest, ACubeTruncatedAfterItWasOpenedIsAnErrorWhenRead) {
  const CubeValues values = quantized_cube(4, 3);
  const auto header = write_envi(dir_ / "shrinking", values, {});
  auto cube = Cube::open(header.string());
  ASSERT_TRUE(cube) << cube.error().what();
  ASSERT_TRUE(cube->read_lines(0, 4));
  fs::resize_file(dir_ / "shrinking.img", fs::file_size(dir_ / "shrinking.img") / 2);
  const auto lines = cube->read_lines(2, 2);
  ASSERT_FALSE(lines);
  EXPECT_EQ(lines.error().file, header.string());
  EXPECT_EQ(lines.error().field, "lines");
}

TEST_F(MapsTest, ABadCubeIsRefusedNamingItsFileAndField) {
  const CubeValues values = quantized_cube(4, 3);
  {
    const auto header = write_envi(dir_ / "truncated", values, {});
    fs::resize_file(dir_ / "truncated.img", fs::file_size(dir_ / "truncated.img") - 10);
    const CubeError e = refusal(header);
    EXPECT_EQ(e.file, header.string());
    EXPECT_EQ(e.field, "lines");
  }
  {
    const auto header = write_envi(dir_ / "sizes", values, {});
    replaced(header, "lines = 4", "lines = 3");
    EXPECT_EQ(refusal(header).field, "lines");
  }
  {
    const auto header = write_envi(dir_ / "type", values, {});
    replaced(header, "data type = 4", "data type = 99");
    const CubeError e = refusal(header);
    EXPECT_EQ(e.field, "data type") << e.what();
  }
  {
    const auto header = write_envi(dir_ / "complex", values, {});
    replaced(header, "data type = 4", "data type = 6");
    replaced(header, "samples = 3", "samples = 1");
    replaced(header, "lines = 4", "lines = 6");  // 6 × 1 × 101 complex pairs: the file's size
    EXPECT_EQ(refusal(header).field, "data type");
  }
  {
    const auto header = write_envi(dir_ / "nowavelength", values, {}, "", false);
    EXPECT_EQ(refusal(header).field, "wavelength");
  }
  {
    const auto header = write_envi(dir_ / "decreasing", values, {});
    replaced(header, "wavelength = {380, 384", "wavelength = {384, 380");
    const CubeError e = refusal(header);
    EXPECT_EQ(e.field, "wavelength");
    EXPECT_NE(e.message.find("not increasing"), std::string::npos) << e.what();
  }
  {
    const auto header = write_envi(dir_ / "nodata", values, {});
    fs::remove(dir_ / "nodata.img");
    EXPECT_NE(refusal(header).message.find("no data file"), std::string::npos);
  }
  {
    CubeValues narrow = quantized_cube(2, 2);
    narrow.wavelength_nm = grid(500, 900, 4);
    const auto cube = Cube::open(write_envi(dir_ / "narrow", narrow, {}).string());
    ASSERT_TRUE(cube) << cube.error().what();
    const auto covered = check_coverage(cube->info());
    ASSERT_FALSE(covered);
    EXPECT_EQ(covered.error().field, "wavelength");
  }
}

// GDAL reads some two hundred formats, and some of them name other files or addresses: a VRT
// file's bands can be any raw file the process may read, a WMS file's a web server. A cube is
// read only as ENVI, TIFF, HDF5 or netCDF, so an uploaded "cube" cannot make the service read
// its database, its token file or its TLS key, or fetch an address inside the lab's network.
TEST_F(MapsTest, AFileThatNamesOtherFilesIsNotReadAsACube) {
  const fs::path secret = dir_ / "secret.bin";
  {
    std::ofstream out(secret, std::ios::binary);
    const std::vector<float> values(2 * 2 * 3, 0.5F);
    out.write(reinterpret_cast<const char*>(values.data()), static_cast<std::streamsize>(values.size() * 4));
  }
  const std::string vrt = testing::raw_file_vrt(secret, 2, 2, {400, 550, 700});
  for (const char* name : {"cube.vrt", "cube.tif"}) {
    std::ofstream(dir_ / name) << vrt;
    const CubeError e = refusal(dir_ / name);
    EXPECT_EQ(e.file, (dir_ / name).string());
    EXPECT_NE(e.message.find("ENVI, TIFF, HDF5 or netCDF"), std::string::npos) << e.what();
  }
}

// ---------------------------------------------------------------------------------------------
// Ground truth: every parameter varies smoothly over the image; a border two pixels wide is a
// grey card, which is not skin.

constexpr ModelKind kModel = ModelKind::extended;
constexpr std::size_t kSide = 20, kBorder = 2;
constexpr double kNoise = 0.002;

Params truth_at(std::size_t line, std::size_t sample) {
  const double x = static_cast<double>(sample) / (kSide - 1), y = static_cast<double>(line) / (kSide - 1);
  Params p(kExtendedParamCount);
  p[kSurfaceReflectance] = 0.035 + 0.02 * y;
  p[kMelanin] = 2 + 18 * x;
  p[kTotalHemoglobin] = 4 + 10 * y;
  p[kOxygenSaturation] = 0.5 + 0.3 * (x + y) / 2;
  p[kBilirubin] = 0.5;
  p[kDermisScattering] = 25 + 15 * x * y;
  p[kDermisScatteringPower] = 1.0 + 1.0 * y;
  return p;
}

bool on_border(std::size_t line, std::size_t sample) {
  return line < kBorder || sample < kBorder || line >= kSide - kBorder || sample >= kSide - kBorder;
}

CubeValues ground_truth_cube() {
  CubeValues cube{kSide, kSide, 0, grid(380, 780, 4), {}};
  cube.bands = cube.wavelength_nm.size();
  cube.values.resize(kSide * kSide * cube.bands);
  const SkinOptics& optics = testing::shipped_optics(kModel);
  const SkinModel model(optics, *optics.site("forearm"), cube.wavelength_nm, true);
  std::mt19937 random(2039);
  std::normal_distribution noise(0.0, kNoise);
  for (std::size_t l = 0; l < kSide; ++l)
    for (std::size_t s = 0; s < kSide; ++s) {
      const Params p = truth_at(l, s);
      for (std::size_t b = 0; b < cube.bands; ++b)
        cube.at(l, s, b) = on_border(l, s) ? 0.4 : model.reflectance_at(b, p.data()) + noise(random);
    }
  return cube;
}

struct MappedCube {
  std::vector<float> answers;
  MapTally tally;
};

MappedCube map_cube(const Cube& cube, bool neighbour_starts) {
  const Fitter fitter(testing::shipped_optics(kModel), testing::colorimetry());
  MapOptions options;
  options.fit.model = kModel;
  options.neighbour_starts = neighbour_starts;
  const Mapper mapper(fitter, options, cube.info());
  const auto stored = cube.read_lines(0, cube.info().lines);
  EXPECT_TRUE(stored);
  MappedCube mapped;
  if (stored) mapped.answers = mapper.map_lines(*stored, cube.info().lines, mapped.tally);
  return mapped;
}

TEST_F(MapsTest, ASyntheticCubeIsRecoveredPixelByPixelAsSkinspecFitRecoversEach) {
  const CubeValues values = ground_truth_cube();
  const auto cube = Cube::open(write_envi(dir_ / "truth", values, {}).string());
  ASSERT_TRUE(cube) << cube.error().what();
  const MappedCube mapped = map_cube(*cube, true);
  const std::size_t bands = map_bands(kModel).size();
  const Fitter fitter(testing::shipped_optics(kModel), testing::colorimetry());
  FitOptions options;
  options.model = kModel;
  std::size_t skin = 0, melanin_determined = 0, better_than_fit = 0;
  for (std::size_t l = 0; l < kSide; ++l)
    for (std::size_t s = 0; s < kSide; ++s) {
      const float* answer = &mapped.answers[(l * kSide + s) * bands];
      const auto reason = static_cast<MaskReason>(static_cast<int>(answer[bands - 1]));
      if (on_border(l, s)) {
        EXPECT_EQ(reason, MaskReason::not_skin) << l << "," << s;
        EXPECT_TRUE(std::isnan(answer[0]));
        continue;
      }
      ASSERT_EQ(reason, MaskReason::skin) << l << "," << s;
      ++skin;
      const Params truth = truth_at(l, s);
      std::vector<double> spectrum(values.bands);
      for (std::size_t b = 0; b < values.bands; ++b) spectrum[b] = values.values[(l * kSide + s) * values.bands + b];
      const auto fit = fitter.fit(*Spectrum::create(values.wavelength_nm, spectrum), options);
      ASSERT_TRUE(fit) << fit.error();
      // Never worse than `skinspec fit`; where that found the same minimum, the same answer.
      const auto rmse = static_cast<double>(answer[2 * kExtendedParamCount]);
      EXPECT_LE(rmse, fit->rmse * (1 + 1e-4)) << l << "," << s;
      const bool same_minimum = rmse >= fit->rmse * (1 - 1e-4);
      better_than_fit += same_minimum ? 0 : 1;
      for (std::size_t p = 0; p < truth.size(); ++p) {
        const float value = answer[2 * p], error = answer[2 * p + 1];
        const auto name = model_spec(kModel).params[p].name;
        if (same_minimum) {
          EXPECT_EQ(std::isnan(value), !fit->determination[p].determined()) << name << " at " << l << "," << s;
          if (!std::isnan(value)) {
            EXPECT_NEAR(value, fit->params[p], fit->standard_error[p]) << name << " at " << l << "," << s;
          }
        }
        if (std::isnan(value)) continue;
        melanin_determined += p == kMelanin ? 1 : 0;
        // docs/maps.md: within five standard errors plus the precision it counts as determined at.
        const ParamSpec& spec = model_spec(kModel).params[p];
        const double precision = std::max(spec.precision_absolute, spec.precision_relative * truth[p]);
        EXPECT_NEAR(value, truth[p], 5 * static_cast<double>(error) + precision) << name << " at " << l << "," << s;
      }
    }
  EXPECT_EQ(skin, (kSide - 2 * kBorder) * (kSide - 2 * kBorder));
  EXPECT_EQ(mapped.tally.pixels[static_cast<std::size_t>(MaskReason::skin)], skin);
  EXPECT_EQ(mapped.tally.pixels[static_cast<std::size_t>(MaskReason::not_skin)], kSide * kSide - skin);
  EXPECT_EQ(melanin_determined, skin);
  // Before the fit solved again from a dermal scattering on its upper bound (fit/src/solver.cpp),
  // 14 pixels were better here than `skinspec fit`, which ended in that basin.
  RecordProperty("pixels_better_than_skinspec_fit", static_cast<int>(better_than_fit));
  EXPECT_EQ(better_than_fit, 0u);
}

// A pixel started from its neighbour's answer needs fewer solver steps than one started from
// the coarse search (docs/maps.md gives the figures).
TEST_F(MapsTest, NeighbourStartsTakeFewerSteps) {
  const auto cube = Cube::open(write_envi(dir_ / "truth", ground_truth_cube(), {}).string());
  ASSERT_TRUE(cube) << cube.error().what();
  const MappedCube started = map_cube(*cube, true), searched = map_cube(*cube, false);
  RecordProperty("steps_neighbour_starts", static_cast<int>(started.tally.iterations));
  RecordProperty("steps_coarse_search", static_cast<int>(searched.tally.iterations));
  EXPECT_GT(started.tally.started_from_neighbour, 0u);
  EXPECT_LT(started.tally.iterations, searched.tally.iterations);
}

// A camera's bands beyond the model's 380-780 nm (many reach 950 or 1000 nm) are read and
// ignored: the map is the one of the same cube cut at 780 nm.
TEST_F(MapsTest, BandsBeyondTheModelsRangeChangeNothing) {
  const CubeValues visible = ground_truth_cube();
  CubeValues wider{visible.lines, visible.samples, 0, visible.wavelength_nm, {}};
  for (double nm = 790; nm <= 950; nm += 10) wider.wavelength_nm.push_back(nm);
  wider.bands = wider.wavelength_nm.size();
  for (std::size_t p = 0; p < visible.lines * visible.samples; ++p) {
    for (std::size_t b = 0; b < visible.bands; ++b) wider.values.push_back(visible.values[p * visible.bands + b]);
    for (std::size_t b = visible.bands; b < wider.bands; ++b) wider.values.push_back(0.6);
  }
  const auto narrow_cube = Cube::open(write_envi(dir_ / "visible", visible, {}).string());
  const auto wide_cube = Cube::open(write_envi(dir_ / "wider", wider, {}).string());
  ASSERT_TRUE(narrow_cube && wide_cube);
  const MappedCube narrow = map_cube(*narrow_cube, true), wide = map_cube(*wide_cube, true);
  ASSERT_EQ(wide.answers.size(), narrow.answers.size());
  for (std::size_t i = 0; i < narrow.answers.size(); ++i) {
    if (std::isnan(narrow.answers[i])) {
      EXPECT_TRUE(std::isnan(wide.answers[i])) << i;
    } else {
      EXPECT_EQ(wide.answers[i], narrow.answers[i]) << i;
    }
  }
}

TEST_F(MapsTest, PixelsThatCannotBeFittedAreMaskedWithTheirReason) {
  const auto cube = Cube::open(write_envi(dir_ / "few", quantized_cube(1, 1), {}).string());
  ASSERT_TRUE(cube);
  const Fitter fitter(testing::shipped_optics(kModel), testing::colorimetry());
  MapOptions options;
  options.fit.model = kModel;
  const Mapper mapper(fitter, options, cube->info());
  const std::size_t n = cube->info().bands;
  const SkinOptics& optics = testing::shipped_optics(kModel);
  const SkinModel model(optics, *optics.site("forearm"), cube->info().wavelength_nm, true);
  const Params skin_params = truth_at(5, 5);
  std::vector<double> skin(n);
  for (std::size_t b = 0; b < n; ++b) skin[b] = model.reflectance_at(b, skin_params.data());
  EXPECT_EQ(mapper.judge(skin, false), MaskReason::skin);
  EXPECT_EQ(mapper.judge(skin, true), MaskReason::saturated);
  auto glare = skin;
  glare[n / 2] = 1.2;
  EXPECT_EQ(mapper.judge(glare, false), MaskReason::saturated);
  auto gap = skin;
  gap[3] = std::nan("");
  EXPECT_EQ(mapper.judge(gap, false), MaskReason::no_data);
  std::vector<double> dark(n);
  for (std::size_t b = 0; b < n; ++b) dark[b] = skin[b] / 100;
  EXPECT_EQ(mapper.judge(dark, false), MaskReason::too_dark);
  EXPECT_EQ(mapper.judge(std::vector<double>(n, 0.4), false), MaskReason::not_skin);
}

// ---------------------------------------------------------------------------------------------
// The pictures' colour map and a picture.

// Linear sRGB to CIELAB with the IEC 61966-2-1 matrix to XYZ, written out here: the map's own
// conversion goes the other way, through spectral/'s matrix.
Lab lab_of_linear_srgb(const std::array<double, 3>& rgb) {
  const Xyz xyz{0.4124 * rgb[0] + 0.3576 * rgb[1] + 0.1805 * rgb[2],
                0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2],
                0.0193 * rgb[0] + 0.1192 * rgb[1] + 0.9505 * rgb[2]};
  return xyz_to_lab(xyz, {0.95047, 1.0, 1.08883});
}

TEST(ColourMap, IsInsideSrgbAndItsStepsLookAlike) {
  constexpr int kSteps = 256;
  std::vector<double> steps;
  double lightness = -1;
  for (int i = 0; i < kSteps; ++i) {
    const double t = static_cast<double>(i) / (kSteps - 1);
    const auto rgb = map_linear_srgb(t);
    for (const double c : rgb) {
      EXPECT_GE(c, -1e-9) << t;
      EXPECT_LE(c, 1 + 1e-9) << t;
    }
    const Lab lab = lab_of_linear_srgb(rgb);
    const LabColour intended = map_lab(t);
    EXPECT_NEAR(lab.l, intended.l, 0.01) << t;
    EXPECT_NEAR(lab.a, intended.a, 0.05) << t;
    EXPECT_NEAR(lab.b, intended.b, 0.05) << t;
    EXPECT_GT(lab.l, lightness) << t;  // reads dark to light, in grey too
    lightness = lab.l;
    if (i > 0) steps.push_back(delta_e2000(lab_of_linear_srgb(map_linear_srgb(t - 1.0 / (kSteps - 1))), lab));
  }
  // Equal steps of the map are equal in CIELAB by construction; in CIEDE2000, computed
  // independently (spectral/colour.hpp), they stay within a factor of kMostUneven of each other.
  constexpr double kMostUneven = 2.0;
  EXPECT_LT(std::ranges::max(steps) / std::ranges::min(steps), kMostUneven);
  RecordProperty("ciede2000_step_ratio", fmt::format("{:.3f}", std::ranges::max(steps) / std::ranges::min(steps)));
}

TEST(MapPicture, DrawsValuesNotDeterminedAndMaskedPixelsAndTheBar) {
  // One line of four pixels: the lowest value, the highest, not determined, not skin.
  const std::vector<float> values = {1.0f, 3.0f, std::nanf(""), std::nanf("")};
  const std::vector<float> mask = {0, 0, 0, static_cast<float>(MaskReason::not_skin)};
  const render::Image picture = parameter_picture(values, mask, 1, 4, {"melanin", "x 1 %"}, 1.0, 3.0);
  const int enlarge = 256 / 4, at_y = 8 + enlarge / 2;
  const auto near = [](const render::Rgb& got, const std::array<double, 3>& want) {
    return std::abs(static_cast<double>(got.r) - want[0]) < 1e-6 &&
           std::abs(static_cast<double>(got.g) - want[1]) < 1e-6 &&
           std::abs(static_cast<double>(got.b) - want[2]) < 1e-6;
  };
  EXPECT_TRUE(near(picture.at(8 + enlarge / 2, at_y), map_linear_srgb(0)));
  EXPECT_TRUE(near(picture.at(8 + enlarge + enlarge / 2, at_y), map_linear_srgb(1)));
  EXPECT_TRUE(near(picture.at(8 + 2 * enlarge + enlarge / 2, at_y), lab_to_linear_srgb(kNotDeterminedLab)));
  EXPECT_TRUE(near(picture.at(8 + 3 * enlarge + enlarge / 2, at_y), lab_to_linear_srgb(kMaskedLab)));
  // The bar, right of the map: a column 256 pixels high from the map's end down to its start.
  bool found = false;
  for (int x = 8 + 4 * enlarge; x < picture.width() && !found; ++x)
    for (int y = 0; y + 255 < picture.height() && !found; ++y)
      found = near(picture.at(x, y), map_linear_srgb(1)) && near(picture.at(x, y + 255), map_linear_srgb(0)) &&
              near(picture.at(x, y + 128), map_linear_srgb(1 - 128.0 / 255));
  EXPECT_TRUE(found) << "no colour bar";
}

}  // namespace
}  // namespace skinspec::maps
