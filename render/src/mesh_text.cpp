#include "mesh_text.hpp"

#include <charconv>
#include <cmath>

namespace skinspec::render::detail {

std::optional<std::string_view> LineReader::next() {
  if (rest_.empty()) return std::nullopt;
  const std::size_t end = rest_.find('\n');
  std::string_view line = rest_.substr(0, end);
  rest_ = end == std::string_view::npos ? std::string_view{} : rest_.substr(end + 1);
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  ++line_;
  return line;
}

std::vector<std::string_view> words(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    const std::size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
    if (i > start) out.push_back(line.substr(start, i - start));
  }
  return out;
}

std::optional<double> finite_number(std::string_view word) {
  double value = 0;
  const auto [end, ec] = std::from_chars(word.data(), word.data() + word.size(), value);
  if (ec != std::errc{} || end != word.data() + word.size() || !std::isfinite(value)) return std::nullopt;
  return value;
}

std::optional<std::int64_t> integer(std::string_view word) {
  std::int64_t value = 0;
  const auto [end, ec] = std::from_chars(word.data(), word.data() + word.size(), value);
  if (ec != std::errc{} || end != word.data() + word.size()) return std::nullopt;
  return value;
}

std::expected<Mesh, InputError> checked_mesh(Mesh mesh, std::string_view source) {
  for (const auto& t : mesh.triangles)
    for (const auto v : t)
      if (v >= mesh.positions.size())
        return std::unexpected(InputError{
            std::string(source), 0, 0,
            "a face names vertex " + std::to_string(v) + " of only " + std::to_string(mesh.positions.size())});
  mesh = with_vertex_normals(std::move(mesh));
  if (mesh.triangles.empty())
    return std::unexpected(InputError{std::string(source), 0, 0, "the mesh has no triangle of non-zero area"});
  return mesh;
}

}  // namespace skinspec::render::detail
