#include "skinspec/render/mesh.hpp"

#include <algorithm>
#include <cctype>
#include <string>

namespace skinspec::render {

void Mesh::append(const Mesh& other) {
  const auto offset = static_cast<std::uint32_t>(positions.size());
  positions.insert(positions.end(), other.positions.begin(), other.positions.end());
  normals.insert(normals.end(), other.normals.begin(), other.normals.end());
  for (const auto& t : other.triangles) triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
}

Bounds bounds_of(const Mesh& mesh) {
  if (mesh.positions.empty()) return {};
  Bounds b{mesh.positions.front(), mesh.positions.front()};
  for (const Vec3& p : mesh.positions) {
    b.low = component_min(b.low, p);
    b.high = component_max(b.high, p);
  }
  return b;
}

Mesh with_vertex_normals(Mesh mesh) {
  std::vector<Vec3> sums(mesh.positions.size());
  std::vector<std::array<std::uint32_t, 3>> kept;
  kept.reserve(mesh.triangles.size());
  for (const auto& t : mesh.triangles) {
    // The cross product's length is twice the area: summing it weights normals by area.
    const Vec3 n = cross(mesh.positions[t[1]] - mesh.positions[t[0]], mesh.positions[t[2]] - mesh.positions[t[0]]);
    if (!(length(n) > 0)) continue;
    kept.push_back(t);
    for (const auto v : t) sums[v] += n;
  }
  mesh.triangles = std::move(kept);
  mesh.normals.resize(sums.size());
  std::ranges::transform(sums, mesh.normals.begin(), normalized);
  return mesh;
}

std::expected<Mesh, InputError> parse_mesh(std::string_view bytes, std::string_view source) {
  std::string extension(source.substr(std::min(source.size(), source.rfind('.'))));
  std::ranges::transform(extension, extension.begin(),
                         [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (extension == ".obj") return parse_obj(bytes, source);
  if (extension == ".ply") return parse_ply(bytes, source);
  return std::unexpected(InputError{std::string(source), 0, 0, "not a mesh file: the name must end in .obj or .ply"});
}

}  // namespace skinspec::render
