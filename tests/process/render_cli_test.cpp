// The render and figures commands through the built skinspec program: PNG files that libpng
// decodes at the asked size, and bad input refused with status 2 naming the file and line.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "support/png_reader.hpp"
#include "skinspec/testkit/process.hpp"
#include "skinspec/testkit/store_samples.hpp"

namespace skinspec {
namespace {

using ::testing::HasSubstr;

constexpr int kBadInput = 2;

testing::ProcessResult skinspec(const std::vector<std::string>& args) {
  return testing::run_process(SKINSPEC_TEST_BIN_DIR "/skinspec", args);
}

std::string contents(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write(const std::string& path, const std::string& text) { std::ofstream(path, std::ios::binary) << text; }

class RenderCommand : public ::testing::Test {
 protected:
  testing::ScratchDirectory dir;
  std::string out = dir.file("out.png");

  // Runs `skinspec render ARGS -o out.png` and expects status 2, no file, and `text` on stderr.
  void expect_refused(std::vector<std::string> args, const std::string& text) {
    args.insert(args.begin(), "render");
    args.insert(args.end(), {"-o", out});
    const auto r = skinspec(args);
    EXPECT_EQ(r.exit_status, kBadInput) << r.describe();
    EXPECT_THAT(r.err, HasSubstr(text)) << r.describe();
    EXPECT_FALSE(std::filesystem::exists(out));
  }
};

TEST_F(RenderCommand, WritesAPngOfTheAskedSize) {
  const auto r = skinspec({"render", "--size", "96x64", "-o", out});
  ASSERT_EQ(r.exit_status, 0) << r.describe();
  const auto png = testing::decode_png(contents(out));
  ASSERT_TRUE(png.has_value());
  EXPECT_EQ(png->width, 96);
  EXPECT_EQ(png->height, 64);
  EXPECT_EQ(png->bits, 8);
  // The hand sits in the middle of a dark background, its skin redder than blue.
  const auto centre = png->pixel(48, 32), corner = png->pixel(0, 0);
  EXPECT_GT(centre[0], corner[0] + 50);
  EXPECT_GT(centre[0], centre[2]);
}

TEST_F(RenderCommand, WritesSixteenBitsOfASphereUnderA) {
  const auto r = skinspec({"render", "--scene", "sphere", "--illuminant", "A", "--bits", "16", "--size", "40x40",
                           "--scale-melanin", "2", "--roughness", "0.2", "--index", "1.5", "--beta", "2", "-o", out});
  ASSERT_EQ(r.exit_status, 0) << r.describe();
  const auto png = testing::decode_png(contents(out));
  ASSERT_TRUE(png.has_value());
  EXPECT_EQ(png->bits, 16);
  EXPECT_EQ(png->width, 40);
}

TEST_F(RenderCommand, RendersTheSkinOfAFitAndAMeshFile) {
  const auto fit = skinspec({"fit", SKINSPEC_TEST_DATA_DIR "/examples/forearm.csv"});
  ASSERT_EQ(fit.exit_status, 0) << fit.describe();
  write(dir.file("fit.json"), fit.out);
  write(dir.file("tri.obj"), "v -1 -1 0\nv 1 -1 0\nv 0 1 0\nf 1 2 3\n");
  const auto r =
      skinspec({"render", "--fit", dir.file("fit.json"), "--mesh", dir.file("tri.obj"), "--size", "32x32", "-o", out});
  ASSERT_EQ(r.exit_status, 0) << r.describe();
  const auto png = testing::decode_png(contents(out));
  ASSERT_TRUE(png.has_value());
  EXPECT_GT(png->pixel(16, 16)[0], 60);
}

TEST_F(RenderCommand, RefusesMalformedMeshesNamingFileAndLine) {
  write(dir.file("bad.obj"), "v 0 0 0\nv 1 0 0\nf 1 2 3\n");
  expect_refused({"--mesh", dir.file("bad.obj")}, dir.file("bad.obj") + ":3:");
  write(dir.file("empty.ply"), "");
  expect_refused({"--mesh", dir.file("empty.ply")}, "empty.ply:1:");
  expect_refused({"--mesh", dir.file("missing.obj")}, "missing.obj");
}

TEST_F(RenderCommand, RefusesBadFitJson) {
  write(dir.file("fit.json"), "\n{\"site\": \"forearm\", \"params\": {\"melanin\": 3}}\n");
  expect_refused({"--fit", dir.file("fit.json")}, dir.file("fit.json") + ":2: params.surface_reflectance");
  write(dir.file("fit.json"), "not json\n");
  expect_refused({"--fit", dir.file("fit.json")}, ":1: not a JSON object");
  write(dir.file("fit.json"), "{\"site\": \"elbow\", \"params\": {}}\n");
  expect_refused({"--fit", dir.file("fit.json")}, "elbow");
}

TEST_F(RenderCommand, RefusesUnknownIlluminantsAbsurdSizesAndBadNumbers) {
  expect_refused({"--illuminant", "F11"}, "F11");
  expect_refused({"--size", "0x10"}, "--size '0x10'");
  expect_refused({"--size", "100000x100000"}, "--size");
  expect_refused({"--size", "big"}, "--size 'big'");
  expect_refused({"--scale-melanin", "-1"}, "--scale-melanin");
  expect_refused({"--roughness", "nan"}, "--roughness");
  expect_refused({"--melanin", "x"}, "--melanin");
  expect_refused({"--bits", "12"}, "--bits");
  expect_refused({"--fit", "a.json", "--melanin", "3"}, "excludes");
}

TEST(FiguresCommand, WritesThePapersThreeContactSheets) {
  testing::ScratchDirectory dir;
  const std::string out = dir.file("figures");
  const auto r = skinspec({"figures", "--out", out, "--size", "48x48"});
  ASSERT_EQ(r.exit_status, 0) << r.describe();
  const std::pair<const char*, int> sheets[] = {
      {"figure4_illuminants.png", 2}, {"figure5_melanin_haemoglobin.png", 3}, {"figure6_bilirubin.png", 3}};
  for (const auto& [name, columns] : sheets) {
    const auto png = testing::decode_png(contents(out + "/" + name));
    ASSERT_TRUE(png.has_value()) << name;
    EXPECT_GT(png->width, columns * 48) << name;
    EXPECT_THAT(r.out, HasSubstr(name));
  }
  EXPECT_GT(testing::decode_png(contents(out + "/figure5_melanin_haemoglobin.png"))->height, 3 * 48);
}

}  // namespace
}  // namespace skinspec
