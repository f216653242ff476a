// PLY (Stanford polygon files) as written by scanners: a text header describing elements and
// their typed properties, then an ASCII or binary little-endian body. Only vertex positions and
// face index lists are kept; every other element and property is read past.

#include <algorithm>
#include <bit>
#include <cstring>

#include "mesh_text.hpp"
#include "skinspec/spectral/utf8.hpp"

namespace skinspec::render {

namespace {

using detail::finite_number;
using detail::integer;

enum class Type { i8, u8, i16, u16, i32, u32, f32, f64 };

std::optional<Type> type_named(std::string_view name) {
  static constexpr std::pair<std::string_view, Type> kNames[] = {
      {"char", Type::i8},   {"int8", Type::i8},     {"uchar", Type::u8},   {"uint8", Type::u8},
      {"short", Type::i16}, {"int16", Type::i16},   {"ushort", Type::u16}, {"uint16", Type::u16},
      {"int", Type::i32},   {"int32", Type::i32},   {"uint", Type::u32},   {"uint32", Type::u32},
      {"float", Type::f32}, {"float32", Type::f32}, {"double", Type::f64}, {"float64", Type::f64}};
  for (const auto& [n, t] : kNames)
    if (n == name) return t;
  return std::nullopt;
}

struct Property {
  std::string name;
  Type type = Type::f32;
  std::optional<Type> list_count;  // set for `property list COUNT ITEM name`
};

struct Element {
  std::string name;
  std::size_t count = 0;
  std::vector<Property> properties;
};

struct Header {
  bool binary = false;
  std::vector<Element> elements;
};

InputError error_at(std::string_view source, std::size_t line, std::string message) {
  return {std::string(source), line, 0, std::move(message)};
}

std::optional<InputError> header_line(Header& header, const std::vector<std::string_view>& w, std::size_t line,
                                      std::string_view source) {
  if (w[0] == "comment" || w[0] == "obj_info") return std::nullopt;
  if (w[0] == "format") {
    if (w.size() != 3) return error_at(source, line, "format needs a kind and a version");
    if (w[1] == "binary_big_endian")
      return error_at(source, line, "binary big-endian PLY is not supported; use ASCII or little-endian");
    if (w[1] != "ascii" && w[1] != "binary_little_endian")
      return error_at(source, line, "unknown format " + quote(w[1]));
    header.binary = w[1] == "binary_little_endian";
    return std::nullopt;
  }
  if (w[0] == "element") {
    const auto count = w.size() == 3 ? integer(w[2]) : std::nullopt;
    if (!count || *count < 0) return error_at(source, line, "an element needs a name and a count of zero or more");
    header.elements.push_back({std::string(w[1]), static_cast<std::size_t>(*count), {}});
    return std::nullopt;
  }
  if (w[0] == "property") {
    if (header.elements.empty()) return error_at(source, line, "a property before any element");
    const bool list = w.size() == 5 && w[1] == "list";
    const auto type = type_named(w[list ? 3 : 1]);
    const auto count = list ? type_named(w[2]) : std::nullopt;
    if ((w.size() != 3 && !list) || !type || (list && !count))
      return error_at(source, line, "a property needs a known type and a name");
    header.elements.back().properties.push_back({std::string(w.back()), *type, count});
    return std::nullopt;
  }
  return error_at(source, line, "unknown header line " + quote(w[0]));
}

// Reads values in body order from text lines (one element instance per line).
class AsciiBody {
 public:
  AsciiBody(detail::LineReader lines, std::string_view source) : lines_(lines), source_(source) {}

  std::optional<InputError> start_item() {
    do {
      const auto line = lines_.next();
      if (!line) return error("the file ends before every element declared in the header");
      words_ = detail::words(*line);
    } while (words_.empty());
    next_ = 0;
    return std::nullopt;
  }
  std::expected<double, InputError> value(Type) {
    if (next_ >= words_.size()) return std::unexpected(error("too few values on the line"));
    const auto v = finite_number(words_[next_]);
    if (!v) return std::unexpected(error("not a finite number: " + quote(words_[next_])));
    ++next_;
    return *v;
  }
  // An error at the line being read.
  InputError error(std::string message) const { return error_at(source_, lines_.line(), std::move(message)); }

 private:
  detail::LineReader lines_;
  std::string_view source_;
  std::vector<std::string_view> words_;
  std::size_t next_ = 0;
};

// Reads values in body order from little-endian bytes.
class BinaryBody {
 public:
  BinaryBody(std::string_view bytes, std::string_view source) : bytes_(bytes), source_(source) {}

  std::optional<InputError> start_item() {
    item_offset_ = offset_;
    return std::nullopt;
  }
  std::expected<double, InputError> value(Type type) {
    switch (type) {
      case Type::i8:
        return read<std::int8_t>();
      case Type::u8:
        return read<std::uint8_t>();
      case Type::i16:
        return read<std::int16_t>();
      case Type::u16:
        return read<std::uint16_t>();
      case Type::i32:
        return read<std::int32_t>();
      case Type::u32:
        return read<std::uint32_t>();
      case Type::f32:
        return read<float>();
      case Type::f64:
        return read<double>();
    }
    return std::unexpected(error("unknown property type"));
  }
  // An error at the item being read, located by its byte offset in the body.
  InputError error(std::string message) const {
    return error_at(source_, 0, message + " (binary body, item at byte " + std::to_string(item_offset_) + ")");
  }

