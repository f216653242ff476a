// The OBJ and PLY readers (good files, and bad ones refused with their line) and the BVH
// against brute force.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstring>
#include <random>

#include "skinspec/render/bvh.hpp"
#include "skinspec/render/scenes.hpp"

namespace skinspec::render {
namespace {

using ::testing::HasSubstr;

constexpr std::string_view kQuadObj =
    "# a unit square\r\n"
    "v 0 0 0\n"
    "v 1 0 0\n"
    "v 1 1 0\n"
    "v 0 1 0\n"
    "vn 0 0 1\n"
    "f 1//1 2//1 3//1 -1//1\n";

TEST(ObjReader, ReadsAPolygonAsAFanWithNormals) {
  const auto mesh = parse_obj(kQuadObj, "quad.obj");
  ASSERT_TRUE(mesh) << mesh.error().what();
  EXPECT_EQ(mesh->positions.size(), 4u);
  ASSERT_EQ(mesh->triangles.size(), 2u);
  EXPECT_EQ(mesh->triangles[1], (std::array<std::uint32_t, 3>{0, 2, 3}));
  for (const Vec3& n : mesh->normals) EXPECT_NEAR(n.z, 1.0, 1e-12);
}

struct BadMesh {
  std::string_view name, text;
  std::size_t line;
  std::string_view message;
};

// Names the case in test listings instead of dumping its bytes.
void PrintTo(const BadMesh& bad, std::ostream* out) { *out << bad.name; }

class MeshRefuses : public ::testing::TestWithParam<BadMesh> {};

TEST_P(MeshRefuses, NamingTheLine) {
  const auto mesh = parse_mesh(GetParam().text, GetParam().name);
  ASSERT_FALSE(mesh);
  EXPECT_EQ(mesh.error().source, GetParam().name);
  EXPECT_EQ(mesh.error().line, GetParam().line) << mesh.error().what();
  EXPECT_THAT(mesh.error().what(), HasSubstr(GetParam().message));
}

INSTANTIATE_TEST_SUITE_P(
    Bad, MeshRefuses,
    ::testing::Values(BadMesh{"empty.obj", "", 0, "no faces"},
                      BadMesh{"vertices.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n", 0, "no faces"},
                      BadMesh{"short.obj", "v 0 0 0\nv 1 0\n", 2, "x y z"},
                      BadMesh{"word.obj", "v 0 0 0\n\nv 1 zero 0\n", 3, "'zero'"},
                      BadMesh{"nan.obj", "v 0 0 nan\n", 1, "finite"},
                      BadMesh{"index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", 4, "vertex 4"},
                      BadMesh{"zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", 4, "vertex 0"},
                      BadMesh{"two.obj", "v 0 0 0\nv 1 0 0\nf 1 2\n", 3, "three"},
                      BadMesh{"flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n", 0, "non-zero area"},
                      BadMesh{"hand.stl", "solid", 0, ".obj or .ply"}, BadMesh{"magic.ply", "plyx\n", 1, "first line"},
                      BadMesh{"noformat.ply", "ply\nelement vertex 0\nend_header\n", 3, "format"},
                      BadMesh{"unended.ply", "ply\nformat ascii 1.0\n", 2, "end_header"},
                      BadMesh{"big.ply", "ply\nformat binary_big_endian 1.0\nend_header\n", 2, "big-endian"},
                      BadMesh{"type.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\n", 4, "type"},
                      BadMesh{"noxyz.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n",
                              5, "x, y and z"},
                      BadMesh{"count.ply",
                              "ply\nformat ascii 1.0\nelement vertex 99999999\nproperty float x\nproperty float y\n"
                              "property float z\nend_header\n0 0 0\n",
                              7, "more items than"},
                      BadMesh{"truncated.ply",
                              "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                              "property float z\nend_header\n0 0 0\n1 0 0\n",
                              9, "ends before"},
                      BadMesh{"cell.ply",
                              "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                              "property float z\nend_header\n0 0 oops\n",
                              8, "'oops'"}),
    [](const auto& test) {
      std::string name(test.param.name);
      for (char& c : name)
        if (c == '.') c = '_';
      return name;
    });

constexpr std::string_view kPlyHeader =
    "ply\n"
    "format ascii 1.0\n"
    "comment made by hand\n"
    "element vertex 4\n"
    "property float x\nproperty float y\nproperty float z\nproperty uchar red\n"
    "element face 1\n"
    "property list uchar int vertex_indices\n"
    "end_header\n";

TEST(PlyReader, ReadsAsciiWithExtraProperties) {
  const std::string text = std::string(kPlyHeader) + "0 0 0 9\n1 0 0 9\n1 1 0 9\n0 1 0 9\n4 0 1 2 3\n";
  const auto mesh = parse_ply(text, "quad.ply");
  ASSERT_TRUE(mesh) << mesh.error().what();
  EXPECT_EQ(mesh->positions.size(), 4u);
  EXPECT_EQ(mesh->triangles.size(), 2u);
}

TEST(PlyReader, RefusesFacesNamingMissingVerticesOrTooFew) {
  const std::string vertices = "0 0 0 9\n1 0 0 9\n1 1 0 9\n0 1 0 9\n";
  const auto missing = parse_ply(std::string(kPlyHeader) + vertices + "3 0 1 7\n", "quad.ply");
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().line, 16u);
  EXPECT_THAT(missing.error().what(), HasSubstr("vertex 7 is not among the 4"));
  const auto two = parse_ply(std::string(kPlyHeader) + vertices + "2 0 1\n", "quad.ply");
  ASSERT_FALSE(two);
  EXPECT_EQ(two.error().line, 16u);
}

template <typename T>
void put(std::string& out, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  out.append(bytes, sizeof(T));
}

std::string binary_triangle_ply() {
  std::string out =
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property double z\nelement face 1\nproperty list uchar uint vertex_indices\nend_header\n";
  for (const auto& [x, y] : {std::pair{0.0f, 0.0f}, {2.0f, 0.0f}, {0.0f, 2.0f}}) {
    put(out, x);
    put(out, y);
    put(out, 0.5);
  }
  put<std::uint8_t>(out, 3);
  for (const std::uint32_t i : {0u, 1u, 2u}) put(out, i);
  return out;
}

TEST(PlyReader, ReadsBinaryLittleEndian) {
  const auto mesh = parse_mesh(binary_triangle_ply(), "scan.PLY");
  ASSERT_TRUE(mesh) << mesh.error().what();
  ASSERT_EQ(mesh->positions.size(), 3u);
  EXPECT_EQ(mesh->positions[1].x, 2.0);
  EXPECT_EQ(mesh->positions[2].z, 0.5);
  EXPECT_EQ(mesh->triangles.size(), 1u);
}

TEST(PlyReader, RefusesATruncatedBinaryBody) {
  std::string bytes = binary_triangle_ply();
  bytes.resize(bytes.size() - 3);  // into the face, after three vertices of 16 bytes
  const auto mesh = parse_ply(bytes, "scan.ply");
  ASSERT_FALSE(mesh);
  EXPECT_THAT(mesh.error().what(), HasSubstr("binary body ends before every element"));
  EXPECT_THAT(mesh.error().what(), HasSubstr("item at byte 48"));
}

// Brute force: every triangle tried, by the plane of the triangle and edge signs (a different
// method from the Moller-Trumbore test the BVH uses).
std::optional<double> nearest_by_brute_force(const Mesh& mesh, const Ray& ray) {
  std::optional<double> best;
  for (const auto& t : mesh.triangles) {
    const Vec3 &a = mesh.positions[t[0]], &b = mesh.positions[t[1]], &c = mesh.positions[t[2]];
    const Vec3 n = cross(b - a, c - a);
    const double along = dot(n, ray.direction);
    if (std::abs(along) < 1e-14) continue;
    const double d = dot(n, a - ray.origin) / along;
    if (d <= 0 || (best && d >= *best)) continue;
    const Vec3 p = ray.origin + ray.direction * d;
    const double s0 = dot(n, cross(b - a, p - a)), s1 = dot(n, cross(c - b, p - b)), s2 = dot(n, cross(a - c, p - c));
    if ((s0 >= 0 && s1 >= 0 && s2 >= 0) || (s0 <= 0 && s1 <= 0 && s2 <= 0)) best = d;
  }
  return best;
}

TEST(Bvh, FindsTheSameNearestHitsAsBruteForce) {
  const Mesh hand = procedural_hand();
  const Bvh bvh(hand);
  EXPECT_GT(bvh.node_count(), hand.triangles.size() / 8);
  const Bounds b = bounds_of(hand);
  std::mt19937 random(7);
  std::uniform_real_distribution<double> unit(-1, 1);
  int hits = 0;
  for (int i = 0; i < 60; ++i) {
    const Vec3 target = b.centre() + Vec3{unit(random) * 5, unit(random) * 9, unit(random)};
    const Vec3 origin = b.centre() + normalized({unit(random), unit(random), unit(random)}) * 40;
    const Ray ray{origin, normalized(target - origin)};
    const auto fast = bvh.nearest(ray, 0, 1e300);
    const auto slow = nearest_by_brute_force(hand, ray);
    ASSERT_EQ(fast.has_value(), slow.has_value()) << "ray " << i;
    if (!fast) continue;
    ++hits;
    EXPECT_NEAR(fast->distance, *slow, 1e-9) << "ray " << i;
    EXPECT_TRUE(bvh.blocked(ray, 0, fast->distance + 1e-6));
    EXPECT_FALSE(bvh.blocked(ray, 0, fast->distance * 0.999));
  }
  EXPECT_GT(hits, 20);
}

}  // namespace
}  // namespace skinspec::render
