#pragma once
// GDAL once per process, as the maps library uses it (cube.cpp).

namespace skinspec::maps::detail {

// Every driver registered; no side files (a .aux.xml beside a cube that was only read); GDAL's
// errors kept for our messages instead of printed.
void start_gdal();

}  // namespace skinspec::maps::detail
