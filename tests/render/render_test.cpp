// The renderer against the seed paper's equations: a flat patch against the colour of
// R(lambda) E(lambda) computed directly, white under D65 and A, the specular highlight's
// position, the Fresnel and geometric terms at their limits, shadows, and the pigments' effect.

#include <gtest/gtest.h>

#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include "skinspec/render/figures.hpp"
#include "skinspec/render/png.hpp"
#include "skinspec/render/scenes.hpp"
#include "support/data.hpp"
#include "support/png_reader.hpp"

namespace skinspec::render {
namespace {

const Params kForearm{0.04, 5, 6, 3, 1};

Site forearm() { return *testing::shipped_optics().site("forearm"); }
Spectrum d65() { return *testing::colorimetry().illuminant("D65"); }
Spectrum illuminant_a() { return *testing::colorimetry().illuminant("A"); }
Spectrum perfect_white() { return *Spectrum::create({380, 780}, {1, 1}); }

// A square in the z = 0 plane facing +z, `half` wide either way from (cx, cy).
Mesh square(double cx, double cy, double z, double half) {
  Mesh m;
  m.positions = {
      {cx - half, cy - half, z}, {cx + half, cy - half, z}, {cx + half, cy + half, z}, {cx - half, cy + half, z}};
  m.triangles = {{0, 1, 2}, {0, 2, 3}};
  return with_vertex_normals(std::move(m));
}

// A camera far up the z axis with a narrow field: nearly orthographic, so a pixel's world x
// and y follow from its column and row (see world_of).
constexpr double kDistance = 1000, kHalfView = 1.5;
Camera overhead() {
  return {{0, 0, kDistance}, {0, 0, 0}, {0, 1, 0}, 2 * std::atan(kHalfView / kDistance) * 180 / std::numbers::pi};
}
std::pair<double, double> world_of(int px, int py, int size) {
  return {(2.0 * (px + 0.5) / size - 1) * kHalfView, (1 - 2.0 * (py + 0.5) / size) * kHalfView};
}
int column_of(double x, int size) { return static_cast<int>((x / kHalfView + 1) / 2 * size); }

RenderSettings settings(int size, double alpha, double beta) {
  RenderSettings s;
  s.width = s.height = size;
  s.surface.alpha = alpha;
  s.surface.beta = beta;
  return s;
}

Light overhead_light() { return {Light::Kind::directional, {0, 0, 1}, 1.0}; }

std::array<int, 3> code_of(const Rgb& linear) {
  return srgb_8bit({static_cast<double>(linear.r), static_cast<double>(linear.g), static_cast<double>(linear.b)});
}

Image render_patch(const Spectrum& reflectance, const Spectrum& illuminant) {
  const Scene scene{square(0, 0, 0, 10), overhead(), {overhead_light()}};
  return *render(scene, spectral_colours(testing::colorimetry(), reflectance, illuminant), settings(8, 1, 0));
}

TEST(RenderColour, FlatPatchIsTheSrgbOfReflectanceTimesIlluminant) {
  const auto grid = Spectrum::uniform_grid(380, 780, 1);
  const SkinModel model(testing::shipped_optics(), forearm(), grid, false);
  const Spectrum skin = *Spectrum::create(grid, model.reflectance(kForearm));
  const auto expected = srgb_8bit(xyz_to_linear_srgb(testing::colorimetry().xyz(skin, d65())));

  const Image image = render_patch(skin_reflectance_spectrum(testing::shipped_optics(), forearm(), kForearm), d65());
  const auto png = testing::decode_png([&] {
    const auto bytes = *encode_png(image, 8);
    return std::string(bytes.begin(), bytes.end());
  }());
  ASSERT_TRUE(png.has_value());
  for (int y = 0; y < image.height(); ++y)
    for (int x = 0; x < image.width(); ++x)
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(png->pixel(x, y)[c], expected[c], 1) << x << "," << y << " channel " << c;
  // Skin, not grey: red well above blue.
  EXPECT_GT(expected[0], expected[2] + 20);
}

TEST(RenderColour, WhitePatchIsWhiteUnderD65AndWarmerUnderA) {
  const Image under_d65 = render_patch(perfect_white(), d65());
  for (const int c : code_of(under_d65.at(4, 4))) EXPECT_NEAR(c, 255, 1);
  const Image under_a = render_patch(perfect_white(), illuminant_a());
  const Rgb d = under_d65.at(4, 4), a = under_a.at(4, 4);
  EXPECT_GT(a.r / a.b, 1.5f * d.r / d.b);
}

TEST(RenderGeometry, SpecularHighlightSitsWhereTheNormalBisectsLightAndView) {
  constexpr int kSize = 160;
  const Vec3 to_light = normalized({0.6, 0.3, 1.0});
  const Scene scene{sphere({0, 0, 0}, 1.0, 128), overhead(), {{Light::Kind::directional, to_light, 1.0}}};
  RenderSettings s = settings(kSize, 0, 1);
  s.surface.roughness = 0.08;
  const Image image = *render(scene, spectral_colours(testing::colorimetry(), perfect_white(), d65()), s);
  int best_x = 0, best_y = 0;
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x)
      if (image.at(x, y).g > image.at(best_x, best_y).g) std::tie(best_x, best_y) = std::pair{x, y};
  const auto [wx, wy] = world_of(best_x, best_y, kSize);
  const Vec3 normal{wx, wy, std::sqrt(std::max(0.0, 1 - wx * wx - wy * wy))};
  const Vec3 bisector = normalized(to_light + Vec3{0, 0, 1});
  const double degrees = std::acos(std::min(1.0, dot(normal, bisector))) * 180 / std::numbers::pi;
  EXPECT_LT(degrees, 2.0) << "brightest pixel " << best_x << "," << best_y;
  EXPECT_GT(image.at(best_x, best_y).g, 0.01f);
  // The mirror point of the light lies up and to the right: the lower left stays dark.
  EXPECT_LT(image.at(kSize / 2 - 30, kSize / 2 + 30).g, image.at(best_x, best_y).g * 0.01f);
}

TEST(RenderGeometry, ShadowsFallWhereAnOccluderBlocksTheLight) {
  constexpr int kSize = 120;
  // Light from +x at 45 degrees: the square at height 1 over x in [0.6, 1.0] shades x in
  // [-0.4, 0.0] of the floor, and the camera overhead sees that strip beside it.
  Mesh mesh = square(0, 0, 0, 20);
  mesh.append(square(0.8, 0, 1, 0.2));
  const Scene scene{mesh, overhead(), {{Light::Kind::directional, {1, 0, 1}, 1.0}}};
  const auto colours = spectral_colours(testing::colorimetry(), perfect_white(), d65());
  RenderSettings s = settings(kSize, 1, 0);
  const Image shadowed = *render(scene, colours, s);
  s.shadows = false;
  const Image unshadowed = *render(scene, colours, s);
  const int row = kSize / 2, in_shadow = column_of(-0.2, kSize), lit = column_of(-1.0, kSize);
  EXPECT_LT(shadowed.at(in_shadow, row).g, 0.001f);
  EXPECT_NEAR(unshadowed.at(in_shadow, row).g, shadowed.at(lit, row).g, 1e-4);
  EXPECT_NEAR(shadowed.at(lit, row).g, std::sqrt(0.5), 0.01);  // N.L = cos 45 degrees
}

TEST(TorranceSparrow, FacetDistributionHalvesAtTheRoughness) {
  EXPECT_DOUBLE_EQ(facet_distribution(0, 0.3), 1.0);
  EXPECT_NEAR(facet_distribution(0.3, 0.3), 0.5, 1e-12);
  EXPECT_NEAR(facet_distribution(0.6, 0.3), 0.0625, 1e-12);
}

TEST(TorranceSparrow, FresnelGoesFromTheNormalValueToOneAtGrazing) {
  for (const double n : {1.33, 1.4, 1.55}) {
    EXPECT_NEAR(fresnel(1.0, n), std::pow((n - 1) / (n + 1), 2), 1e-12) << n;
    EXPECT_NEAR(fresnel(1e-6, n), 1.0, 1e-4) << n;
    double previous = fresnel(1.0, n);
    for (double c = 0.95; c > 0.01; c -= 0.05) {
      EXPECT_GT(fresnel(c, n), previous) << "n " << n << " cos " << c;
      previous = fresnel(c, n);
    }
  }
}

TEST(TorranceSparrow, GeometricAttenuationIsOneHeadOnAndVanishesAtGrazing) {
  EXPECT_DOUBLE_EQ(geometric_attenuation(1, 1, 1, 1), 1.0);
  // Light grazing the surface: the masking term 2 cos(phi) cos(theta_i) / cos(theta_Q) rules.
  const Vec3 n{0, 0, 1}, v{0, 0, 1};
  for (const double grazing_degrees : {80.0, 85.0, 89.0, 89.9}) {
    const double t = grazing_degrees * std::numbers::pi / 180;
    const Vec3 l{std::sin(t), 0, std::cos(t)};
    const Vec3 q = normalized(l + v);
    const double g = geometric_attenuation(dot(n, q), dot(n, v), dot(n, l), dot(l, q));
    EXPECT_NEAR(g, 2 * dot(n, q) * std::cos(t) / dot(l, q), 1e-12);
    EXPECT_LT(g, 2.5 * std::cos(t));
  }
  // Symmetric in the light and the viewer.
  EXPECT_DOUBLE_EQ(geometric_attenuation(0.9, 0.3, 0.7, 0.8), geometric_attenuation(0.9, 0.7, 0.3, 0.8));
}

TEST(TorranceSparrow, NothingFromBehindTheSurface) {
  const Shading s = torrance_sparrow({0, 0, 1}, {0, 0.6, -0.8}, {0, 0, 1}, {});
  EXPECT_EQ(s.body, 0);
  EXPECT_EQ(s.specular, 0);
}

Lab skin_lab(const PigmentScales& scales) {
  const Params p = *scaled_params(ModelKind::paper, kForearm, scales);
  return testing::colorimetry().lab(skin_reflectance_spectrum(testing::shipped_optics(), forearm(), p), d65());
}

TEST(RenderPigments, FourTimesTheMelaninIsDarker) { EXPECT_LT(skin_lab({4, 1, 1, 1}).l, skin_lab({}).l - 5); }

TEST(RenderPigments, TenTimesTheBilirubinIsYellower) { EXPECT_GT(skin_lab({1, 1, 1, 10}).b, skin_lab({}).b + 3); }

TEST(RenderPigments, MelaninDarkensTheRenderedHand) {
  const auto& c = testing::colorimetry();
  const Scene scene = builtin_scene(SceneKind::hand, 1.0);
  const Skin skin{forearm(), kForearm};
  const auto mean_green = [&](const PigmentScales& scales) {
    const Image image = *render_skin(testing::shipped_optics(), c, skin, scales, d65(), scene, settings(48, 1, 4));
    double sum = 0;
    for (int y = 0; y < 48; ++y)
      for (int x = 0; x < 48; ++x) sum += static_cast<double>(image.at(x, y).g);
    return sum;
  };
  EXPECT_LT(mean_green({4, 1, 1, 1}), 0.8 * mean_green({}));
}

TEST(RenderPigments, ExtendedScalesTheBloodItsOxyAndDeoxyHaemoglobinStandFor) {
  const Params p = {0.04, 5, 4, 0.75, 1, 30, 1.3};
  const auto both = *scaled_params(ModelKind::extended, p, {1, 2, 2, 1});
  EXPECT_DOUBLE_EQ(both[kTotalHemoglobin], 8);
  EXPECT_DOUBLE_EQ(both[kOxygenSaturation], 0.75);
  const auto more_oxy = *scaled_params(ModelKind::extended, p, {1, 3, 1, 1});  // oxy 9, deoxy 1
  EXPECT_DOUBLE_EQ(more_oxy[kTotalHemoglobin], 10);
  EXPECT_DOUBLE_EQ(more_oxy[kOxygenSaturation], 0.9);
  const auto darker = *scaled_params(ModelKind::extended, p, {4, 1, 1, 10});
  EXPECT_DOUBLE_EQ(darker[kMelanin], 20);
  EXPECT_DOUBLE_EQ(darker[kBilirubin], 10);
  EXPECT_EQ(darker[kDermisScattering], 30);
  EXPECT_FALSE(scaled_params(ModelKind::extended, {0.04, 5, 4, 1.5, 1, 30, 1.3}, {}));  // saturation above 1
  EXPECT_FALSE(scaled_params(ModelKind::extended, kForearm, {}));                       // the paper's five
}

// A render changes the model's own parameters: an amount scaled (held to its domain), anything
// set within its domain; a fraction is never scaled.
TEST(RenderChanges, SetOrScaleTheModelsOwnParameters) {
  using Kind = ParamChange::Kind;
  const Params p = {0.04, 5, 4, 0.75, 1, 30, 1.3};
  const ParamChange changes[] = {
      {kMelanin, Kind::scale, 2}, {kOxygenSaturation, Kind::value, 0.4}, {kDermisScattering, Kind::value, 60}};
  const auto changed = changed_params(ModelKind::extended, p, changes);
  ASSERT_TRUE(changed) << changed.error();
  EXPECT_EQ(*changed, (Params{0.04, 10, 4, 0.4, 1, 60, 1.3}));
  EXPECT_EQ(*changed_params(ModelKind::extended, p, {}), p);
  // A product beyond the domain is held to it.
  const ParamChange lots[] = {{kTotalHemoglobin, Kind::scale, 100}};
  EXPECT_EQ((*changed_params(ModelKind::extended, {0.04, 5, 500, 0.75, 1, 30, 1.3}, lots))[kTotalHemoglobin],
            model_spec(ModelKind::extended).params[kTotalHemoglobin].domain_upper);
  // The paper's haemoglobins as before.
  const ParamChange paper[] = {{kOxyhemoglobin, Kind::scale, 2}, {kDeoxyhemoglobin, Kind::value, 0}};
  EXPECT_EQ(*changed_params(ModelKind::paper, kForearm, paper), (Params{0.04, 5, 12, 0, 1}));

  EXPECT_TRUE(param_change(ModelKind::extended, kOxygenSaturation, Kind::value, 1));
  EXPECT_TRUE(param_change(ModelKind::extended, kOxygenSaturation, Kind::value, 0));
  for (const double bad : {1.01, -0.01, std::nan("")})
    EXPECT_FALSE(param_change(ModelKind::extended, kOxygenSaturation, Kind::value, bad)) << bad;
  const auto scaled_fraction = param_change(ModelKind::extended, kOxygenSaturation, Kind::scale, 1.5);
  ASSERT_FALSE(scaled_fraction);
  EXPECT_NE(scaled_fraction.error().find("not an amount"), std::string::npos) << scaled_fraction.error();
  EXPECT_FALSE(param_change(ModelKind::extended, kDermisScattering, Kind::scale, 2));
  EXPECT_FALSE(param_change(ModelKind::extended, kMelanin, Kind::scale, kMaxPigmentScale + 1));
  EXPECT_FALSE(param_change(ModelKind::extended, kMelanin, Kind::scale, -1));
  EXPECT_FALSE(param_change(ModelKind::extended, kDermisScattering, Kind::value, 0));
  EXPECT_FALSE(param_change(ModelKind::paper, kDermisScattering, Kind::value, 30));  // the paper has five
  const ParamChange out_of_domain[] = {{kOxygenSaturation, Kind::value, 2}};
  EXPECT_FALSE(changed_params(ModelKind::extended, p, out_of_domain));
  EXPECT_FALSE(changed_params(ModelKind::extended, kForearm, {}));  // the paper's five
}

TEST(RenderChanges, OxygenatedBloodIsRedderThanDeoxygenated) {
  const Site site = forearm();
  const auto lab = [&](double saturation) {
    const ParamChange set[] = {{kOxygenSaturation, ParamChange::Kind::value, saturation}};
    const Params p = *changed_params(ModelKind::extended, {0.04, 5, 8, 0.75, 1, 30, 1.3}, set);
    return testing::colorimetry().lab(skin_reflectance_spectrum(testing::shipped_optics(ModelKind::extended), site, p),
                                      d65());
  };
  EXPECT_GT(lab(1).a, lab(0).a + 1);
}

TEST(RenderPigments, ASkinIsRenderedOnlyWithItsModelsOptics) {
  const Skin skin{forearm(), {0.04, 5, 4, 0.75, 1, 30, 1.3}, ModelKind::extended};
  const Scene scene = builtin_scene(SceneKind::sphere, 1.0);
  const auto& c = testing::colorimetry();
  EXPECT_TRUE(render_skin(testing::shipped_optics(ModelKind::extended), c, skin, {}, d65(), scene, settings(8, 1, 2)));
  const auto wrong =
      render_skin(testing::shipped_optics(ModelKind::paper), c, skin, {}, d65(), scene, settings(8, 1, 2));
  ASSERT_FALSE(wrong);
  EXPECT_NE(wrong.error().find("extended"), std::string::npos);
}

TEST(RenderInput, RefusesBadScalesSizesAndSurfaces) {
  EXPECT_FALSE(scaled_params(ModelKind::paper, kForearm, {-1, 1, 1, 1}));
  EXPECT_FALSE(scaled_params(ModelKind::paper, kForearm, {1, std::nan(""), 1, 1}));
  EXPECT_FALSE(scaled_params(ModelKind::paper, kForearm, {1, 1, 1, 1e6}));
  EXPECT_FALSE(scaled_params(ModelKind::paper, {0.04, -5, 6, 3, 1}, {}));
  const Scene scene{square(0, 0, 0, 1), overhead(), {overhead_light()}};
  const auto colours = spectral_colours(testing::colorimetry(), perfect_white(), d65());
  for (const auto& [w, h] : {std::pair{0, 10}, {10, -1}, {kMaxImageSide + 1, 10}}) {
    RenderSettings s = settings(1, 1, 0);
    s.width = w;
    s.height = h;
    const auto image = render(scene, colours, s);
    ASSERT_FALSE(image);
    EXPECT_NE(image.error().find("image size"), std::string::npos) << image.error();
  }
  RenderSettings rough = settings(4, 1, 1);
  rough.surface.roughness = 0;
  EXPECT_FALSE(render(scene, colours, rough));
  RenderSettings index = settings(4, 1, 1);
  index.surface.index = std::nan("");
  EXPECT_FALSE(render(scene, colours, index));
  Scene looking_up = scene;
  looking_up.camera.target = looking_up.camera.position + Vec3{0, 5, 0};
  EXPECT_FALSE(render(looking_up, colours, settings(4, 1, 1)));
  EXPECT_FALSE(encode_png(Image(2, 2), 12));
}

TEST(RenderImages, SixteenBitPngKeepsTheImage) {
  Image image(3, 2, {0.5f, 0.2f, 0.0f});
  image.at(2, 1) = {2.0f, -1.0f, 1.0f};  // clipped to [0, 1]
  const auto bytes = *encode_png(image, 16);
  const auto png = testing::decode_png(std::string(bytes.begin(), bytes.end()));
  ASSERT_TRUE(png.has_value());
  EXPECT_EQ(png->bits, 16);
  EXPECT_EQ(png->width, 3);
  EXPECT_EQ(png->height, 2);
  EXPECT_EQ(png->pixel(2, 1), (std::array<int, 3>{255, 0, 255}));
}

// Where the 8-bit sRGB code of a linear value steps from code - 1 to code: the least double
// with that code, by bisection on the value.
double code_step(int code) {
  const auto code_at = [](double v) { return srgb_8bit({v, v, v})[0]; };
  double below = 0, at = 1;
  for (int i = 0; i < 200 && below < at; ++i) {
    const double middle = below + (at - below) / 2;
    if (middle == below || middle == at) break;
    (code_at(middle) >= code ? at : below) = middle;
  }
  return at;
}

// 8-bit PNGs hold srgb_8bit's code of each sample, bit for bit: at 65,536 values spread over
// [0, 1], at the 64 floats either side of every step from one code to the next, and at values
// the curve clips (below 0, above 1, NaN), in both kinds of picture.
TEST(RenderImages, EightBitPngHoldsTheSrgbCodeOfEverySample) {
  std::vector<float> values;
  for (int i = 0; i <= 65535; ++i) values.push_back(static_cast<float>(i) / 65535.0f);
  for (int code = 1; code <= 255; ++code) {
    float v = static_cast<float>(code_step(code));
    for (int i = 0; i < 64; ++i) v = std::nextafter(v, 0.0f);
    for (int i = 0; i < 128; ++i, v = std::nextafter(v, 2.0f)) values.push_back(v);
  }
  using limits = std::numeric_limits<float>;
  for (const float v : {-1.0f, -0.0f, 1.0f, std::nextafter(1.0f, 2.0f), 1.5f, limits::quiet_NaN(), limits::infinity(),
                        -limits::infinity(), limits::denorm_min(), std::nextafter(limits::min(), 0.0f), limits::min()})
    values.push_back(v);
  constexpr int kWidth = 1024;
  const int height = static_cast<int>((values.size() + kWidth - 1) / kWidth);
  Image image(kWidth, height);
  for (std::size_t i = 0; i < values.size(); ++i) {
    const float v = values[i], w = values[values.size() - 1 - i];
    image.at(static_cast<int>(i % kWidth), static_cast<int>(i / kWidth)) = {v, w, v};
  }
  for (const PngContent content : {PngContent::continuous_tone, PngContent::false_colour}) {
    const auto bytes = *encode_png(image, 8, content);
    const auto png = testing::decode_png(std::string(bytes.begin(), bytes.end()));
    ASSERT_TRUE(png.has_value());
    int wrong = 0;
    for (std::size_t i = 0; i < values.size(); ++i) {
      const auto x = static_cast<int>(i % kWidth), y = static_cast<int>(i / kWidth);
      const auto held = png->pixel(x, y), expected = code_of(image.at(x, y));
      if (held != expected && ++wrong <= 5)
        ADD_FAILURE() << "linear " << values[i] << " (" << x << "," << y << "): PNG holds " << held[0] << "," << held[1]
                      << "," << held[2] << " where srgb_8bit gives " << expected[0] << "," << expected[1] << ","
                      << expected[2];
    }
    EXPECT_EQ(wrong, 0);
  }
}

// The filter byte that starts each row of an 8-bit RGB PNG's image data: the IDAT chunks
// joined and inflated with zlib, apart from libpng, which reads past them.
std::vector<int> row_filters(const std::vector<unsigned char>& png, int width, int height) {
  std::vector<unsigned char> deflated;
  for (std::size_t at = 8; at + 12 <= png.size();) {  // past the signature, chunk by chunk
    const std::size_t length = (std::size_t{png[at]} << 24) | (std::size_t{png[at + 1]} << 16) |
                               (std::size_t{png[at + 2]} << 8) | std::size_t{png[at + 3]};
    if (std::string(png.begin() + static_cast<std::ptrdiff_t>(at + 4),
                    png.begin() + static_cast<std::ptrdiff_t>(at + 8)) == "IDAT")
      deflated.insert(deflated.end(), png.begin() + static_cast<std::ptrdiff_t>(at + 8),
                      png.begin() + static_cast<std::ptrdiff_t>(at + 8 + length));
    at += 12 + length;
  }
  const std::size_t stride = 1 + 3 * static_cast<std::size_t>(width);
  std::vector<unsigned char> rows(stride * static_cast<std::size_t>(height));
  uLongf size = rows.size();
  if (uncompress(rows.data(), &size, deflated.data(), deflated.size()) != Z_OK || size != rows.size()) return {};
  std::vector<int> filters;
  for (std::size_t row = 0; row < static_cast<std::size_t>(height); ++row) filters.push_back(rows[row * stride]);
  return filters;
}

// A false-colour picture's rows are written unfiltered; a rendering's keep libpng's adaptive
// filters, which choose others on a gradient.
TEST(RenderImages, FalseColourPicturesAreWrittenUnfiltered) {
  constexpr int kSize = 64;
  Image gradient(kSize, kSize);
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) gradient.at(x, y) = {x / float{kSize}, y / float{kSize}, 0.5f};
  const auto unfiltered = row_filters(*encode_png(gradient, 8, PngContent::false_colour), kSize, kSize);
  ASSERT_EQ(unfiltered.size(), std::size_t{kSize});
  EXPECT_EQ(std::ranges::count(unfiltered, 0), kSize);
  const auto adaptive = row_filters(*encode_png(gradient, 8), kSize, kSize);
  ASSERT_EQ(adaptive.size(), std::size_t{kSize});
  EXPECT_GT(std::ranges::count_if(adaptive, [](int f) { return f != 0; }), 0);
}

TEST(RenderImages, ContactSheetHoldsEveryCellAndItsLabel) {
  std::vector<LabelledImage> cells;
  for (int i = 0; i < 3; ++i) cells.push_back({"X" + std::to_string(i), Image(20, 10, {1, 0, 0})});
  const Image sheet = contact_sheet("TITLE", cells, 2);
  int red = 0, ink = 0;
  for (int y = 0; y < sheet.height(); ++y)
    for (int x = 0; x < sheet.width(); ++x) {
      const Rgb& p = sheet.at(x, y);
      red += p.r == 1 && p.g == 0;
      ink += p.r == 0 && p.g == 0;
    }
  EXPECT_EQ(red, 3 * 20 * 10);
  EXPECT_GT(ink, 4 * 10);  // the title and three labels drew something
  EXPECT_GT(sheet.width(), 2 * 20);
}

}  // namespace
}  // namespace skinspec::render
