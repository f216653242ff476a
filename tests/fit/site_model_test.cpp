// The extended model's body sites (docs/model.md, "Body sites"): the same chromophores per unit
// area of skin, rendered with the model at each site's anatomy plus small noise, are recovered
// at each site within their standard errors; the right site fits no worse than a wrong one; on
// healthy skin the oxygen saturation, surface reflectance and scattering power seldom end on a
// bound; and the measured forearms fit best as forearms.

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "skinspec/fit/fitter.hpp"
#include "skinspec/spectral/spectra_csv.hpp"
#include "support/data.hpp"

namespace skinspec {
namespace {

constexpr ModelKind kExtended = ModelKind::extended;
constexpr double kNoiseSigma = 0.001;  // small: a spectroradiometer's repeatability on skin

const SkinOptics& optics() { return testing::shipped_optics(kExtended); }
const std::vector<double>& grid() {
  static const auto g = Spectrum::uniform_grid(380, 780, 4);
  return g;
}

// A skin by what it holds per unit area of skin, so that it is the same skin at any site:
// melanin as weight times the living epidermis's thickness (mm), blood and bilirubin as weight
// times the dermis's; the rest are not amounts.
struct Skin {
  double surface, melanin_mm, blood_mm, saturation, bilirubin_mm, scattering, power;
};

// A skin given by its weights at the forearm.
Skin at_forearm(double surface, double melanin, double blood, double saturation, double bilirubin, double scattering,
                double power) {
  const Site forearm = *optics().site("forearm");
  return {surface,    melanin * forearm.epidermis_mm, blood * forearm.dermis_mm,
          saturation, bilirubin * forearm.dermis_mm,  scattering,
          power};
}

// The model's parameters for that skin at a site: the amounts spread through its layers.
Params weights_at(const Skin& s, const Site& site) {
  return {s.surface,    s.melanin_mm / site.epidermis_mm, s.blood_mm / site.dermis_mm,
          s.saturation, s.bilirubin_mm / site.dermis_mm,  s.scattering,
          s.power};
}

Spectrum rendered(const Skin& skin, const Site& site, unsigned seed) {
  auto values = SkinModel(optics(), site, grid(), true).reflectance(weights_at(skin, site));
  std::mt19937 generator(seed);
  std::normal_distribution<double> noise(0.0, kNoiseSigma);
  for (double& v : values) v += noise(generator);
  return *Spectrum::create(grid(), values);
}

FitResult fitted(const Spectrum& spectrum, const std::string& site) {
  FitOptions options;
  options.model = kExtended;
  options.site = site;
  auto fit = testing::shipped_fitter().fit(spectrum, options);
  EXPECT_TRUE(fit) << fit.error();
  return fit ? *fit : FitResult{};
}

// Light, medium and darker skin with ordinary dermis settings, by their forearm weights.
const std::vector<Skin>& skins() {
  static const std::vector<Skin> s = {at_forearm(0.04, 3, 12, 0.6, 0.5, 30, 1.5),
                                      at_forearm(0.05, 10, 18, 0.75, 1, 40, 2.0),
                                      at_forearm(0.035, 25, 15, 0.5, 1, 25, 1.2)};
  return s;
}

TEST(SiteModel, EverySiteHasItsOwnAnatomy) {
  // Otherwise the tests below would compare a site with itself.
  const auto names = optics().site_names();
  ASSERT_GE(names.size(), 5u);
  const Site forearm = *optics().site("forearm"), palm = *optics().site("palm");
  EXPECT_GT(palm.epidermis_mm, 2 * forearm.epidermis_mm);
  EXPECT_GT(palm.stratum_corneum_mm, 2 * forearm.stratum_corneum_mm);
}

// The amounts per unit area come back at every site, each within three of its standard errors.
TEST(SiteModel, TheSameAmountsPerAreaAreRecoveredAtEverySite) {
  unsigned seed = 1;
  for (const auto& name : optics().site_names()) {
    const Site site = *optics().site(name);
    for (const Skin& skin : skins()) {
      const Params truth = weights_at(skin, site);
      const FitResult fit = fitted(rendered(skin, site, seed++), name);
      ASSERT_TRUE(fit.converged) << name;
      EXPECT_LT(fit.rmse, 1.3 * kNoiseSigma) << name;
      for (const int k : {static_cast<int>(kMelanin), static_cast<int>(kTotalHemoglobin)}) {
        const auto i = static_cast<std::size_t>(k);
        ASSERT_TRUE(fit.determination[i].determined()) << name << " " << model_spec(kExtended).params[i].name;
        EXPECT_NEAR(fit.params[i], truth[i], 3 * fit.standard_error[i])
            << name << " " << model_spec(kExtended).params[i].name << " per area: true "
            << truth[i] * (k == kMelanin ? site.epidermis_mm : site.dermis_mm) << " mm";
      }
    }
  }
}

// A skin rendered at one site is fitted at least as well there as at any other site.
TEST(SiteModel, TheRightSiteFitsNoWorseThanAWrongOne) {
  const auto names = optics().site_names();
  unsigned seed = 100;
  for (const auto& right : names)
    for (const Skin& skin : skins()) {
      const Spectrum spectrum = rendered(skin, *optics().site(right), seed++);
      const double right_rmse = fitted(spectrum, right).rmse;
      for (const auto& wrong : names)
        if (wrong != right) {
          EXPECT_LE(right_rmse, fitted(spectrum, wrong).rmse) << right << " fitted as " << wrong;
        }
    }
}

// Healthy skins drawn across the plausible ranges, away from the bounds: the model at the right
// site must let the spectrum, not a bound, decide the saturation, surface reflectance and power.
TEST(SiteModel, OnHealthySkinFewFitsEndOnABound) {
  std::mt19937 generator(36);
  const auto uniform = [&](double low, double high) { return std::uniform_real_distribution(low, high)(generator); };
  for (const auto& name : optics().site_names()) {
    const Site site = *optics().site(name);
    constexpr int kSkins = 20;
    const auto watched = model_spec(kExtended).bound_watched;
    std::vector<int> at_bound(watched.size());
    for (int n = 0; n < kSkins; ++n) {
      const Skin skin = at_forearm(uniform(0.03, 0.06), uniform(1, 20), uniform(5, 25), uniform(0.45, 0.9),
                                   uniform(0, 2), uniform(20, 50), uniform(0.8, 2.5));
      const FitResult fit = fitted(rendered(skin, site, 1000 + static_cast<unsigned>(n)), name);
      for (std::size_t w = 0; w < watched.size(); ++w)
        at_bound[w] +=
            fit.determination[static_cast<std::size_t>(watched[w])].status == Determination::at_bound ? 1 : 0;
    }
    for (std::size_t w = 0; w < watched.size(); ++w)
      EXPECT_LE(at_bound[w], model_spec(kExtended).most_at_bound * kSkins)
          << name << ": " << model_spec(kExtended).params[static_cast<std::size_t>(watched[w])].name;
  }
}

// The 50 NIST forearms: no other site's anatomy fits them better, by the median RMSE.
TEST(SiteModel, MeasuredForearmsFitBestAsForearms) {
  const std::string file = "real-skin/nist_forearm_odd_subjects_379-781nm_3nm.csv";
  const auto parsed = parse_spectra_csv(testing::data_file(file), file);
  ASSERT_TRUE(parsed) << parsed.error().what();
  const auto median_rmse = [&](const std::string& site) {
    std::vector<double> rmse;
    for (const auto& s : *parsed) rmse.push_back(fitted(s.spectrum, site).rmse);
    std::ranges::nth_element(rmse, rmse.begin() + static_cast<std::ptrdiff_t>(rmse.size() / 2));
    return rmse[rmse.size() / 2];
  };
  const double forearm = median_rmse("forearm");
  for (const auto& name : optics().site_names())
    if (name != "forearm") {
      EXPECT_LE(forearm, median_rmse(name)) << name;
    }
}

}  // namespace
}  // namespace skinspec
