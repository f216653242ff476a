#include "support/data.hpp"

#include <cstdio>
#include <cstdlib>

#include "data_dir.hpp"

namespace skinspec::testing {

namespace {
[[noreturn]] void die(const std::string& message) {
  std::fprintf(stderr, "test data: %s\n", message.c_str());
  std::abort();
}

constexpr double kTypicalLateralRadiusMm = 2.0;
}  // namespace

std::string data_file(const std::string& relative) {
  auto bytes = read_file(std::filesystem::path(SKINSPEC_TEST_DATA_DIR) / relative);
  if (!bytes) die(bytes.error());
  return *bytes;
}

Table table(const std::string& relative) {
  auto parsed = parse_table(data_file(relative), relative, {});
  if (!parsed) die(parsed.error().what());
  return *parsed;
}

const Colorimetry& colorimetry() {
  static const Colorimetry instance = [] {
    auto c = Colorimetry::from_tables(table("colour/cie1931_2deg_cmf.csv"), table("colour/cie_illuminants.csv"));
    if (!c) die(c.error().what());
    return *c;
  }();
  return instance;
}

DataReader source_data_reader() { return directory_reader(SKINSPEC_TEST_DATA_DIR); }

const SkinOptics& shipped_optics() {
  static const SkinOptics optics = [] {
    auto loaded = SkinOptics::load(source_data_reader());
    if (!loaded) die("cannot load the model tables: " + loaded.error().what());
    return *loaded;
  }();
  return optics;
}

const SkinOptics& textbook_optics() {
  static const SkinOptics optics = [] {
    ModelConstants constants;  // every scale 1
    constants.lateral_radius_mm = kTypicalLateralRadiusMm;
    return shipped_optics().with_constants(constants);
  }();
  return optics;
}

}  // namespace skinspec::testing
