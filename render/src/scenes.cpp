#include "skinspec/render/scenes.hpp"

#include <algorithm>
#include <numbers>

namespace skinspec::render {

namespace {

// Two unit vectors perpendicular to `axis` and to each other.
std::pair<Vec3, Vec3> perpendiculars(const Vec3& axis) {
  const Vec3 helper = std::abs(axis.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
  const Vec3 u = normalized(cross(axis, helper));
  return {u, cross(axis, u)};
}

Mesh squashed(Mesh mesh, const Vec3& centre, const Vec3& scale) {
  for (Vec3& p : mesh.positions) {
    const Vec3 d = p - centre;
    p = centre + Vec3{d.x * scale.x, d.y * scale.y, d.z * scale.z};
  }
  return mesh;
}

// A chain of capsules through `joints`, the radius tapering from r0 to r1 along it.
Mesh limb(const std::vector<Vec3>& joints, double r0, double r1, int segments) {
  Mesh out;
  const auto n = static_cast<double>(joints.size() - 1);
  for (std::size_t i = 0; i + 1 < joints.size(); ++i) {
    const double ra = r0 + (r1 - r0) * static_cast<double>(i) / n;
    const double rb = r0 + (r1 - r0) * static_cast<double>(i + 1) / n;
    out.append(capsule(joints[i], ra, joints[i + 1], rb, segments));
  }
  return out;
}

}  // namespace

Mesh capsule(const Vec3& a, double ra, const Vec3& b, double rb, int segments) {
  const Vec3 span = b - a;
  const Vec3 axis = length(span) > 0 ? normalized(span) : Vec3{0, 1, 0};
  const auto [u, w] = perpendiculars(axis);
  const int around = std::max(segments, 3), per_cap = std::max(segments / 2, 2);
  Mesh mesh;
  // Rings from b's pole down to a's: the cap of b, then the cap of a; the band between the
  // last ring of one cap and the first of the other is the swept side.
  for (int cap = 0; cap < 2; ++cap) {
    const Vec3& centre = cap == 0 ? b : a;
    const double r = cap == 0 ? rb : ra;
    for (int ring = 0; ring <= per_cap; ++ring) {
      const double theta = std::numbers::pi / 2 * (cap + static_cast<double>(ring) / per_cap);
      for (int k = 0; k < around; ++k) {
        const double phi = 2 * std::numbers::pi * k / around;
        const Vec3 radial = u * std::cos(phi) + w * std::sin(phi);
        mesh.positions.push_back(centre + axis * (r * std::cos(theta)) + radial * (r * std::sin(theta)));
      }
    }
  }
  const int rings = 2 * (per_cap + 1);
  for (int ring = 0; ring + 1 < rings; ++ring)
    for (int k = 0; k < around; ++k) {
      const auto at = [&](int rr, int kk) { return static_cast<std::uint32_t>(rr * around + (kk % around)); };
      mesh.triangles.push_back({at(ring, k), at(ring + 1, k), at(ring + 1, k + 1)});
      mesh.triangles.push_back({at(ring, k), at(ring + 1, k + 1), at(ring, k + 1)});
    }
  return mesh;
}

Mesh sphere(const Vec3& centre, double radius, int segments) {
  return with_vertex_normals(capsule(centre, radius, centre, radius, segments));
}

Mesh procedural_hand() {
  constexpr int kSegments = 32;
  const Vec3 palm_centre{0, 0, 0};
  Mesh hand = squashed(capsule({0, -2.0, 0}, 4.0, {0, 2.0, 0}, 4.2, kSegments), palm_centre, {1.0, 1.0, 0.38});
  hand.append(
      squashed(capsule({0, -5.0, -0.3}, 2.6, {0, -12.0, -0.3}, 2.9, kSegments), {0, -8, -0.3}, {1.15, 1.0, 0.7}));
  // Fingers: base x, base y, spread (radians from vertical), phalanx lengths, base radius.
  struct Finger {
    double x, y, spread;
    std::array<double, 3> lengths;
    double radius;
  };
  constexpr Finger kFingers[] = {{-3.0, 4.6, -0.10, {4.6, 2.6, 2.2}, 0.95},
                                 {-1.0, 5.2, -0.03, {4.9, 2.9, 2.4}, 0.98},
                                 {1.0, 5.0, 0.04, {4.6, 2.8, 2.3}, 0.93},
                                 {2.9, 4.4, 0.12, {3.8, 2.2, 2.0}, 0.82}};
  for (const Finger& f : kFingers) {
    // Each joint bends a little towards the palm (-z), as a relaxed hand does.
    std::vector<Vec3> joints{{f.x, f.y, 0.1}};
    double bend = 0.1;
    for (const double l : f.lengths) {
      const Vec3& last = joints.back();
      joints.push_back(last +
                       Vec3{std::sin(f.spread) * l, std::cos(f.spread) * std::cos(bend) * l, -std::sin(bend) * l});
      bend += 0.15;
    }
    hand.append(limb(joints, f.radius, f.radius * 0.82, kSegments));
  }
  hand.append(limb({{3.0, -2.2, -0.4}, {5.6, 0.2, 0.2}, {7.2, 2.6, 0.4}, {8.2, 4.3, 0.3}}, 1.35, 0.95, kSegments));
  return with_vertex_normals(std::move(hand));
}

Scene framed_scene(Mesh mesh, double aspect) {
  const Bounds b = bounds_of(mesh);
  const double fov = 30;
  const double half = std::tan(fov * std::numbers::pi / 360.0);
  const Vec3 extent = b.high - b.low;
  // Far enough that the bounds' larger visible half-extent fits the field of view, plus margin.
  const double fit_height = std::max(extent.y, extent.x / std::max(aspect, 1e-3)) * 0.5;
  const double distance = 1.1 * fit_height / half + extent.z * 0.5;
  const Vec3 centre = b.centre();
  Scene scene{std::move(mesh), Camera{centre + Vec3{0, 0, distance}, centre, {0, 1, 0}, fov}, {}};
  const double reach = std::max(b.radius(), 1e-6);
  scene.lights.push_back({Light::Kind::directional, Vec3{-0.75, 0.45, 0.5}, 0.9});
  const double fill_distance = 3 * reach;
  scene.lights.push_back(
      {Light::Kind::point, centre + Vec3{0.8, -0.2, 0.6} * fill_distance, 0.3 * fill_distance * fill_distance});
  return scene;
}

Scene builtin_scene(SceneKind kind, double aspect) {
  return framed_scene(kind == SceneKind::hand ? procedural_hand() : sphere({0, 0, 0}, 1.0, 64), aspect);
}

}  // namespace skinspec::render
