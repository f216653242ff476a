#include "skinspec/render/bvh.hpp"

#include <algorithm>
#include <array>
#include <numeric>

namespace skinspec::render {

namespace {

constexpr std::uint32_t kLeafSize = 4;

Bounds triangle_bounds(const Mesh& mesh, std::uint32_t t) {
  const auto& tri = mesh.triangles[t];
  const Vec3 &a = mesh.positions[tri[0]], &b = mesh.positions[tri[1]], &c = mesh.positions[tri[2]];
  return {component_min(a, component_min(b, c)), component_max(a, component_max(b, c))};
}

// Slab test: whether the ray meets the box within (near, far).
bool meets(const Bounds& box, const Vec3& origin, const Vec3& inverse_direction, double near, double far) {
  for (int axis = 0; axis < 3; ++axis) {
    double t0 = (box.low[axis] - origin[axis]) * inverse_direction[axis];
    double t1 = (box.high[axis] - origin[axis]) * inverse_direction[axis];
    if (t0 > t1) std::swap(t0, t1);
    near = std::max(near, t0);
    far = std::min(far, t1);
    if (near > far) return false;
  }
  return true;
}

// Moller-Trumbore ray-triangle intersection, accepting either side.
std::optional<Hit> intersect(const Mesh& mesh, std::uint32_t t, const Ray& ray, double near, double far) {
  const auto& tri = mesh.triangles[t];
  const Vec3& a = mesh.positions[tri[0]];
  const Vec3 e1 = mesh.positions[tri[1]] - a, e2 = mesh.positions[tri[2]] - a;
  const Vec3 p = cross(ray.direction, e2);
  const double det = dot(e1, p);
  if (std::abs(det) < 1e-14) return std::nullopt;
  const double inv = 1.0 / det;
  const Vec3 s = ray.origin - a;
  const double u = dot(s, p) * inv;
  if (u < 0 || u > 1) return std::nullopt;
  const Vec3 q = cross(s, e1);
  const double v = dot(ray.direction, q) * inv;
  if (v < 0 || u + v > 1) return std::nullopt;
  const double distance = dot(e2, q) * inv;
  if (distance <= near || distance >= far) return std::nullopt;
  return Hit{distance, t, u, v};
}

}  // namespace

Bvh::Bvh(const Mesh& mesh) : mesh_(mesh) {
  const auto n = static_cast<std::uint32_t>(mesh.triangles.size());
  order_.resize(n);
  std::iota(order_.begin(), order_.end(), 0u);
  std::vector<Vec3> centroids(n);
  for (std::uint32_t t = 0; t < n; ++t) centroids[t] = triangle_bounds(mesh, t).centre();
  nodes_.reserve(2 * static_cast<std::size_t>(n) / kLeafSize + 1);
  if (n > 0) build(0, n, centroids);
}

// Splits at the median of the centroids along the box's longest axis: not the cheapest
// hierarchy to trace, but built in n log n and good for the evenly tessellated meshes rendered.
std::uint32_t Bvh::build(std::uint32_t first, std::uint32_t count, std::vector<Vec3>& centroids) {
  const auto index = static_cast<std::uint32_t>(nodes_.size());
  Bounds box = triangle_bounds(mesh_, order_[first]);
  for (std::uint32_t i = first; i < first + count; ++i) {
    const Bounds b = triangle_bounds(mesh_, order_[i]);
    box = {component_min(box.low, b.low), component_max(box.high, b.high)};
  }
  nodes_.push_back({box, first, count});
  if (count <= kLeafSize) return index;
  const Vec3 extent = box.high - box.low;
  const int axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : extent.y >= extent.z ? 1 : 2;
  const std::uint32_t half = count / 2;
  std::nth_element(order_.begin() + first, order_.begin() + first + half, order_.begin() + first + count,
                   [&](std::uint32_t a, std::uint32_t b) { return centroids[a][axis] < centroids[b][axis]; });
  nodes_[index].count = 0;
  build(first, half, centroids);
  const std::uint32_t right = build(first + half, count - half, centroids);
  nodes_[index].first = right;
  return index;
}

template <bool kAnyHit>
std::optional<Hit> Bvh::traverse(const Ray& ray, double min_distance, double max_distance) const {
  if (nodes_.empty()) return std::nullopt;
  const Vec3 inverse{1.0 / ray.direction.x, 1.0 / ray.direction.y, 1.0 / ray.direction.z};
  std::optional<Hit> best;
  std::array<std::uint32_t, 64> stack{};
  std::size_t depth = 0;
  stack[depth++] = 0;
  while (depth > 0) {
    const Node& node = nodes_[stack[--depth]];
    const double far = best ? best->distance : max_distance;
    if (!meets(node.box, ray.origin, inverse, min_distance, far)) continue;
    if (node.count == 0) {
      const auto self = static_cast<std::uint32_t>(&node - nodes_.data());
      stack[depth++] = node.first;
      stack[depth++] = self + 1;
      continue;
    }
    for (std::uint32_t i = node.first; i < node.first + node.count; ++i) {
      const auto hit = intersect(mesh_, order_[i], ray, min_distance, best ? best->distance : max_distance);
      if (!hit) continue;
      if (kAnyHit) return hit;
      best = hit;
    }
  }
  return best;
}

std::optional<Hit> Bvh::nearest(const Ray& ray, double min_distance, double max_distance) const {
  return traverse<false>(ray, min_distance, max_distance);
}

bool Bvh::blocked(const Ray& ray, double min_distance, double max_distance) const {
  return traverse<true>(ray, min_distance, max_distance).has_value();
}

}  // namespace skinspec::render
