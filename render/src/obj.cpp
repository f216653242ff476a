// Wavefront OBJ: only geometry (v, f) is read; materials, texture coordinates and groups are
// skipped because the renderer takes its colour from the skin model, not from the file.

#include "mesh_text.hpp"
#include "skinspec/spectral/utf8.hpp"

namespace skinspec::render {

namespace {

using detail::finite_number;
using detail::integer;

struct ObjReader {
  std::string source;
  Mesh mesh;

  InputError error(std::size_t line, std::string message) const { return {source, line, 0, std::move(message)}; }

  std::optional<InputError> vertex(const std::vector<std::string_view>& w, std::size_t line) {
    if (w.size() < 4) return error(line, "a vertex needs x y z");
    Vec3 p;
    for (int axis = 0; axis < 3; ++axis) {
      const auto v = finite_number(w[static_cast<std::size_t>(axis) + 1]);
      if (!v) return error(line, "not a finite number: " + quote(w[static_cast<std::size_t>(axis) + 1]));
      (axis == 0 ? p.x : axis == 1 ? p.y : p.z) = *v;
    }
    mesh.positions.push_back(p);
    return std::nullopt;
  }

  // "7", "7/2", "7//3", "-1/2/3": the vertex index before the first slash, 1-based or
  // counted back from the latest vertex when negative.
  std::expected<std::uint32_t, InputError> vertex_index(std::string_view word, std::size_t line) const {
    const auto index = integer(word.substr(0, word.find('/')));
    const auto count = static_cast<std::int64_t>(mesh.positions.size());
    if (!index) return std::unexpected(error(line, "not a vertex index: " + quote(word)));
    const std::int64_t zero_based = *index < 0 ? count + *index : *index - 1;
    if (*index == 0 || zero_based < 0 || zero_based >= count)
      return std::unexpected(error(line, "vertex " + std::to_string(*index) + " is not among the " +
                                             std::to_string(count) + " vertices defined so far"));
    return static_cast<std::uint32_t>(zero_based);
  }

  std::optional<InputError> face(const std::vector<std::string_view>& w, std::size_t line) {
    if (w.size() < 4) return error(line, "a face needs at least three vertices");
    std::vector<std::uint32_t> corners;
    for (std::size_t i = 1; i < w.size(); ++i) {
      const auto v = vertex_index(w[i], line);
      if (!v) return v.error();
      corners.push_back(*v);
    }
    for (std::size_t i = 1; i + 1 < corners.size(); ++i)
      mesh.triangles.push_back({corners[0], corners[i], corners[i + 1]});
    return std::nullopt;
  }
};

}  // namespace

std::expected<Mesh, InputError> parse_obj(std::string_view bytes, std::string_view source) {
  ObjReader reader{std::string(source), {}};
  detail::LineReader lines(bytes);
  while (const auto line = lines.next()) {
    const auto w = detail::words(line->substr(0, line->find('#')));
    if (w.empty()) continue;
    std::optional<InputError> failed;
    if (w[0] == "v") failed = reader.vertex(w, lines.line());
    else if (w[0] == "f") failed = reader.face(w, lines.line());
    if (failed) return std::unexpected(*failed);
  }
  if (reader.mesh.triangles.empty())
    return std::unexpected(InputError{std::string(source), 0, 0, "no faces: an OBJ mesh needs 'f' lines"});
  return detail::checked_mesh(std::move(reader.mesh), source);
}

}  // namespace skinspec::render
