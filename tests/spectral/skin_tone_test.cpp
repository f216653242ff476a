// The skin-tone descriptors (spectral/skin_tone.hpp): the definitions on constructed values, and
// the 50 NIST forearms against CIELAB, ITA and the indices computed apart from skinspec, with
// numpy from the CIE tables (tests/data/skin-tone/make_reference.py).
#include "skinspec/spectral/skin_tone.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "skinspec/spectral/spectra_csv.hpp"
#include "support/data.hpp"

namespace skinspec {
namespace {

TEST(SkinTone, ItaIsTheAngleOfLightnessAboveFiftyAgainstYellowness) {
  EXPECT_NEAR(individual_typology_angle({65, 10, 15}), 45.0, 1e-12);
  EXPECT_NEAR(individual_typology_angle({50, 10, 20}), 0.0, 1e-12);
  EXPECT_NEAR(individual_typology_angle({35, 10, 15}), -45.0, 1e-12);
  EXPECT_NEAR(individual_typology_angle({50 + std::sqrt(3.0), 5, 1}), 60.0, 1e-12);
}

TEST(SkinTone, ClassesFollowDelBinoWithABoundaryInTheDarkerClass) {
  const std::vector<std::pair<double, ItaClass>> cases = {
      {70, ItaClass::very_light}, {55.001, ItaClass::very_light}, {55, ItaClass::light},
      {41.5, ItaClass::light},    {41, ItaClass::intermediate},   {28, ItaClass::tan},
      {10.5, ItaClass::tan},      {10, ItaClass::brown},          {-29.9, ItaClass::brown},
      {-30, ItaClass::dark},      {-60, ItaClass::dark},
  };
  for (const auto& [ita, expected] : cases) EXPECT_EQ(classify_ita(ita), expected) << ita;
}

TEST(SkinTone, ClassNamesReadBackAndUnknownOnesAreRefused) {
  for (auto c : {ItaClass::very_light, ItaClass::light, ItaClass::intermediate, ItaClass::tan, ItaClass::brown,
                 ItaClass::dark})
    EXPECT_EQ(parse_ita_class(to_string(c)), c);
  EXPECT_EQ(to_string(ItaClass::very_light), "very_light");
  EXPECT_FALSE(parse_ita_class("Very light"));
  EXPECT_FALSE(parse_ita_class(""));
}

TEST(SkinTone, IndicesAreHundredLogRatiosAtTheirWavelengths) {
  // 0.25 at 568 nm and 0.5 at 655 nm, interpolated between samples 20 nm either side.
  const auto spectrum = Spectrum::create({548, 588, 635, 675}, {0.25, 0.25, 0.5, 0.5});
  ASSERT_TRUE(spectrum);
  const SkinTone tone = skin_tone(*spectrum, {60, 10, 15});
  ASSERT_TRUE(tone.melanin_index && tone.erythema_index);
  EXPECT_NEAR(*tone.melanin_index, 100 * std::log10(2.0), 1e-12);
  EXPECT_NEAR(*tone.erythema_index, 100 * std::log10(2.0), 1e-12);
  EXPECT_EQ(tone.ita_class, ItaClass::intermediate);
}

TEST(SkinTone, AReflectanceAtOrBelowZeroLeavesItsIndexUnknown) {
  const auto no_red = Spectrum::create({500, 600, 655, 700}, {0.2, 0.1, 0.0, 0.0});
  ASSERT_TRUE(no_red);
  const SkinTone dark = skin_tone(*no_red, {20, 5, 5});
  EXPECT_FALSE(dark.melanin_index);
  EXPECT_FALSE(dark.erythema_index);
  EXPECT_EQ(dark.ita_class, ItaClass::dark);

  const auto no_green = Spectrum::create({500, 568, 700}, {0.1, -0.01, 0.3});
  ASSERT_TRUE(no_green);
  const SkinTone tone = skin_tone(*no_green, {60, 10, 15});
  EXPECT_TRUE(tone.melanin_index);
  EXPECT_FALSE(tone.erythema_index);
}

struct Reference {
  Lab lab;
  double ita = 0, melanin = 0, erythema = 0;
};

std::map<std::string, Reference> read_reference() {
  std::ifstream in(SKINSPEC_TEST_SOURCE_DIR "/tests/data/skin-tone/reference.csv");
  std::map<std::string, Reference> rows;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#' || line.starts_with("subject,")) continue;
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream fields(line);
    std::string name;
    Reference r;
    fields >> name >> r.lab.l >> r.lab.a >> r.lab.b >> r.ita >> r.melanin >> r.erythema;
    EXPECT_TRUE(fields) << line;
    rows[name] = r;
  }
  return rows;
}

TEST(SkinTone, NistForearmsAgreeWithAnIndependentComputation) {
  const std::string file = "real-skin/nist_forearm_odd_subjects_379-781nm_3nm.csv";
  const auto spectra = parse_spectra_csv(testing::data_file(file), file);
  ASSERT_TRUE(spectra) << spectra.error().what();
  const auto reference = read_reference();
  ASSERT_EQ(reference.size(), 50u);
  ASSERT_EQ(spectra->size(), 50u);
  const auto d65 = testing::colorimetry().illuminant("D65");
  ASSERT_TRUE(d65);
  std::map<ItaClass, int> classes;
  for (const auto& [name, spectrum] : *spectra) {
    SCOPED_TRACE(name);
    ASSERT_TRUE(reference.contains(name));
    const Reference& expected = reference.at(name);
    const Lab lab = testing::colorimetry().lab(spectrum, *d65);
    EXPECT_NEAR(lab.l, expected.lab.l, 1e-4);
    EXPECT_NEAR(lab.b, expected.lab.b, 1e-4);
    const SkinTone tone = skin_tone(spectrum, lab);
    EXPECT_NEAR(tone.ita_deg, expected.ita, 1e-3);
    EXPECT_EQ(tone.ita_class, classify_ita(expected.ita));
    ASSERT_TRUE(tone.melanin_index && tone.erythema_index);
    EXPECT_NEAR(*tone.melanin_index, expected.melanin, 1e-4);
    EXPECT_NEAR(*tone.erythema_index, expected.erythema, 1e-4);
    ++classes[tone.ita_class];
  }
  // The set spans five of the six classes, from very light to brown: no dark skin.
  EXPECT_EQ(classes.size(), 5u);
  EXPECT_FALSE(classes.contains(ItaClass::dark));
}

}  // namespace
}  // namespace skinspec
