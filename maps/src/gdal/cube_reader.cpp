// The cube reader of the GDAL module (gdal_io.hpp): ENVI and TIFF images,
// and containers of arrays (array_cube.hpp).
#include "gdal/cube_reader.hpp"

#include "gdal/array_cube.hpp"
#include "gdal/gdal_support.hpp"
#include "gdal/hdf5_guard.hpp"

#include <gdal_priv.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cpl_conv.h>
#include <cpl_error.h>
#include <cpl_vsi.h>
#include <filesystem>
#include <fmt/format.h>
#include <limits>
#include <mutex>
#include <optional>
#include <string_view>

namespace skinspec::maps {

namespace {

class GdalCubeData final : public gdal_io::CubeData {
 public:
  GdalCubeData() = default;
  GdalCubeData(const GdalCubeData&) = delete;
  GdalCubeData& operator=(const GdalCubeData&) = delete;
  ~GdalCubeData() override {
    if (!container) return;
    const std::lock_guard hdf5(detail::hdf5_mutex());  // closing it calls HDF5
    array.reset();
    container.reset();
  }

  std::expected<void, CubeError> read_lines(const CubeInfo& info, std::size_t first, std::size_t count,
                                            std::vector<float>& values) const override;

  std::unique_ptr<GDALDataset> gdal;  // an image: ENVI, TIFF, ...
  bool pixel_interleaved = true;      // its bands together for each pixel, in its file
  // Or a container of arrays (HDF5, netCDF) and its cube's array, with which of its dimensions
  // runs along the bands, the samples and the lines.
  std::unique_ptr<GDALDataset> container;
  std::shared_ptr<GDALMDArray> array;
  std::size_t band_dim = 0, sample_dim = 0, line_dim = 0;
};

using detail::increasing;
using detail::last_gdal_error;
using detail::lower;
using detail::nanometres_per;

std::optional<double> number(std::string_view text) {
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.front()))) text.remove_prefix(1);
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back()))) text.remove_suffix(1);
  double value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || text.empty()) return std::nullopt;
  return value;
}

// "{400, 410.5, ...}" (an ENVI list) as numbers; nullopt if any is not one.
std::optional<std::vector<double>> number_list(std::string_view text) {
  if (const auto open = text.find('{'); open != std::string_view::npos) text.remove_prefix(open + 1);
  if (const auto close = text.rfind('}'); close != std::string_view::npos) text = text.substr(0, close);
  std::vector<double> values;
  while (!text.empty()) {
    const auto comma = text.find(',');
    const auto value = number(text.substr(0, comma));
    if (!value) return std::nullopt;
    values.push_back(*value);
    if (comma == std::string_view::npos) break;
    text.remove_prefix(comma + 1);
  }
  return values;
}

// An ENVI header field as GDAL keeps it, in its "ENVI" metadata domain, under its own name or
// with underscores for the spaces.
const char* envi_item(GDALDataset& d, std::string_view field) {
  std::string key(field);
  if (const char* value = d.GetMetadataItem(key.c_str(), "ENVI")) return value;
  std::ranges::replace(key, ' ', '_');
  return d.GetMetadataItem(key.c_str(), "ENVI");
}

// The band centres in nm: the ENVI header's list, else each band's "wavelength" item.
std::expected<std::vector<double>, CubeError> wavelengths(GDALDataset& d, const std::string& file) {
  std::optional<std::vector<double>> values;
  std::string units;
  if (const char* list = envi_item(d, "wavelength")) {
    values = number_list(list);
    if (!values) return std::unexpected(CubeError{file, "wavelength", fmt::format("not a list of numbers: {}", list)});
    if (const char* u = envi_item(d, "wavelength units")) units = u;
  } else {
    std::vector<double> per_band;
    for (int b = 1; b <= d.GetRasterCount(); ++b) {
      const char* item = d.GetRasterBand(b)->GetMetadataItem("wavelength");
      const auto value = item ? number(item) : std::nullopt;
      if (!value) break;
      per_band.push_back(*value);
      if (const char* u = d.GetRasterBand(b)->GetMetadataItem("wavelength_units")) units = u;
    }
    if (!per_band.empty()) values = std::move(per_band);
  }
  if (!values) return std::unexpected(CubeError{file, "wavelength", "missing: the band centres are needed to fit"});
  if (values->size() != static_cast<std::size_t>(d.GetRasterCount()))
    return std::unexpected(
        CubeError{file, "wavelength", fmt::format("{} values for {} bands", values->size(), d.GetRasterCount())});
  const auto scale = nanometres_per(units);
  if (!scale) return std::unexpected(CubeError{file, "wavelength units", fmt::format("unknown unit '{}'", units)});
  for (double& w : *values) w *= *scale;
  return increasing(std::move(*values), file);
}

