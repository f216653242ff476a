// A map's answer cube written through GDAL (gdal_io.hpp's AnswerFile): ENVI, band-interleaved
// by line, with the band names and units in its header, or a tiled float TIFF with them as band
// metadata; NaN is every band's no-data value (not determined, or not skin).

#include "gdal/answer_file.hpp"

#include <gdal_priv.h>

#include <fmt/format.h>

#include <limits>

#include "gdal/gdal_support.hpp"

namespace skinspec::maps {

namespace {

// An ENVI header list cannot hold commas inside its items.
std::string header_item(std::string text) {
  for (char& c : text)
    if (c == ',' || c == '{' || c == '}') c = ';';
  return text;
}

class GdalAnswerFile final : public gdal_io::AnswerFile {
 public:
  GdalAnswerFile(std::filesystem::path file, std::unique_ptr<GDALDataset> cube, std::size_t samples, std::size_t bands)
      : file_(std::move(file)), cube_(std::move(cube)), samples_(samples), bands_(bands) {}

  std::expected<void, std::string> write_lines(std::size_t first, std::size_t count,
                                               std::span<const float> answers) override {
    const auto bands = static_cast<GSpacing>(bands_);
    const auto direct = detail::direct_raw_io();
    const CPLErr result = cube_->RasterIO(
        GF_Write, 0, static_cast<int>(first), static_cast<int>(samples_), static_cast<int>(count),
        const_cast<float*>(answers.data()), static_cast<int>(samples_), static_cast<int>(count), GDT_Float32,
        static_cast<int>(bands_), nullptr, bands * static_cast<GSpacing>(sizeof(float)),
        bands * static_cast<GSpacing>(samples_ * sizeof(float)), static_cast<GSpacing>(sizeof(float)), nullptr);
    if (result != CE_None) return std::unexpected(fmt::format("cannot write the map: {}", CPLGetLastErrorMsg()));
    return {};
  }

  std::expected<void, std::string> close_and_reopen() override {
    CPLErrorReset();
    cube_->FlushCache(true);
    const std::string driver = cube_->GetDriver()->GetDescription();
    cube_.reset();  // closing writes the header
    if (CPLGetLastErrorType() >= CE_Failure)
      return std::unexpected(fmt::format("cannot write the map: {}", CPLGetLastErrorMsg()));
    const char* const written_by[] = {driver.c_str(), nullptr};
    const auto uncached = detail::uncached_files();
    cube_.reset(GDALDataset::Open(file_.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, written_by));
    if (!cube_) return std::unexpected(fmt::format("cannot read the map back: {}", CPLGetLastErrorMsg()));
    return {};
  }

  std::expected<std::vector<float>, std::string> read_band(int index) const override {
    const std::size_t lines = this->lines();
    std::vector<float> band(lines * samples_);
    // Line by line, each read straight into the band (gdal_support.hpp, direct_raw_io).
    const auto direct = detail::direct_raw_io();
    GDALRasterBand* const raster = cube_->GetRasterBand(index);
    for (std::size_t line = 0; line < lines; ++line)
      if (raster->RasterIO(GF_Read, 0, static_cast<int>(line), static_cast<int>(samples_), 1,
                           band.data() + line * samples_, static_cast<int>(samples_), 1, GDT_Float32, 0, 0,
                           nullptr) != CE_None)
        return std::unexpected(fmt::format("cannot read the map back: {}", CPLGetLastErrorMsg()));
    return band;
  }

  std::size_t lines() const override { return static_cast<std::size_t>(cube_->GetRasterYSize()); }

 private:
  std::filesystem::path file_;
  std::unique_ptr<GDALDataset> cube_;
  std::size_t samples_, bands_;
};

}  // namespace

std::expected<std::unique_ptr<gdal_io::AnswerFile>, std::string> create_gdal_answer_file(
    const std::filesystem::path& file, const CubeInfo& cube, const std::vector<MapBand>& bands, bool envi) {
  detail::start_gdal();
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName(envi ? "ENVI" : "GTiff");
  if (!driver) return std::unexpected(fmt::format("GDAL has no {} driver", envi ? "ENVI" : "GTiff"));
  // ENVI: the header GDAL writes is the data file's name with ".hdr" for its extension.
  const char* envi_options[] = {"INTERLEAVE=BIL", nullptr};
  const char* tiff_options[] = {"INTERLEAVE=BAND", "TILED=YES", "BIGTIFF=IF_SAFER", nullptr};
  std::unique_ptr<GDALDataset> answers(driver->Create(
      file.c_str(), static_cast<int>(cube.samples), static_cast<int>(cube.lines), static_cast<int>(bands.size()),
      GDT_Float32, const_cast<char**>(envi ? envi_options : tiff_options)));
  if (!answers) return std::unexpected(fmt::format("{}: cannot create: {}", file.string(), CPLGetLastErrorMsg()));
  std::string units = "{";
  for (std::size_t b = 0; b < bands.size(); ++b) {
    GDALRasterBand* band = answers->GetRasterBand(static_cast<int>(b + 1));
    band->SetDescription(bands[b].name.c_str());
    band->SetNoDataValue(std::numeric_limits<double>::quiet_NaN());
    units += (b ? ", " : " ") + header_item(bands[b].unit);
  }
  if (envi) answers->SetMetadataItem("band_units", (units + " }").c_str(), "ENVI");
  // A TIFF's bands carry their names (above) and units as GDAL band metadata.
  for (std::size_t b = 0; b < bands.size() && !envi; ++b)
    answers->GetRasterBand(static_cast<int>(b + 1))->SetMetadataItem("unit", bands[b].unit.c_str());
  answers->SetDescription(fmt::format("skinspec map of {}", cube.file).c_str());
  return std::make_unique<GdalAnswerFile>(file, std::move(answers), cube.samples, bands.size());
}

}  // namespace skinspec::maps
