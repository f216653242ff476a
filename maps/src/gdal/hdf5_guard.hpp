#pragma once
// HDF5 files whose data is kept outside them. HDF5 lets a dataset's values be any other file (a
// dataset stored externally, or a virtual dataset), and a link lead into another file. GDAL
// follows them all: an uploaded HDF5 "cube" whose values are the service's database or TLS key
// would be read, mapped and served back. Such a file is refused before GDAL opens it.
//
// HDF5 as Debian builds it is not thread-safe, and two maps may read HDF5 cubes at once; every
// call into it, ours and GDAL's on our behalf, holds hdf5_mutex().

#include <expected>
#include <mutex>
#include <string>

#include "skinspec/maps/cube.hpp"

namespace skinspec::maps::detail {

std::recursive_mutex& hdf5_mutex();

// Nothing if `file` is not HDF5 or keeps everything inside itself; else an error naming `path`
// and the dataset or link that leads out. Hold hdf5_mutex().
std::expected<void, CubeError> refuse_data_outside(const std::string& path, const std::string& file);

}  // namespace skinspec::maps::detail