std::optional<double> type_maximum(GDALDataType type) {
  switch (type) {
    case GDT_Byte:
      return 255.0;
    case GDT_UInt16:
      return 65535.0;
    case GDT_Int16:
      return 32767.0;
    case GDT_UInt32:
      return 4294967295.0;
    case GDT_Int32:
      return 2147483647.0;
    default:
      return std::nullopt;
  }
}

// ENVI's data file must hold exactly what its header describes: a GDAL raw dataset reads
// zeros (or fails late) past a short file, and a longer one means the sizes are wrong.
std::optional<CubeError> envi_size_error(GDALDataset& d, const CubeInfo& info) {
  // An image made from an array has no driver of its own.
  if (!d.GetDriver() || std::string_view(d.GetDriver()->GetDescription()) != "ENVI") return std::nullopt;
  char** files = d.GetFileList();
  std::string data_file = files && files[0] ? files[0] : "";
  CSLDestroy(files);
  VSIStatBufL stat{};
  if (data_file.empty() || VSIStatL(data_file.c_str(), &stat) != 0) return std::nullopt;
  const auto offset = number(envi_item(d, "header offset") ? envi_item(d, "header offset") : "0").value_or(0);
  const auto bytes = static_cast<double>(GDALGetDataTypeSizeBytes(d.GetRasterBand(1)->GetRasterDataType()));
  // In floating point: a header's sizes may multiply past any integer type.
  const double needed = offset + static_cast<double>(info.lines) * static_cast<double>(info.samples) *
                                     static_cast<double>(info.bands) * bytes;
  if (static_cast<double>(stat.st_size) == needed) return std::nullopt;
  return CubeError{info.file, "lines",
                   fmt::format("{} samples × {} lines × {} bands of {} bytes after a header offset of {} need {} "
                               "bytes; the data file {} has {}",
                               info.samples, info.lines, info.bands, bytes, offset, needed, data_file, stat.st_size)};
}

// GDAL opens an ENVI cube by its data file; people name the header. The data file is the
// header's name without ".hdr", or with one of the usual extensions instead.
std::expected<std::string, CubeError> data_file_of(const std::string& path) {
  const std::filesystem::path header(path);
  if (lower(header.extension().string()) != ".hdr") return path;
  const std::filesystem::path stem = header.parent_path() / header.stem();
  for (const char* extension : {"", ".img", ".dat", ".raw", ".bil", ".bsq", ".bip", ".bin", ".IMG", ".DAT", ".RAW"}) {
    std::filesystem::path candidate = stem;
    candidate += extension;
    std::error_code error;
    if (std::filesystem::is_regular_file(candidate, error)) return candidate.string();
  }
  return std::unexpected(CubeError{path, "",
                                   fmt::format("no data file beside the header (looked for {} with no "
                                               "extension, .img, .dat, .raw, .bil, .bsq, .bip or .bin)",
                                               stem.string())});
}

