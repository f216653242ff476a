#pragma once

#include <string>

namespace skinspec::maps {

// One band of the answer cube: its name and unit, as the ENVI header gives them.
struct MapBand {
  std::string name;
  std::string unit;
};

}  // namespace skinspec::maps
