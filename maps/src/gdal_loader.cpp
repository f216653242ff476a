// Loading the GDAL module (gdal_io.hpp): beside the program in a build tree
// (bin/../lib/skinspec/), else where it is installed.

#include <dlfcn.h>

#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "gdal_io.hpp"

namespace skinspec::maps::gdal_io {

namespace {

constexpr const char* kModule = "libskinspec-gdal.so";

std::vector<std::filesystem::path> places() {
  std::vector<std::filesystem::path> found;
  std::error_code error;
  const auto program = std::filesystem::read_symlink("/proc/self/exe", error);
  if (!error) found.push_back(program.parent_path().parent_path() / "lib" / "skinspec" / kModule);
  found.push_back(std::filesystem::path(SKINSPEC_MODULE_DIR) / kModule);
  return found;
}

const Io* load() {
  std::string tried;
  for (const auto& path : places()) {
    // Never closed: GDAL keeps its drivers until the process ends.
    void* module = ::dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (module == nullptr) {
      const char* why = ::dlerror();  // names the file
      tried += (tried.empty() ? "" : "; ") + (why ? std::string(why) : path.string() + ": not loaded");
      continue;
    }
    using Entry = const Io* (*)();
    if (auto entry = reinterpret_cast<Entry>(::dlsym(module, "skinspec_gdal_io"))) return entry();
    tried += (tried.empty() ? "" : "; ") + path.string() + ": no entry point skinspec_gdal_io";
  }
  throw std::runtime_error("skinspec's GDAL module, which reads and writes spectral images, cannot be loaded (" +
                           tried + "); install skinspec again");
}

}  // namespace

const Io& io() {
  static const Io* const loaded = load();
  return *loaded;
}

}  // namespace skinspec::maps::gdal_io
