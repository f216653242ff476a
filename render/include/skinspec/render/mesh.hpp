#pragma once
// Triangle meshes: the OBJ and PLY readers (bytes in, a mesh or a located error out) and the
// vertex normals that make a scanned or tessellated surface shade smoothly.

#include <array>
#include <cstdint>
#include <expected>
#include <string_view>
#include <vector>

#include "skinspec/render/vec3.hpp"
#include "skinspec/spectral/table.hpp"

namespace skinspec::render {

struct Mesh {
  std::vector<Vec3> positions;
  std::vector<Vec3> normals;  // one per position, unit length (see with_vertex_normals)
  std::vector<std::array<std::uint32_t, 3>> triangles;

  // Appends another mesh's vertices and triangles.
  void append(const Mesh& other);
};

struct Bounds {
  Vec3 low, high;
  Vec3 centre() const { return (low + high) * 0.5; }
  double radius() const { return length(high - low) * 0.5; }
};
Bounds bounds_of(const Mesh& mesh);

// The mesh with area-weighted vertex normals; triangles of zero area are dropped.
Mesh with_vertex_normals(Mesh mesh);

// Wavefront OBJ: `v x y z` and `f a b c ...` (1-based or negative indices, `a/t/n` forms;
// polygons become fans); other statements are ignored. Errors name the line. A file without
// a triangle is an error.
std::expected<Mesh, InputError> parse_obj(std::string_view bytes, std::string_view source);

// PLY, ASCII or binary little-endian: `element vertex` with float/double x, y, z (other
// properties skipped) and `element face` with a `list` of vertex indices. Errors name the line
// (of the header or of an ASCII body) or the byte offset of a binary body.
std::expected<Mesh, InputError> parse_ply(std::string_view bytes, std::string_view source);

// By the file name's extension (.obj or .ply, any case); an error for anything else.
std::expected<Mesh, InputError> parse_mesh(std::string_view bytes, std::string_view source);

}  // namespace skinspec::render
