#pragma once
// Line and number reading shared by the OBJ and ASCII PLY readers.

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "skinspec/render/mesh.hpp"
#include "skinspec/spectral/table.hpp"

namespace skinspec::render::detail {

// Splits bytes into lines, numbering them from 1; a trailing '\r' is dropped.
class LineReader {
 public:
  explicit LineReader(std::string_view bytes) : rest_(bytes) {}
  std::optional<std::string_view> next();
  std::size_t line() const { return line_; }
  // What follows the last line read (for a binary body after a text header).
  std::string_view rest() const { return rest_; }

 private:
  std::string_view rest_;
  std::size_t line_ = 0;
};

// Whitespace-separated words.
std::vector<std::string_view> words(std::string_view line);
// A finite number, or nothing.
std::optional<double> finite_number(std::string_view word);
std::optional<std::int64_t> integer(std::string_view word);

// A mesh with at least one triangle whose every index names a vertex, or the error why not.
std::expected<Mesh, InputError> checked_mesh(Mesh mesh, std::string_view source);

}  // namespace skinspec::render::detail
