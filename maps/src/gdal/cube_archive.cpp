// A cube uploaded as one file: itself, or a tar archive of an ENVI header and its data file,
// unpacked through GDAL's /vsitar/ (which reads gzipped archives too).

#include <cpl_conv.h>
#include <cpl_string.h>
#include <cpl_vsi.h>
#include <fmt/format.h>

#include <array>
#include <filesystem>
#include <fstream>
#include <memory>

#include "gdal/cube_reader.hpp"
#include "gdal/gdal_support.hpp"

namespace skinspec::maps {

namespace {

namespace fs = std::filesystem;

constexpr int kMaxUnpackedRatio = 20;

enum class Archive { none, tar, gzip };

// A POSIX tar archive has "ustar" at byte 257 of its first header; gzip starts 1f 8b.
Archive archive_of(const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  std::array<char, 262> head{};
  in.read(head.data(), head.size());
  const auto got = in.gcount();
  if (got >= 2 && static_cast<unsigned char>(head[0]) == 0x1f && static_cast<unsigned char>(head[1]) == 0x8b)
    return Archive::gzip;
  if (got == static_cast<std::streamsize>(head.size()) && std::string_view(head.data() + 257, 5) == "ustar")
    return Archive::tar;
  return Archive::none;
}

// GDAL's /vsitar/ knows an archive by its name's ending.
std::expected<std::string, std::string> named_as(const std::string& file, Archive archive) {
  const std::string ending = archive == Archive::gzip ? ".tgz" : ".tar";
  if (file.ends_with(ending)) return file;
  std::error_code error;
  fs::rename(file, file + ending, error);
  if (error) return std::unexpected(fmt::format("{} cannot be renamed: {}", file, error.message()));
  return file + ending;
}

struct VsiClose {
  void operator()(VSILFILE* f) const { VSIFCloseL(f); }
};

std::expected<void, std::string> copy_member(const std::string& from, const fs::path& to) {
  std::unique_ptr<VSILFILE, VsiClose> in(VSIFOpenL(from.c_str(), "rb"));
  std::ofstream out(to, std::ios::binary | std::ios::trunc);
  if (!in || !out) return std::unexpected(fmt::format("{} cannot be unpacked to {}", from, to.string()));
  std::vector<char> buffer(1 << 20);
  for (;;) {
    const std::size_t got = VSIFReadL(buffer.data(), 1, buffer.size(), in.get());
    out.write(buffer.data(), static_cast<std::streamsize>(got));
    if (got < buffer.size()) break;
  }
  if (!out.flush()) return std::unexpected(fmt::format("{} cannot be written", to.string()));
  return {};
}

}  // namespace

std::expected<std::string, CubeError> unpack_cube_upload(const std::string& file, const std::string& dir,
                                                         const std::string& name) {
  const Archive archive = archive_of(file);
  if (archive == Archive::none) return file;
  const auto refuse = [&](std::string why) { return std::unexpected(CubeError{name, "", std::move(why)}); };
  const auto named = named_as(file, archive);
  if (!named) return refuse(named.error());
  detail::start_gdal();
  const std::string root = "/vsitar/" + *named;
  char** listed = VSIReadDirRecursive(root.c_str());
  std::vector<std::string> members;
  for (char** m = listed; m && *m; ++m) members.emplace_back(*m);
  CSLDestroy(listed);
  std::vector<std::string> headers;
  std::size_t files = 0;
  std::error_code error;
  // A gzipped archive of a cube unpacks to a few times its size; one that claims more than
  // kMaxUnpackedRatio times is refused before anything is written, so no upload fills the disk.
  const auto budget = static_cast<double>(fs::file_size(*named, error)) * kMaxUnpackedRatio;
  double claimed = 0;
  for (const auto& member : members) {
    VSIStatBufL stat{};
    if (VSIStatL((root + "/" + member).c_str(), &stat) == 0) claimed += static_cast<double>(stat.st_size);
  }
  if (error || claimed > budget)
    return refuse(fmt::format("the archive's files come to {:.0f} bytes, more than {} times the archive", claimed,
                              kMaxUnpackedRatio));
  for (const auto& member : members) {
    VSIStatBufL stat{};
    const std::string path = root + "/" + member;
    if (VSIStatL(path.c_str(), &stat) != 0) return refuse(fmt::format("archive member {} cannot be read", member));
    if (VSI_ISDIR(stat.st_mode)) continue;
    if (!VSI_ISREG(stat.st_mode)) return refuse(fmt::format("archive member {} is not a plain file", member));
    if (++files > kMaxArchiveMembers)
      return refuse(fmt::format("the archive holds more than {} files: send one cube", kMaxArchiveMembers));
    const fs::path target = fs::path(dir) / fs::path(member).filename();
    if (auto copied = copy_member(path, target); !copied) return refuse(copied.error());
    if (detail::lower(target.extension().string()) == ".hdr") headers.push_back(target.string());
  }
  if (files == 0) return refuse("an empty or damaged archive");
  if (headers.size() != 1)
    return refuse(
        fmt::format("the archive holds {} ENVI headers (.hdr); it must hold one, with its data file", headers.size()));
  return headers.front();
}

}  // namespace skinspec::maps