 private:
  template <typename T>
  std::expected<double, InputError> read() {
    static_assert(std::endian::native == std::endian::little, "binary PLY is read on little-endian machines only");
    if (bytes_.size() - offset_ < sizeof(T))
      return std::unexpected(error("the binary body ends before every element declared in the header"));
    T v;
    std::memcpy(&v, bytes_.data() + offset_, sizeof(T));
    offset_ += sizeof(T);
    const auto out = static_cast<double>(v);
    if (!std::isfinite(out)) return std::unexpected(error("a value that is not finite"));
    return out;
  }

  std::string_view bytes_;
  std::string_view source_;
  std::size_t offset_ = 0, item_offset_ = 0;
};

// A list property's entries as vertex indices, each naming one of `vertex_count` vertices.
template <typename Body>
std::expected<std::vector<std::uint32_t>, InputError> read_index_list(Body& body, const Property& property,
                                                                      std::size_t vertex_count) {
  const auto n = body.value(*property.list_count);
  if (!n) return std::unexpected(n.error());
  if (*n < 0 || *n > 1e6) return std::unexpected(body.error("a list of " + std::to_string(*n) + " entries"));
  std::vector<std::uint32_t> indices;
  for (int i = 0; i < static_cast<int>(*n); ++i) {
    const auto v = body.value(property.type);
    if (!v) return std::unexpected(v.error());
    if (*v < 0 || *v >= static_cast<double>(vertex_count))
      return std::unexpected(body.error("vertex " + std::to_string(static_cast<long long>(*v)) + " is not among the " +
                                        std::to_string(vertex_count) + " vertices"));
    indices.push_back(static_cast<std::uint32_t>(*v));
  }
  return indices;
}

bool is_face_indices(const Element& element, const Property& property) {
  return element.name == "face" && (property.name == "vertex_indices" || property.name == "vertex_index");
}

// One instance of `element`: a vertex's position, a face's triangles, or values read past.
template <typename Body>
std::optional<InputError> read_item(Body& body, const Element& element, Mesh& mesh) {
  if (auto failed = body.start_item()) return failed;
  Vec3 p;
  for (const Property& property : element.properties) {
    if (property.list_count) {
      const auto corners = read_index_list(body, property, mesh.positions.size());
      if (!corners) return corners.error();
      if (!is_face_indices(element, property)) continue;
      if (corners->size() < 3) return body.error("a face needs at least three vertices");
      for (std::size_t i = 1; i + 1 < corners->size(); ++i)
        mesh.triangles.push_back({(*corners)[0], (*corners)[i], (*corners)[i + 1]});
      continue;
    }
    const auto v = body.value(property.type);
    if (!v) return v.error();
    if (property.name == "x") p.x = *v;
    else if (property.name == "y") p.y = *v;
    else if (property.name == "z") p.z = *v;
  }
  if (element.name == "vertex") mesh.positions.push_back(p);
  return std::nullopt;
}

template <typename Body>
std::expected<Mesh, InputError> read_body(Body body, const Header& header, std::string_view source) {
  Mesh mesh;
  for (const Element& element : header.elements)
    for (std::size_t item = 0; item < element.count; ++item)
      if (auto failed = read_item(body, element, mesh)) return std::unexpected(*failed);
  return detail::checked_mesh(std::move(mesh), source);
}

// The header's own promises: x, y, z on vertices, an index list on faces, vertices first, and
// no more items than the body has bytes (so a corrupt count cannot demand gigabytes).
std::optional<InputError> check_header(const Header& header, std::size_t body_bytes, std::size_t line,
                                       std::string_view source) {
  bool seen_vertex = false;
  for (const Element& e : header.elements) {
    if (e.count > body_bytes)
      return error_at(source, line, "element " + e.name + " declares more items than the file has bytes");
    const auto has = [&](std::string_view name) {
      return std::ranges::any_of(e.properties, [&](const Property& p) { return p.name == name; });
    };
    if (e.name == "vertex" && !(has("x") && has("y") && has("z")))
      return error_at(source, line, "vertices need x, y and z properties");
    if (e.name == "face" && !(has("vertex_indices") || has("vertex_index")))
      return error_at(source, line, "faces need a vertex_indices list");
    if (e.name == "face" && !seen_vertex) return error_at(source, line, "faces come before the vertices");
    seen_vertex = seen_vertex || e.name == "vertex";
  }
  return std::nullopt;
}

}  // namespace

std::expected<Mesh, InputError> parse_ply(std::string_view bytes, std::string_view source) {
  detail::LineReader lines(bytes);
  const auto magic = lines.next();
  if (!magic || *magic != "ply")
    return std::unexpected(error_at(source, 1, "not a PLY file: the first line must be 'ply'"));
  Header header;
  bool ended = false, has_format = false;
  while (const auto line = lines.next()) {
    const auto w = detail::words(*line);
    if (w.empty()) continue;
    if (w[0] == "end_header") {
      ended = true;
      break;
    }
    has_format = has_format || w[0] == "format";
    if (auto failed = header_line(header, w, lines.line(), source)) return std::unexpected(*failed);
  }
  if (!ended || !has_format)
    return std::unexpected(error_at(source, lines.line(), "the header has no format line or no end_header"));
  if (auto failed = check_header(header, lines.rest().size(), lines.line(), source)) return std::unexpected(*failed);
  if (header.binary) return read_body(BinaryBody(lines.rest(), source), header, source);
  return read_body(AsciiBody(lines, source), header, source);
}

}  // namespace skinspec::render
