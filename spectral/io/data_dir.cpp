#include "data_dir.hpp"

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

namespace skinspec {

namespace {

std::filesystem::path executable_dir() {
  std::error_code ec;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::filesystem::path() : exe.parent_path();
}

bool looks_like_data_dir(const std::filesystem::path& dir) {
  std::error_code ec;
  return std::filesystem::is_directory(dir / "optics", ec);
}

}  // namespace

std::filesystem::path find_data_dir() {
  if (const char* env = std::getenv("SKINSPEC_DATA_DIR"); env && *env) return env;
  const auto installed = executable_dir() / ".." / "share" / "skinspec" / "data";
  if (looks_like_data_dir(installed)) return installed.lexically_normal();
  return SKINSPEC_SOURCE_DATA_DIR;
}

std::expected<std::string, std::string> read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::unexpected(path.string() + ": cannot open: " + std::strerror(errno));
  std::ostringstream bytes;
  bytes << in.rdbuf();
  if (in.bad()) return std::unexpected(path.string() + ": read error");
  return std::move(bytes).str();
}

DataReader directory_reader(std::filesystem::path dir) {
  return [dir = std::move(dir)](std::string_view relative) { return read_file(dir / relative); };
}

}  // namespace skinspec
