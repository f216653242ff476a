// The shipped constants on measured skin: the goals of the tuning, checked so that a change to
// the model, the tables or the fitter that loses them fails here.

#include <gtest/gtest.h>

#include <filesystem>

#include "data_dir.hpp"
#include "skinspec/fit/tuning.hpp"
#include "skinspec/spectral/spectra_csv.hpp"
#include "support/data.hpp"

namespace skinspec {
namespace {

const Fitter& shipped_fitter() {
  static const Fitter fitter(testing::shipped_optics(), testing::colorimetry());
  return fitter;
}

std::vector<Spectrum> spectra_of(const std::string& bytes, const std::string& name) {
  auto parsed = parse_spectra_csv(bytes, name);
  EXPECT_TRUE(parsed) << parsed.error().what();
  std::vector<Spectrum> spectra;
  if (parsed)
    for (auto& s : *parsed) spectra.push_back(s.spectrum);
  return spectra;
}

TEST(RealSkin, ShippedExamplesFitWell) {
  const auto spectra = spectra_of(testing::data_file("examples/forearm.csv"), "examples/forearm.csv");
  ASSERT_EQ(spectra.size(), 3u);
  const auto scores = score_fits(shipped_fitter(), spectra, {});
  ASSERT_TRUE(scores) << scores.error();
  EXPECT_EQ(scores->converged, 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_LT(scores->rmse[i], 0.015) << "spectrum " << i;
    EXPECT_LT(scores->delta_e00[i], 1.5) << "spectrum " << i;
  }
}

// The 25 NIST forearms held out of the tuning (every second subject of the shared set): the
// goals of the fit on real skin the constants never saw.
TEST(RealSkin, HeldOutNistForearmsMeetTheGoals) {
  const std::filesystem::path file = std::filesystem::path(SKINSPEC_TEST_SHARED_DIR) / "data" / "real-skin" /
                                     "nist_forearm_odd_subjects_379-781nm_3nm.csv";
  auto bytes = read_file(file);
  if (!bytes) GTEST_SKIP() << "the shared NIST spectra are not beside this checkout: " << bytes.error();
  const auto all = spectra_of(*bytes, file.string());
  ASSERT_EQ(all.size(), 50u);
  std::vector<Spectrum> held_out;
  for (std::size_t i = 1; i < all.size(); i += 2) held_out.push_back(all[i]);
  const auto scores = score_fits(shipped_fitter(), held_out, {});
  ASSERT_TRUE(scores) << scores.error();
  const FitQuality q = summarize(*scores);
  EXPECT_EQ(q.converged, 25u);
  EXPECT_LE(q.median_rmse, 0.010);
  EXPECT_LE(q.p95_rmse, 0.020);
  EXPECT_LE(q.median_delta_e00, 1.0);
}

}  // namespace
}  // namespace skinspec
