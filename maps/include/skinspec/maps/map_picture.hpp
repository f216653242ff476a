#pragma once
// A parameter's map as a picture: the band over the image in the maps' colour map, with a
// colour bar that gives the values at its ends and middle, the parameter's name and unit, and
// swatches of the colours for "not determined" and "not skin" (docs/maps.md, "Pictures").

#include <cstddef>
#include <span>

#include "skinspec/maps/mapper.hpp"
#include "skinspec/render/image.hpp"

namespace skinspec::maps {

// `values` and `mask` hold the answer cube's band of the parameter and its mask band, line by
// line; values between `low` and `high` span the colour map (outside it, its ends). Small maps
// are drawn with each pixel enlarged to a square, so that the picture is at least 256 pixels
// on its longer side.
render::Image parameter_picture(std::span<const float> values, std::span<const float> mask, std::size_t lines,
                                std::size_t samples, const MapBand& band, double low, double high);

}  // namespace skinspec::maps
