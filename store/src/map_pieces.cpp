#include "map_pieces.hpp"

#include <fmt/format.h>
#include <zlib.h>

#include <algorithm>

#include "db.hpp"

namespace skinspec::store::detail {

namespace {

// The store holds the writer while it deflates a map's pieces, and a cube's floats gain little
// from zlib's harder levels: the fastest one.
constexpr int kLevel = Z_BEST_SPEED;

const Bytef* bytes_of(const char* data) { return reinterpret_cast<const Bytef*>(data); }

}  // namespace

std::int64_t map_piece_count(std::int64_t size) { return (size + kMapPieceBytes - 1) / kMapPieceBytes; }

std::int64_t map_piece_length(std::int64_t size, std::int64_t piece) {
  return std::clamp<std::int64_t>(size - piece * kMapPieceBytes, 0, kMapPieceBytes);
}

std::string deflate_piece(std::span<const char> raw) {
  std::string out(compressBound(static_cast<uLong>(raw.size())), '\0');
  auto length = static_cast<uLongf>(out.size());
  const int status = compress2(reinterpret_cast<Bytef*>(out.data()), &length, bytes_of(raw.data()),
                               static_cast<uLong>(raw.size()), kLevel);
  if (status != Z_OK)
    fail(StoreError::Kind::internal, fmt::format("deflating a piece of a map: zlib status {}", status));
  out.resize(length);
  return out;
}

void inflate_piece(std::string_view stored, std::span<char> out, std::string_view what) {
  auto length = static_cast<uLongf>(out.size());
  const int status = uncompress(reinterpret_cast<Bytef*>(out.data()), &length, bytes_of(stored.data()),
                                static_cast<uLong>(stored.size()));
  // Z_BUF_ERROR: more data than the piece's length (or, for an empty one, any data at all).
  if (status != Z_OK || length != out.size()) {
    fail(StoreError::Kind::corrupt,
         fmt::format("{}: its {} stored bytes do not inflate to {} bytes (zlib status {}, {} bytes)", what,
                     stored.size(), out.size(), status, length));
  }
}

}  // namespace skinspec::store::detail
