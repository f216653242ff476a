#pragma once
// A map's data as the store keeps it (docs/store.md, "Maps"): pieces of kMapPieceBytes of raw
// data each (the last one shorter), each deflated with zlib on its own, so that a piece is
// written and read without holding the rest.

#include <cstdint>
#include <span>
#include <string>
#include <string_view>

namespace skinspec::store::detail {

inline constexpr std::int64_t kMapPieceBytes = std::int64_t{1} << 20;

// How many pieces `size` bytes of raw data make.
std::int64_t map_piece_count(std::int64_t size);
// The raw length of piece `piece` of `size` bytes.
std::int64_t map_piece_length(std::int64_t size, std::int64_t piece);

// `raw` deflated (zlib's format).
std::string deflate_piece(std::span<const char> raw);
// Inflates `stored` into `out`, which it must fill exactly; throws Failure (corrupt) naming
// `what` otherwise.
void inflate_piece(std::string_view stored, std::span<char> out, std::string_view what);

}  // namespace skinspec::store::detail