// A cube that is an array of a container (HDF5, netCDF) at `file`, named `path` in errors.
std::expected<gdal_io::OpenedCube, CubeError> open_array(const std::string& path, const std::string& file) {
  auto arrays = detail::open_array_cube(file);
  if (!arrays) return std::unexpected(arrays.error());
  auto dataset = std::make_unique<GdalCubeData>();
  const auto& dims = arrays->array->GetDimensions();
  CubeInfo info;
  info.file = path;
  info.lines = static_cast<std::size_t>(dims[arrays->line_dim]->GetSize());
  info.samples = static_cast<std::size_t>(dims[arrays->sample_dim]->GetSize());
  info.bands = static_cast<std::size_t>(dims[arrays->band_dim]->GetSize());
  const GDALExtendedDataType& type = arrays->array->GetDataType();
  if (type.GetClass() != GEDTC_NUMERIC || GDALDataTypeIsComplex(type.GetNumericDataType()))
    return std::unexpected(CubeError{path, "data type", "the cube's values are not real numbers"});
  info.type_maximum = type_maximum(type.GetNumericDataType());
  if (auto checked = increasing(std::move(arrays->wavelength_nm), path)) info.wavelength_nm = std::move(*checked);
  else return std::unexpected(checked.error());
  bool has = false;
  const double no_data = arrays->array->GetNoDataValueAsDouble(&has);
  if (has) info.ignore_value = no_data;
  info.files = {file};
  dataset->container = std::move(arrays->container);
  dataset->array = std::move(arrays->array);
  dataset->band_dim = arrays->band_dim, dataset->sample_dim = arrays->sample_dim, dataset->line_dim = arrays->line_dim;
  return gdal_io::OpenedCube{std::move(dataset), std::move(info)};
}

}  // namespace

std::expected<gdal_io::OpenedCube, CubeError> open_gdal_cube(const std::string& path) {
  detail::start_gdal();
  CPLErrorReset();
  const auto data_file = data_file_of(path);
  if (!data_file) return std::unexpected(data_file.error());
  const std::lock_guard hdf5(detail::hdf5_mutex());
  if (auto inside = detail::refuse_data_outside(path, *data_file); !inside) return std::unexpected(inside.error());
  auto dataset = std::make_unique<GdalCubeData>();
  dataset->gdal.reset(GDALDataset::Open(data_file->c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, detail::kCubeDrivers));
  if (!dataset->gdal) {
    const std::string why = last_gdal_error();
    const bool type =
        lower(why).find("data type") != std::string::npos || lower(why).find("data_type") != std::string::npos;
    const std::string field = type ? "data type" : "";
    return std::unexpected(CubeError{
        path, field, fmt::format("not a spectral image in a format read here ({}): {}", detail::kCubeFormats, why)});
  }
  // Containers of arrays are read as arrays: GDAL's image of their one dataset knows neither
  // its wavelengths nor MATLAB's column order.
  const std::string_view driver = dataset->gdal->GetDriver()->GetDescription();
  if (dataset->gdal->GetRasterCount() == 0 || driver == "HDF5" || driver == "HDF5Image" || driver == "netCDF") {
    dataset->gdal.reset();
    return open_array(path, *data_file);
  }
  GDALDataset& d = *dataset->gdal;
  const char* interleave = d.GetMetadataItem("INTERLEAVE", "IMAGE_STRUCTURE");
  dataset->pixel_interleaved = !interleave || std::string_view(interleave) == "PIXEL";
  CubeInfo info;
  info.file = path;
  char** files = d.GetFileList();
  for (char** f = files; f && *f; ++f) info.files.emplace_back(*f);
  CSLDestroy(files);
  info.lines = static_cast<std::size_t>(d.GetRasterYSize());
  info.samples = static_cast<std::size_t>(d.GetRasterXSize());
  info.bands = static_cast<std::size_t>(d.GetRasterCount());
  if (info.bands == 0) return std::unexpected(CubeError{path, "bands", "the image has no bands"});
  const GDALDataType type = d.GetRasterBand(1)->GetRasterDataType();
  if (GDALDataTypeIsComplex(type))
    return std::unexpected(
        CubeError{path, "data type", fmt::format("{} is not a real number", GDALGetDataTypeName(type))});
  info.type_maximum = type_maximum(type);
  if (auto w = wavelengths(d, path)) info.wavelength_nm = std::move(*w);
  else return std::unexpected(w.error());
  if (const char* scale = envi_item(d, "reflectance scale factor")) {
    const auto value = number(scale);
    if (!value || !(*value > 0))
      return std::unexpected(
          CubeError{path, "reflectance scale factor", fmt::format("not a positive number: {}", scale)});
    info.reflectance_scale = *value;
  }
  if (const char* ignore = envi_item(d, "data ignore value")) {
    info.ignore_value = number(ignore);
    if (!info.ignore_value)
      return std::unexpected(CubeError{path, "data ignore value", fmt::format("not a number: {}", ignore)});
  } else {
    int has = 0;
    const double no_data = d.GetRasterBand(1)->GetNoDataValue(&has);
    if (has) info.ignore_value = no_data;
  }
  if (auto error = envi_size_error(d, info)) return std::unexpected(*error);
  return gdal_io::OpenedCube{std::move(dataset), std::move(info)};
}

