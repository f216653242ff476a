#include "gdal/gdal_support.hpp"

#include <gdal_priv.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cpl_conv.h>
#include <cpl_error.h>
#include <fmt/format.h>
#include <mutex>

namespace skinspec::maps::detail {

namespace {
constexpr GIntBig kGdalCacheBytes = 32 << 20;
}  // namespace

void start_gdal() {
  static std::once_flag once;
  std::call_once(once, [] {
    CPLSetConfigOption("GDAL_PAM_ENABLED", "NO");
    // GDAL keeps the blocks it read or wrote in a cache of 5 % of the machine's memory by
    // default: 1.2 GB of a 24 GB machine, for blocks a map reads once. Its lines are read in
    // blocks of our own, so a small cache is enough.
    GDALSetCacheMax64(kGdalCacheBytes);
    // A raw cube's lines are read band by band, a seek and a read of a few kilobytes each:
    // 52,000 system calls for a 512 x 512 x 101 BIL cube. Through GDAL's cache of file
    // blocks (25 MB a file) it read in 0.16 s rather than 0.27 s.
    CPLSetConfigOption("VSI_CACHE", "TRUE");
    CPLSetErrorHandler(CPLQuietErrorHandler);
    GDALAllRegister();
  });
}

ThreadOption::ThreadOption(const char* name, const char* value) : name_(name) {
  CPLSetThreadLocalConfigOption(name, value);
}
ThreadOption::~ThreadOption() { CPLSetThreadLocalConfigOption(name_, nullptr); }

std::string last_gdal_error() {
  const std::string message = CPLGetLastErrorMsg();
  return message.empty() ? "GDAL gave no reason" : message;
}

std::string lower(std::string_view text) {
  std::string out(text);
  std::ranges::transform(out, out.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return out;
}

std::optional<double> nanometres_per(std::string_view units) {
  const std::string u = lower(units);
  if (u.empty() || u == "nanometers" || u == "nanometres" || u == "nm") return 1.0;
  if (u == "micrometers" || u == "micrometres" || u == "um" || u == "\u00b5m" || u == "microns") return 1000.0;
  return std::nullopt;
}

std::expected<std::vector<double>, CubeError> increasing(std::vector<double> values, const std::string& file) {
  for (std::size_t i = 0; i < values.size(); ++i)
    if (!std::isfinite(values[i]) || (i > 0 && !(values[i] > values[i - 1])))
      return std::unexpected(CubeError{file, "wavelength",
                                       i > 0
                                           ? fmt::format("not increasing: {} nm after {} nm", values[i], values[i - 1])
                                           : fmt::format("not a wavelength: {}", values[i])});
  return values;
}

}  // namespace skinspec::maps::detail
