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

namespace {

SkinOptics load_optics(ModelKind model) {
  auto loaded = SkinOptics::load(source_data_reader(), model);
  if (!loaded) die("cannot load the model tables: " + loaded.error().what());
  return *loaded;
}

SkinOptics textbook(ModelKind model) {
  ModelConstants constants;  // every scale 1, no baseline correction
  constants.lateral_radius_mm = kTypicalLateralRadiusMm;
  return shipped_optics(model).with_constants(constants);
}

}  // namespace

const SkinOptics& shipped_optics(ModelKind model) {
  static const SkinOptics paper = load_optics(ModelKind::paper);
  static const SkinOptics extended = load_optics(ModelKind::extended);
  return model == ModelKind::paper ? paper : extended;
}

const SkinOptics& textbook_optics(ModelKind model) {
  static const SkinOptics paper = textbook(ModelKind::paper);
  static const SkinOptics extended = textbook(ModelKind::extended);
  return model == ModelKind::paper ? paper : extended;
}

const Fitter& shipped_fitter() {
  static const Fitter fitter({shipped_optics(ModelKind::paper), shipped_optics(ModelKind::extended)}, colorimetry());
  return fitter;
}

}  // namespace skinspec::testing