namespace {

// Lines of a cube stored band by band or line by line, each read as its bands lie in the file
// (a run of samples each) and then turned pixel by pixel, in tiles that stay in the processor's
// cache. Asked for pixel order, GDAL wrote each sample a band's length from the one before, a
// cache line each: reading a 512 x 512 x 101 BIL cube took 0.18 s of a core rather than 0.13 s.
// A line at a time, so that the extra memory is a line's, not a block's.
CPLErr read_by_bands(GDALDataset& gdal, const CubeInfo& info, std::size_t first, std::size_t count, float* pixels) {
  const std::size_t samples = info.samples, bands = info.bands;
  std::vector<float> by_band(bands * samples);
  const auto word = static_cast<GSpacing>(sizeof(float));
  const auto direct = detail::direct_raw_io();
  for (std::size_t l = 0; l < count; ++l) {
    const CPLErr result =
        gdal.RasterIO(GF_Read, 0, static_cast<int>(first + l), static_cast<int>(samples), 1, by_band.data(),
                      static_cast<int>(samples), 1, GDT_Float32, static_cast<int>(bands), nullptr, word,
                      static_cast<GSpacing>(bands * samples) * word, static_cast<GSpacing>(samples) * word, nullptr);
    if (result != CE_None) return result;
    constexpr std::size_t kTile = 16;
    float* out = pixels + l * samples * bands;
    for (std::size_t b0 = 0; b0 < bands; b0 += kTile)
      for (std::size_t s0 = 0; s0 < samples; s0 += kTile)
        for (std::size_t b = b0; b < std::min(bands, b0 + kTile); ++b)
          for (std::size_t s = s0; s < std::min(samples, s0 + kTile); ++s)
            out[s * bands + b] = by_band[b * samples + s];
  }
  return CE_None;
}

}  // namespace

std::expected<void, CubeError> GdalCubeData::read_lines(const CubeInfo& info, std::size_t first, std::size_t count,
                                                        std::vector<float>& values) const {
  values.resize(count * info.samples * info.bands);
  const auto bands = static_cast<GSpacing>(info.bands);
  const auto word = static_cast<GSpacing>(sizeof(float));
  CPLErrorReset();
  CPLErr result = CE_None;
  if (!array && !pixel_interleaved) {
    result = read_by_bands(*gdal, info, first, count, values.data());
  } else if (!array) {
    result = gdal->RasterIO(GF_Read, 0, static_cast<int>(first), static_cast<int>(info.samples),
                            static_cast<int>(count), values.data(), static_cast<int>(info.samples),
                            static_cast<int>(count), GDT_Float32, static_cast<int>(info.bands), nullptr, bands * word,
                            bands * static_cast<GSpacing>(info.samples) * word, word, nullptr);
  } else {
    const std::lock_guard hdf5(detail::hdf5_mutex());
    // The array's own dimensions, read straight into pixel-interleaved order.
    std::array<GUInt64, 3> start{};
    std::array<std::size_t, 3> counts{};
    std::array<GPtrDiff_t, 3> strides{};
    start[line_dim] = first;
    counts[line_dim] = count, counts[sample_dim] = info.samples, counts[band_dim] = info.bands;
    strides[band_dim] = 1, strides[sample_dim] = static_cast<GPtrDiff_t>(info.bands),
    strides[line_dim] = static_cast<GPtrDiff_t>(info.samples * info.bands);
    if (!array->Read(start.data(), counts.data(), nullptr, strides.data(), GDALExtendedDataType::Create(GDT_Float32),
                     values.data()))
      result = CE_Failure;
  }
  if (result != CE_None)
    return std::unexpected(CubeError{
        info.file, "", fmt::format("lines {}-{} cannot be read: {}", first, first + count - 1, last_gdal_error())});
  // GDAL reads a raw file cut short after it was opened as zeros, silently: a cube truncated
  // while it was mapped (a copy still arriving, a share going away) gave a whole map of "too
  // dark" pixels. Its size is checked again after every read.
  if (!array)
    if (auto error = envi_size_error(*gdal, info)) return std::unexpected(*error);
  return {};
}

}  // namespace skinspec::maps
