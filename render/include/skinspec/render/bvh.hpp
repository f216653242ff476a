#pragma once
// A bounding volume hierarchy over a mesh's triangles: the nearest hit of a ray, and whether
// anything blocks a shadow ray, in logarithmic rather than linear time.

#include <cstdint>
#include <optional>
#include <vector>

#include "skinspec/render/mesh.hpp"

namespace skinspec::render {

struct Hit {
  double distance = 0;
  std::uint32_t triangle = 0;
  double u = 0, v = 0;  // barycentric weights of the triangle's second and third vertices
};

class Bvh {
 public:
  // Keeps a reference to `mesh`, which must outlive the hierarchy.
  explicit Bvh(const Mesh& mesh);

  // The nearest hit with distance in (min_distance, max_distance), either side of a triangle.
  std::optional<Hit> nearest(const Ray& ray, double min_distance, double max_distance) const;
  // Whether any triangle lies along the ray within (min_distance, max_distance).
  bool blocked(const Ray& ray, double min_distance, double max_distance) const;

  const Mesh& mesh() const { return mesh_; }
  std::size_t node_count() const { return nodes_.size(); }

 private:
  struct Node {
    Bounds box;
    std::uint32_t first = 0;  // leaf: first index into order_; inner: index of the right child
    std::uint32_t count = 0;  // triangles in a leaf; 0 for an inner node (left child follows it)
  };

  std::uint32_t build(std::uint32_t first, std::uint32_t count, std::vector<Vec3>& centroids);
  template <bool kAnyHit>
  std::optional<Hit> traverse(const Ray& ray, double min_distance, double max_distance) const;

  const Mesh& mesh_;
  std::vector<Node> nodes_;
  std::vector<std::uint32_t> order_;  // triangle indices, grouped by leaf
};

}  // namespace skinspec::render
