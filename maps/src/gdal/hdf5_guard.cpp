#include "gdal/hdf5_guard.hpp"

#include <hdf5.h>

#include <fmt/format.h>

#include <optional>

namespace skinspec::maps::detail {

namespace {

// What leads out of the file, and where: the first found.
struct Outside {
  std::optional<CubeError> found;
  const std::string* path;
};

herr_t check_link(hid_t, const char* name, const H5L_info_t* info, void* data) {
  auto& outside = *static_cast<Outside*>(data);
  if (info->type == H5L_TYPE_HARD || info->type == H5L_TYPE_SOFT) return 0;
  outside.found = CubeError{*outside.path, name, "a link into another file; a cube must be one self-contained file"};
  return 1;
}

herr_t check_object(hid_t file, const char* name, const H5O_info_t* info, void* data) {
  if (info->type != H5O_TYPE_DATASET) return 0;
  auto& outside = *static_cast<Outside*>(data);
  const hid_t dataset = H5Dopen2(file, name, H5P_DEFAULT);
  if (dataset < 0) return 0;  // what cannot be opened cannot be read either
  const hid_t creation = H5Dget_create_plist(dataset);
  const bool external = creation >= 0 && H5Pget_external_count(creation) > 0;
  const bool is_virtual = creation >= 0 && H5Pget_layout(creation) == H5D_VIRTUAL;
  if (creation >= 0) H5Pclose(creation);
  H5Dclose(dataset);
  if (!external && !is_virtual) return 0;
  outside.found = CubeError{*outside.path, name,
                            fmt::format("its values are kept in other files ({} dataset); a cube must be one "
                                        "self-contained file",
                                        external ? "an external" : "a virtual")};
  return 1;
}

}  // namespace

std::recursive_mutex& hdf5_mutex() {
  static std::recursive_mutex mutex;
  return mutex;
}

std::expected<void, CubeError> refuse_data_outside(const std::string& path, const std::string& file) {
  Outside outside{std::nullopt, &path};
  H5E_BEGIN_TRY {
    if (H5Fis_hdf5(file.c_str()) > 0) {
      const hid_t h5 = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
      if (h5 >= 0) {
        H5Lvisit(h5, H5_INDEX_NAME, H5_ITER_NATIVE, check_link, &outside);
        if (!outside.found) H5Ovisit2(h5, H5_INDEX_NAME, H5_ITER_NATIVE, check_object, &outside, H5O_INFO_BASIC);
        H5Fclose(h5);
      }
    }
  }
  H5E_END_TRY;
  if (outside.found) return std::unexpected(*outside.found);
  return {};
}

}  // namespace skinspec::maps::detail
