#include "skinspec/spectral/colour.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "support/data.hpp"

namespace skinspec {
namespace {

using testing::colorimetry;
using ::testing::HasSubstr;

// ---------------------------------------------------------------------------------------------
// CIEDE2000

struct De2000Pair {
  Lab first, second;
  double delta_e;
};

// Sharma, Wu & Dalal (2005), "The CIEDE2000 color-difference formula: implementation notes,
// supplementary test data, and mathematical observations", Color Res. Appl. 30(1), Table 1.
constexpr De2000Pair kSharmaPairs[] = {
    {{50.0000, 2.6772, -79.7751}, {50.0000, 0.0000, -82.7485}, 2.0425},
    {{50.0000, 3.1571, -77.2803}, {50.0000, 0.0000, -82.7485}, 2.8615},
    {{50.0000, 2.8361, -74.0200}, {50.0000, 0.0000, -82.7485}, 3.4412},
    {{50.0000, -1.3802, -84.2814}, {50.0000, 0.0000, -82.7485}, 1.0000},
    {{50.0000, -1.1848, -84.8006}, {50.0000, 0.0000, -82.7485}, 1.0000},
    {{50.0000, -0.9009, -85.5211}, {50.0000, 0.0000, -82.7485}, 1.0000},
    {{50.0000, 0.0000, 0.0000}, {50.0000, -1.0000, 2.0000}, 2.3669},
    {{50.0000, -1.0000, 2.0000}, {50.0000, 0.0000, 0.0000}, 2.3669},
    {{50.0000, 2.4900, -0.0010}, {50.0000, -2.4900, 0.0009}, 7.1792},
    {{50.0000, 2.4900, -0.0010}, {50.0000, -2.4900, 0.0010}, 7.1792},
    {{50.0000, 2.4900, -0.0010}, {50.0000, -2.4900, 0.0011}, 7.2195},
    {{50.0000, 2.4900, -0.0010}, {50.0000, -2.4900, 0.0012}, 7.2195},
    {{50.0000, -0.0010, 2.4900}, {50.0000, 0.0009, -2.4900}, 4.8045},
    {{50.0000, -0.0010, 2.4900}, {50.0000, 0.0010, -2.4900}, 4.8045},
    {{50.0000, -0.0010, 2.4900}, {50.0000, 0.0011, -2.4900}, 4.7461},
    {{50.0000, 2.5000, 0.0000}, {50.0000, 0.0000, -2.5000}, 4.3065},
    {{50.0000, 2.5000, 0.0000}, {73.0000, 25.0000, -18.0000}, 27.1492},
    {{50.0000, 2.5000, 0.0000}, {61.0000, -5.0000, 29.0000}, 22.8977},
    {{50.0000, 2.5000, 0.0000}, {56.0000, -27.0000, -3.0000}, 31.9030},
    {{50.0000, 2.5000, 0.0000}, {58.0000, 24.0000, 15.0000}, 19.4535},
    {{50.0000, 2.5000, 0.0000}, {50.0000, 3.1736, 0.5854}, 1.0000},
    {{50.0000, 2.5000, 0.0000}, {50.0000, 3.2972, 0.0000}, 1.0000},
    {{50.0000, 2.5000, 0.0000}, {50.0000, 1.8634, 0.5757}, 1.0000},
    {{50.0000, 2.5000, 0.0000}, {50.0000, 3.2592, 0.3350}, 1.0000},
    {{60.2574, -34.0099, 36.2677}, {60.4626, -34.1751, 39.4387}, 1.2644},
    {{63.0109, -31.0961, -5.8663}, {62.8187, -29.7946, -4.0864}, 1.2630},
    {{61.2901, 3.7196, -5.3901}, {61.4292, 2.2480, -4.9620}, 1.8731},
    {{35.0831, -44.1164, 3.7933}, {35.0232, -40.0716, 1.5901}, 1.8645},
    {{22.7233, 20.0904, -46.6940}, {23.0331, 14.9730, -42.5619}, 2.0373},
    {{36.4612, 47.8580, 18.3852}, {36.2715, 50.5065, 21.2231}, 1.4146},
    {{90.8027, -2.0831, 1.4410}, {91.1528, -1.6435, 0.0447}, 1.4441},
    {{90.9257, -0.5406, -0.9208}, {88.6381, -0.8985, -0.7239}, 1.5381},
    {{6.7747, -0.2908, -2.4247}, {5.8714, -0.0985, -2.2286}, 0.6377},
    {{2.0776, 0.0795, -1.1350}, {0.9033, -0.0636, -0.5514}, 0.9082},
};
static_assert(std::size(kSharmaPairs) == 34);

// The published values carry four decimals, so a correct implementation is within half a unit
// of the last place; 1e-4 still catches any of the usual hue-angle mistakes, which move the
// result by 0.04 or more on pairs 9-16.
constexpr double kPublishedPrecision = 1e-4;

TEST(Ciede2000, MatchesAllPublishedSharmaPairs) {
  for (std::size_t i = 0; i < std::size(kSharmaPairs); ++i) {
    const auto& pair = kSharmaPairs[i];
    EXPECT_NEAR(delta_e2000(pair.first, pair.second), pair.delta_e, kPublishedPrecision) << "Sharma pair " << i + 1;
  }
}

TEST(Ciede2000, IsSymmetricInItsArguments) {
  for (std::size_t i = 0; i < std::size(kSharmaPairs); ++i) {
    const auto& pair = kSharmaPairs[i];
    EXPECT_NEAR(delta_e2000(pair.first, pair.second), delta_e2000(pair.second, pair.first), 1e-12)
        << "Sharma pair " << i + 1;
  }
}

TEST(Ciede2000, IsZeroForIdenticalColours) {
  EXPECT_EQ(delta_e2000({50, 0, 0}, {50, 0, 0}), 0.0);
  EXPECT_NEAR(delta_e2000({63.2, -12.5, 30.1}, {63.2, -12.5, 30.1}), 0.0, 1e-12);
}

TEST(Ciede2000, LightnessDifferenceAtMidGreyIsUnweighted) {
  // At L' = 50 and zero chroma S_L = 1, so a pure lightness step counts in full.
  EXPECT_NEAR(delta_e2000({49.5, 0, 0}, {50.5, 0, 0}), 1.0, 1e-12);
}

// ---------------------------------------------------------------------------------------------
// Tristimulus values from the CIE tables

Spectrum flat(double reflectance) { return *Spectrum::create({360, 830}, {reflectance, reflectance}); }

Spectrum named_illuminant(std::string_view name) {
  auto illuminant = colorimetry().illuminant(name);
  EXPECT_TRUE(illuminant) << illuminant.error();
  return *illuminant;
}

TEST(Colorimetry, D65WhitePointFromTheTables) {
  const Xyz white = colorimetry().white(named_illuminant("D65"));
  EXPECT_NEAR(white.x, 0.95047, 5e-5);
  EXPECT_DOUBLE_EQ(white.y, 1.0);
  EXPECT_NEAR(white.z, 1.08883, 5e-5);
}

TEST(Colorimetry, IlluminantAChromaticityFromTheTables) {
  const Xyz white = colorimetry().white(named_illuminant("A"));
  const double sum = white.x + white.y + white.z;
  EXPECT_NEAR(white.x / sum, 0.44757, 5e-5);
  EXPECT_NEAR(white.y / sum, 0.40744, 5e-5);
  EXPECT_DOUBLE_EQ(white.y, 1.0);
}

TEST(Colorimetry, PerfectReflectorIsTheWhitePoint) {
  for (const auto name : {"D65", "A"}) {
    const Spectrum illuminant = named_illuminant(name);
    const Xyz white = colorimetry().white(illuminant);
    const Xyz reflector = colorimetry().xyz(flat(1.0), illuminant);
    EXPECT_NEAR(reflector.x, white.x, 1e-12) << name;
    EXPECT_NEAR(reflector.y, white.y, 1e-12) << name;
    EXPECT_NEAR(reflector.z, white.z, 1e-12) << name;
    const Lab lab = colorimetry().lab(flat(1.0), illuminant);
    EXPECT_NEAR(lab.l, 100, 1e-9) << name;
    EXPECT_NEAR(lab.a, 0, 1e-9) << name;
    EXPECT_NEAR(lab.b, 0, 1e-9) << name;
  }
}

TEST(Colorimetry, PerfectReflectorUnderD65IsSrgbWhite) {
  const Xyz xyz = colorimetry().xyz(flat(1.0), named_illuminant("D65"));
  const auto rgb = xyz_to_linear_srgb(xyz);
  EXPECT_NEAR(rgb[0], 1.0, 1e-3);
  EXPECT_NEAR(rgb[1], 1.0, 1e-3);
  EXPECT_NEAR(rgb[2], 1.0, 1e-3);
  EXPECT_EQ(srgb_8bit(rgb), (std::array<int, 3>{255, 255, 255}));
}

TEST(Colorimetry, EighteenPercentGreyLightness) {
  const Lab grey = colorimetry().lab(flat(0.18), named_illuminant("D65"));
  EXPECT_NEAR(grey.l, 116 * std::cbrt(0.18) - 16, 1e-9);  // 49.496
  EXPECT_NEAR(grey.l, 49.496, 1e-3);
  EXPECT_NEAR(grey.a, 0, 1e-9);
  EXPECT_NEAR(grey.b, 0, 1e-9);
}

TEST(Colorimetry, ReflectanceIsHeldConstantPastItsEnds) {
  // A sample measured only over 400-700 nm counts as flat outside, so a constant 0.5 there
  // gives Y = 0.5 over the whole observer range.
  const auto measured = *Spectrum::create({400, 550, 700}, {0.5, 0.5, 0.5});
  const Xyz xyz = colorimetry().xyz(measured, named_illuminant("D65"));
  EXPECT_NEAR(xyz.y, 0.5, 1e-12);
}

TEST(Colorimetry, ReflectanceIsInterpolatedLinearly) {
  // Linear in wavelength from 0 at 360 nm to 1 at 830 nm, given by its two end samples only:
  // the same as a 1 nm tabulation of that ramp.
  const auto ramp = *Spectrum::create({360, 830}, {0, 1});
  std::vector<double> grid = Spectrum::uniform_grid(360, 830, 1);
  std::vector<double> values;
  for (const double w : grid) values.push_back((w - 360) / 470);
  const auto tabulated = *Spectrum::create(grid, values);
  const Spectrum d65 = named_illuminant("D65");
  EXPECT_NEAR(colorimetry().xyz(ramp, d65).x, colorimetry().xyz(tabulated, d65).x, 1e-12);
  // And the long-wavelength end of a ramp is redder than the short one.
  EXPECT_GT(colorimetry().lab(ramp, d65).a, 0);
}

// The tristimulus sums written out: the spectrum at each nanometre of the observer's range
// (Spectrum::at, which interpolates on its own), times the weighting there.
Xyz summed_at_each_nm(const Spectrum& spectrum, const ColourWeighting& w) {
  Xyz sum;
  for (std::size_t i = 0; i < w.x.size(); ++i) {
    const double value = spectrum.at(360.0 + static_cast<double>(i));
    sum.x += value * w.x[i];
    sum.y += value * w.y[i];
    sum.z += value * w.z[i];
  }
  return sum;
}

// The weighting carried onto a grid gives each spectrum on it the colour of the sums at each
// nanometre, as the spectrum itself does: on the meter's grid, on one past both ends of the
// observer's range, on an uneven one and on one of two samples.
TEST(Colorimetry, WeightingOnTheSamplesGivesTheColourOfTheSpectrum) {
  const ColourWeighting d65 = colorimetry().weighting(named_illuminant("D65"));
  const std::vector<std::vector<double>> grids = {Spectrum::uniform_grid(380, 780, 4),
                                                  Spectrum::uniform_grid(340, 850, 10),
                                                  {361.5, 400, 402, 555.25, 600, 700.5, 829},
                                                  {500, 510}};
  for (const auto& grid : grids) {
    const SampledWeighting on = Colorimetry::on_samples(grid, d65);
    ASSERT_EQ(on.x.size(), grid.size());
    for (const double phase : {0.0, 1.3, 2.9}) {
      std::vector<double> values;
      for (const double w : grid) values.push_back(0.4 + 0.3 * std::sin(w / 37 + phase));
      const Spectrum spectrum = *Spectrum::create(grid, values);
      const Xyz want = summed_at_each_nm(spectrum, d65);
      for (const Xyz& got : {Colorimetry::xyz(values, on), Colorimetry::xyz(spectrum, d65)}) {
        EXPECT_NEAR(got.x, want.x, 1e-13 * want.x) << grid.front() << "-" << grid.back() << " nm";
        EXPECT_NEAR(got.y, want.y, 1e-13 * want.y) << grid.front() << "-" << grid.back() << " nm";
        EXPECT_NEAR(got.z, want.z, 1e-13 * want.z) << grid.front() << "-" << grid.back() << " nm";
      }
      const Lab lab = Colorimetry::lab(values, on), want_lab = Colorimetry::lab(*Spectrum::create(grid, values), d65);
      EXPECT_NEAR(delta_e2000(want_lab, lab), 0, 1e-12);
    }
  }
}

// Two spectra's colours taken side by side are each one's own, to the bit.
TEST(Colorimetry, TheLabsOfTwoSpectraAreEachOnesLab) {
  const std::vector<double> grid = Spectrum::uniform_grid(380, 780, 4);
  const SampledWeighting on = Colorimetry::on_samples(grid, colorimetry().weighting(named_illuminant("D65")));
  std::vector<double> first, second;
  for (const double w : grid) {
    first.push_back(0.4 + 0.3 * std::sin(w / 37));
    second.push_back(0.2 + 0.1 * std::cos(w / 23));
  }
  const auto [a, b] = Colorimetry::labs(first, second, on);
  const auto same = [](const Lab& x, const Lab& y) { return x.l == y.l && x.a == y.a && x.b == y.b; };
  EXPECT_TRUE(same(a, Colorimetry::lab(first, on)));
  EXPECT_TRUE(same(b, Colorimetry::lab(second, on)));
  EXPECT_GT(delta_e2000(a, b), 1);
}

TEST(Colorimetry, UnknownIlluminantListsTheKnownOnes) {
  const auto result = colorimetry().illuminant("F2");
  ASSERT_FALSE(result);
  EXPECT_THAT(result.error(), HasSubstr("F2"));
  EXPECT_THAT(result.error(), HasSubstr("D65"));
  EXPECT_THAT(result.error(), HasSubstr("A"));
}

// ---------------------------------------------------------------------------------------------
// Validation of the tables

std::string table_text(const std::string& header, const std::string& rows) {
  return "# title: t\n# source: s\n# licence: l\n# units: u\n" + header + "\n" + rows;
}

Table parsed(const std::string& bytes, std::string_view source) {
  auto table = parse_table(bytes, source, {});
  EXPECT_TRUE(table) << table.error().what();
  return *table;
}

const std::string kFullRange = "360,1,1,1\n830,1,1,1\n";

TEST(ColorimetryTables, MissingCmfColumnIsNamedWithTheTable) {
  const Table cmf = parsed(table_text("wavelength_nm,xbar,ybar", "360,1,1\n830,1,1\n"), "cmf.csv");
  const auto result = Colorimetry::from_tables(cmf, testing::table("colour/cie_illuminants.csv"));
  ASSERT_FALSE(result);
  EXPECT_EQ(result.error().source, "cmf.csv");
  EXPECT_THAT(result.error().message, HasSubstr("missing column 'zbar'"));
}

TEST(ColorimetryTables, MissingIlluminantColumnIsNamedWithTheTable) {
  const Table illuminants = parsed(table_text("wavelength_nm,D65", "360,1\n830,1\n"), "ill.csv");
  const auto result = Colorimetry::from_tables(testing::table("colour/cie1931_2deg_cmf.csv"), illuminants);
  ASSERT_FALSE(result);
  EXPECT_EQ(result.error().source, "ill.csv");
  EXPECT_THAT(result.error().message, HasSubstr("missing column 'A'"));
}

TEST(ColorimetryTables, MissingWavelengthColumnIsRefused) {
  const Table cmf = parsed(table_text("nm,xbar,ybar,zbar", kFullRange), "cmf.csv");
  const auto result = Colorimetry::from_tables(cmf, testing::table("colour/cie_illuminants.csv"));
  ASSERT_FALSE(result);
  EXPECT_THAT(result.error().message, HasSubstr("missing column 'wavelength_nm'"));
}

TEST(ColorimetryTables, TableShortOfTheObserverRangeIsRefused) {
  const Table illuminants = parsed(table_text("wavelength_nm,D65,A", "380,1,1\n780,1,1\n"), "ill.csv");
  const auto result = Colorimetry::from_tables(testing::table("colour/cie1931_2deg_cmf.csv"), illuminants);
  ASSERT_FALSE(result);
  EXPECT_EQ(result.error().source, "ill.csv");
  EXPECT_THAT(result.error().message, HasSubstr("D65"));
}

TEST(ColorimetryTables, WellFormedTablesAreAccepted) {
  const Table cmf = parsed(table_text("wavelength_nm,xbar,ybar,zbar", kFullRange), "cmf.csv");
  const Table illuminants = parsed(table_text("wavelength_nm,D65,A", "360,1,1\n830,1,1\n"), "ill.csv");
  const auto result = Colorimetry::from_tables(cmf, illuminants);
  ASSERT_TRUE(result) << result.error().what();
  // Equal-energy observer and illuminant: every flat reflectance is its own X = Y = Z.
  const Xyz xyz = result->xyz(flat(0.25), *result->illuminant("D65"));
  EXPECT_NEAR(xyz.x, 0.25, 1e-12);
  EXPECT_NEAR(xyz.y, 0.25, 1e-12);
  EXPECT_NEAR(xyz.z, 0.25, 1e-12);
}

// ---------------------------------------------------------------------------------------------
// CIELAB

TEST(Cielab, CubeRootBranchAboveTheThreshold) {
  const Xyz white{0.95047, 1.0, 1.08883};
  const Lab lab = xyz_to_lab({0.5 * 0.95047, 0.5, 0.5 * 1.08883}, white);
  EXPECT_NEAR(lab.l, 116 * std::cbrt(0.5) - 16, 1e-12);
  EXPECT_NEAR(lab.a, 0, 1e-12);
  EXPECT_NEAR(lab.b, 0, 1e-12);
}

TEST(Cielab, LinearBranchNearBlack) {
  // Below (6/29)^3 = 0.008856, L* = (29/3)^3 Y = 903.3 Y.
  const Xyz white{1, 1, 1};
  EXPECT_NEAR(xyz_to_lab({0.001, 0.001, 0.001}, white).l, std::pow(29.0 / 3, 3) * 0.001, 1e-12);
  EXPECT_NEAR(xyz_to_lab({0, 0, 0}, white).l, 0, 1e-12);
  // The two branches meet at the threshold.
  const double t = std::pow(6.0 / 29, 3);
  const double below = xyz_to_lab({t, t * (1 - 1e-12), t}, white).l;
  EXPECT_NEAR(below, 8.0, 1e-9);
  EXPECT_NEAR(xyz_to_lab({t, t * (1 + 1e-12), t}, white).l, 8.0, 1e-9);
}

TEST(Cielab, OpponentAxesHaveTheRightSigns) {
  const Xyz white{1, 1, 1};
  EXPECT_GT(xyz_to_lab({0.6, 0.5, 0.5}, white).a, 0);  // more X than Y: red
  EXPECT_LT(xyz_to_lab({0.5, 0.5, 0.6}, white).b, 0);  // more Z than Y: blue
}

// ---------------------------------------------------------------------------------------------
// sRGB

TEST(Srgb, MatrixIsTheIec61966Matrix) {
  const auto r = xyz_to_linear_srgb({1, 0, 0});
  const auto g = xyz_to_linear_srgb({0, 1, 0});
  const auto b = xyz_to_linear_srgb({0, 0, 1});
  EXPECT_EQ(r, (std::array<double, 3>{3.2406, -0.9689, 0.0557}));
  EXPECT_EQ(g, (std::array<double, 3>{-1.5372, 1.8758, -0.2040}));
  EXPECT_EQ(b, (std::array<double, 3>{-0.4986, 0.0415, 1.0570}));
  // Not clipped: out-of-gamut colours keep their negative components.
  EXPECT_LT(xyz_to_linear_srgb({0, 0, 1})[0], 0);
}

TEST(Srgb, EncodeLinearBranchAndThreshold) {
  EXPECT_EQ(srgb_encode(0), 0);
  EXPECT_DOUBLE_EQ(srgb_encode(0.001), 0.01292);
  EXPECT_DOUBLE_EQ(srgb_encode(0.0031308), 12.92 * 0.0031308);
  // The power branch starts just above and the curve is continuous there.
  const double above = 0.0031308 * (1 + 1e-9);
  EXPECT_DOUBLE_EQ(srgb_encode(above), 1.055 * std::pow(above, 1 / 2.4) - 0.055);
  EXPECT_NEAR(srgb_encode(above), 12.92 * 0.0031308, 1e-7);
}

TEST(Srgb, EncodePowerBranch) {
  EXPECT_DOUBLE_EQ(srgb_encode(0.5), 1.055 * std::pow(0.5, 1 / 2.4) - 0.055);
  EXPECT_NEAR(srgb_encode(0.5), 0.735357, 1e-6);
  EXPECT_DOUBLE_EQ(srgb_encode(1), 1);
}

TEST(Srgb, DecodeBranchesAndThreshold) {
  EXPECT_DOUBLE_EQ(srgb_decode(0.04045), 0.04045 / 12.92);
  EXPECT_DOUBLE_EQ(srgb_decode(0.02), 0.02 / 12.92);
  EXPECT_DOUBLE_EQ(srgb_decode(0.5), std::pow(0.555 / 1.055, 2.4));
  EXPECT_NEAR(srgb_decode(0.5), 0.214041, 1e-6);
  EXPECT_DOUBLE_EQ(srgb_decode(1), 1);
  EXPECT_NEAR(srgb_decode(0.04045 * (1 + 1e-9)), 0.04045 / 12.92, 1e-8);
}

TEST(Srgb, EncodeDecodeRoundTrip) {
  for (int i = 0; i <= 1000; ++i) {
    const double linear = i / 1000.0;
    EXPECT_NEAR(srgb_decode(srgb_encode(linear)), linear, 1e-12) << linear;
    const double encoded = i / 1000.0;
    EXPECT_NEAR(srgb_encode(srgb_decode(encoded)), encoded, 1e-12) << encoded;
  }
}

TEST(Srgb, ClipsOutOfRangeInput) {
  EXPECT_EQ(srgb_encode(-0.2), 0);
  EXPECT_DOUBLE_EQ(srgb_encode(1.7), 1);
  EXPECT_EQ(srgb_decode(-0.2), 0);
  EXPECT_EQ(srgb_decode(1.7), 1);
  EXPECT_EQ(srgb_encode(std::numeric_limits<double>::quiet_NaN()), 0);
}

TEST(Srgb, EightBitCodesAreClippedAndRounded) {
  EXPECT_EQ(srgb_8bit({-0.2, 0.5, 1.7}), (std::array<int, 3>{0, 188, 255}));  // 0.5 -> 187.52
  EXPECT_EQ(srgb_8bit({0, 1, 0.2140}), (std::array<int, 3>{0, 255, 127}));
  EXPECT_EQ(srgb_8bit({0.2159, 0.0, 0.0}), (std::array<int, 3>{128, 0, 0}));
}

}  // namespace
}  // namespace skinspec
