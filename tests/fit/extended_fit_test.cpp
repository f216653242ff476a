// The extended model's fit on synthetic measurements (the model itself plus instrument-like
// noise, so that the truth is known): recovery within the tolerances of docs/model.md or an
// honest "not determined", standard errors that cover the truth, what a hidden dermis does to
// the report, partial spectral coverage and held parameters.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "skinspec/fit/fitter.hpp"
#include "support/data.hpp"

namespace skinspec {
namespace {

using ::testing::HasSubstr;

constexpr double kNoiseSigma = 0.002;
constexpr ModelKind kExtended = ModelKind::extended;
const auto& kSpecs = model_spec(kExtended).params;

const Fitter& fitter() { return testing::shipped_fitter(); }

FitOptions extended_options() {
  FitOptions options;
  options.model = kExtended;
  return options;
}

std::vector<double> model_reflectance(const Params& truth, const std::vector<double>& grid) {
  const SkinOptics& optics = testing::shipped_optics(kExtended);
  return SkinModel(optics, *optics.site("forearm"), grid, true).reflectance(truth);
}

Spectrum noisy(const Params& truth, const std::vector<double>& grid, unsigned seed) {
  auto values = model_reflectance(truth, grid);
  std::mt19937 generator(seed);
  std::normal_distribution<double> noise(0.0, kNoiseSigma);
  for (double& v : values) v += noise(generator);
  auto s = Spectrum::create(grid, values);
  if (!s) {
    std::fprintf(stderr, "bad synthetic spectrum: %s\n", s.error().c_str());
    std::abort();
  }
  return *s;
}

const std::vector<double>& pr650_grid() {
  static const auto grid = Spectrum::uniform_grid(380, 780, 4);
  return grid;
}

std::string describe(const Params& truth, const FitResult& fit) {
  std::ostringstream out;
  for (std::size_t i = 0; i < kSpecs.size(); ++i)
    out << kSpecs[i].name << ": true " << truth[i] << ", fitted " << fit.params[i] << " ± " << fit.standard_error[i]
        << " (" << to_string(fit.determination[i].status) << ")\n";
  return out.str();
}

// docs/model.md, "Synthetic recovery": a determined estimate is within three times its
// parameter's precision of the truth.
double tolerance(std::size_t i, double truth) {
  return 3 * std::max(kSpecs[i].precision_absolute, kSpecs[i].precision_relative * std::abs(truth));
}

// Very light to very dark skin (melanin over 45x) crossed with dermis levels: blood, its
// saturation, bilirubin, surface reflectance and the dermis's scattering.
constexpr double kMelaninLevels[] = {1, 3, 8, 15, 30, 45};
struct Dermis {
  double surface, blood, saturation, bilirubin, scattering, power;
};
constexpr Dermis kDermisLevels[] = {
    {0.03, 2.0, 0.60, 0.5, 25, 1.0},   // pale
    {0.04, 4.0, 0.75, 1.0, 30, 1.3},   // ordinary
    {0.05, 6.0, 0.90, 2.0, 40, 1.8},   // flushed, well oxygenated
    {0.06, 10.0, 0.50, 0.3, 20, 2.5},  // venous, weakly scattering
    {0.025, 3.0, 0.85, 3.0, 50, 0.8},  // jaundiced, strongly scattering
};

struct Case {
  Params truth;
  FitResult fit;
};

const std::vector<Case>& recovery_cases() {
  static const std::vector<Case> cases = [] {
    std::vector<Case> out;
    unsigned seed = 1;
    for (const double melanin : kMelaninLevels)
      for (const Dermis& d : kDermisLevels) {
        const Params truth = {d.surface, melanin, d.blood, d.saturation, d.bilirubin, d.scattering, d.power};
        auto fit = fitter().fit(noisy(truth, pr650_grid(), seed++), extended_options());
        if (!fit) {
          std::fprintf(stderr, "fit refused a synthetic spectrum: %s\n", fit.error().c_str());
          std::abort();
        }
        out.push_back({truth, std::move(*fit)});
      }
    return out;
  }();
  return cases;
}

TEST(ExtendedRecovery, CoversSkinFromVeryLightToVeryDarkAndEveryFitConverges) {
  EXPECT_GE(kMelaninLevels[std::size(kMelaninLevels) - 1] / kMelaninLevels[0], 30.0);
  ASSERT_EQ(recovery_cases().size(), std::size(kMelaninLevels) * std::size(kDermisLevels));
  for (const auto& c : recovery_cases()) {
    EXPECT_TRUE(c.fit.converged) << describe(c.truth, c.fit);
    EXPECT_EQ(c.fit.model, kExtended);
  }
}

TEST(ExtendedRecovery, ResidualsAreTheNoise) {
  for (const auto& c : recovery_cases()) {
    EXPECT_LT(c.fit.rmse, 1.3 * kNoiseSigma) << describe(c.truth, c.fit);
    EXPECT_GT(c.fit.rmse, 0.7 * kNoiseSigma) << describe(c.truth, c.fit);
  }
}

TEST(ExtendedRecovery, EveryParameterIsWithinToleranceOrMarkedNotDetermined) {
  std::size_t determined = 0, total = 0;
  for (const auto& c : recovery_cases())
    for (std::size_t i = 0; i < kSpecs.size(); ++i) {
      ++total;
      if (!c.fit.determination[i].determined()) continue;
      ++determined;
      EXPECT_LE(std::abs(c.fit.params[i] - c.truth[i]), tolerance(i, c.truth[i])) << kSpecs[i].name << "\n"
                                                                                  << describe(c.truth, c.fit);
    }
  // The rule must not excuse everything: over these skins, from very light to very dark, at
  // least two estimates in three are determined (147 of 210 today).
  EXPECT_GE(determined, 2 * total / 3) << determined << " of " << total << " determined";
  RecordProperty("determined", static_cast<int>(determined));
}

// Surface reflectance is not among them: at this noise its 0.02-0.08 range trades against the
// dermal scattering's amplitude, and it is marked imprecise or at its bound in some light skins.
TEST(ExtendedRecovery, MelaninBloodAndScatteringAreDeterminedInLightSkin) {
  for (const auto& c : recovery_cases()) {
    if (c.truth[kMelanin] > 8) continue;
    for (const int i : {static_cast<int>(kMelanin), static_cast<int>(kTotalHemoglobin),
                        static_cast<int>(kOxygenSaturation), static_cast<int>(kDermisScattering)})
      EXPECT_TRUE(c.fit.determination[static_cast<std::size_t>(i)].determined())
          << kSpecs[static_cast<std::size_t>(i)].name << "\n"
          << describe(c.truth, c.fit);
  }
}

TEST(ExtendedRecovery, AtLeastNinetyPercentOfDeterminedEstimatesAreWithinThreeStandardErrors) {
  std::size_t covered = 0, determined = 0;
  std::ostringstream missed;
  for (const auto& c : recovery_cases())
    for (std::size_t i = 0; i < kSpecs.size(); ++i) {
      if (!c.fit.determination[i].determined()) continue;
      ++determined;
      const double error = std::abs(c.fit.params[i] - c.truth[i]);
      if (error <= 3 * c.fit.standard_error[i]) ++covered;
      else missed << kSpecs[i].name << " off by " << error / c.fit.standard_error[i] << " SE\n";
    }
  ASSERT_GT(determined, 0u);
  const double coverage = static_cast<double>(covered) / static_cast<double>(determined);
  RecordProperty("three_se_coverage", std::to_string(coverage));
  EXPECT_GE(coverage, 0.90) << covered << " of " << determined << "\n" << missed.str();
}

TEST(ExtendedRecovery, DeterminedMeansWithinItsPrecisionAndNotDeterminedSaysWhy) {
  for (const auto& c : recovery_cases())
    for (std::size_t i = 0; i < kSpecs.size(); ++i) {
      const auto& d = c.fit.determination[i];
      const double precision =
          std::max(kSpecs[i].precision_absolute, kSpecs[i].precision_relative * std::abs(c.fit.params[i]));
      if (d.determined()) {
        EXPECT_LE(c.fit.standard_error[i], precision) << kSpecs[i].name;
        EXPECT_GT(c.fit.params[i], kSpecs[i].lower) << kSpecs[i].name;
        EXPECT_LT(c.fit.params[i], kSpecs[i].upper) << kSpecs[i].name;
      } else if (d.status == Determination::correlated) {
        ASSERT_GE(d.correlated_with, 0);
        EXPECT_GE(std::abs(c.fit.correlation_between(i, static_cast<std::size_t>(d.correlated_with))), 0.9);
      } else if (d.status == Determination::at_bound) {
        EXPECT_TRUE(c.fit.params[i] == kSpecs[i].lower || c.fit.params[i] == kSpecs[i].upper ||
                    std::abs(c.fit.params[i] - kSpecs[i].lower) < 1e-9 ||
                    std::abs(c.fit.params[i] - kSpecs[i].upper) < 1e-9)
            << kSpecs[i].name << " " << c.fit.params[i];
      }
    }
}

// ---------------------------------------------------------------------------------------------
// A dermis hidden by melanin: the default skin with melanin 95, about four times that of the
// darkest fitted NIST forearm (the seed paper's figure 5 shows blood vanishing under melanin
// x 4), inside the range's 100.

Params hidden_dermis() {
  Params p = default_params(kExtended);
  p[kMelanin] = 95;
  return p;
}

TEST(HiddenTruth, TheSaturationBarelyChangesTheSpectrumUnderMelaninTimesFour) {
  // What makes the case a hidden truth: across the saturation's whole range, the spectrum
  // moves by less than the noise at every wavelength.
  Params venous = hidden_dermis(), arterial = hidden_dermis();
  venous[kOxygenSaturation] = kSpecs[kOxygenSaturation].lower;
  arterial[kOxygenSaturation] = kSpecs[kOxygenSaturation].upper;
  const auto a = model_reflectance(venous, pr650_grid()), b = model_reflectance(arterial, pr650_grid());
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_LT(std::abs(a[i] - b[i]), kNoiseSigma) << pr650_grid()[i] << " nm";
}

TEST(HiddenTruth, TheSaturationIsMarkedNotDetermined) {
  for (unsigned seed = 500; seed < 505; ++seed) {
    const auto fit = fitter().fit(noisy(hidden_dermis(), pr650_grid(), seed), extended_options());
    ASSERT_TRUE(fit) << fit.error();
    EXPECT_FALSE(fit->determination[kOxygenSaturation].determined()) << describe(hidden_dermis(), *fit);
    EXPECT_FALSE(fit->oxygen_saturation.determined());
    // Melanin itself is still seen.
    EXPECT_TRUE(fit->determination[kMelanin].determined()) << describe(hidden_dermis(), *fit);
  }
}

// ---------------------------------------------------------------------------------------------
// Derived quantities

TEST(DerivedQuantities, FollowFromTheParametersByTheDeltaMethod) {
  const Params truth = {0.04, 4, 4, 0.75, 1, 30, 1.3};
  const auto fit = fitter().fit(noisy(truth, pr650_grid(), 11), extended_options());
  ASSERT_TRUE(fit) << fit.error();
  EXPECT_EQ(fit->oxygen_saturation.value, fit->params[kOxygenSaturation]);
  EXPECT_EQ(fit->oxygen_saturation.standard_error, fit->standard_error[kOxygenSaturation]);
  EXPECT_NEAR(fit->blood_volume_fraction.value, kReferenceBloodFraction * fit->params[kTotalHemoglobin], 1e-15);
  EXPECT_NEAR(fit->blood_volume_fraction.standard_error,
              kReferenceBloodFraction * fit->standard_error[kTotalHemoglobin], 1e-15);
}

TEST(DerivedQuantities, PaperSaturationCombinesOxyAndDeoxyWithTheirCorrelation) {
  FitOptions options;
  options.model = ModelKind::paper;
  const SkinOptics& optics = testing::shipped_optics(ModelKind::paper);
  auto values = SkinModel(optics, *optics.site("forearm"), pr650_grid(), true).reflectance({0.04, 3, 3, 1, 1.5});
  std::mt19937 generator(3);
  std::normal_distribution<double> noise(0.0, kNoiseSigma);
  for (double& v : values) v += noise(generator);
  const auto fit = fitter().fit(*Spectrum::create(pr650_grid(), values), options);
  ASSERT_TRUE(fit) << fit.error();
  const double oxy = fit->params[kOxyhemoglobin], deoxy = fit->params[kDeoxyhemoglobin], total = oxy + deoxy;
  const double g_oxy = deoxy / (total * total), g_deoxy = -oxy / (total * total);
  const double se_oxy = fit->standard_error[kOxyhemoglobin], se_deoxy = fit->standard_error[kDeoxyhemoglobin];
  const double rho = fit->correlation_between(kOxyhemoglobin, kDeoxyhemoglobin);
  const double variance = g_oxy * g_oxy * se_oxy * se_oxy + g_deoxy * g_deoxy * se_deoxy * se_deoxy +
                          2 * g_oxy * g_deoxy * rho * se_oxy * se_deoxy;
  EXPECT_NEAR(fit->oxygen_saturation.value, oxy / total, 1e-15);
  EXPECT_NEAR(fit->oxygen_saturation.standard_error, std::sqrt(variance), 1e-9);
  EXPECT_NEAR(fit->blood_volume_fraction.value, kReferenceBloodFraction * total, 1e-15);
  EXPECT_NEAR(fit->oxygen_saturation.value, 0.75, 0.1);
}

TEST(Correlation, IsASymmetricMatrixWithOnesOnItsDiagonal) {
  const auto fit = fitter().fit(noisy({0.04, 4, 4, 0.75, 1, 30, 1.3}, pr650_grid(), 12), extended_options());
  ASSERT_TRUE(fit) << fit.error();
  const std::size_t n = fit->params.size();
  ASSERT_EQ(fit->correlation.size(), n * n);
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(fit->standard_error[i])) continue;
    EXPECT_NEAR(fit->correlation_between(i, i), 1.0, 1e-12);
    for (std::size_t j = 0; j < n; ++j) {
      if (!std::isfinite(fit->standard_error[j])) continue;
      EXPECT_NEAR(fit->correlation_between(i, j), fit->correlation_between(j, i), 1e-12);
      EXPECT_LE(std::abs(fit->correlation_between(i, j)), 1.0 + 1e-12);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Partial spectral coverage

const Params kOrdinary = {0.04, 4, 4, 0.75, 1, 30, 1.3};

FitResult fit_on(const std::vector<double>& grid, unsigned seed = 21) {
  auto fit = fitter().fit(noisy(kOrdinary, grid, seed), extended_options());
  if (!fit) {
    std::fprintf(stderr, "refused: %s\n", fit.error().c_str());
    std::abort();
  }
  return *fit;
}

TEST(PartialCoverage, AHyperspectralCamerasRangeIsFittedInsideTheModelsWithANote) {
  // 415-950 nm every 5 nm, as a hyperspectral camera gives: 415-780 nm is fitted.
  const auto camera = Spectrum::uniform_grid(415, 950, 5);
  std::vector<double> values = model_reflectance(kOrdinary, Spectrum::uniform_grid(415, 780, 5));
  const std::size_t inside = values.size();
  values.resize(camera.size(), 0.6);  // beyond the model: any value, never looked at
  const auto fit = fitter().fit(*Spectrum::create(camera, values), extended_options());
  ASSERT_TRUE(fit) << fit.error();
  EXPECT_EQ(fit->samples_ignored, camera.size() - inside);
  EXPECT_EQ(fit->wavelength_nm.front(), 415);
  EXPECT_EQ(fit->wavelength_nm.back(), 780);
  EXPECT_THAT(fit->coverage_note, HasSubstr("415-780 nm"));
  EXPECT_LT(fit->rmse, 1e-6);
  for (std::size_t i = 0; i < kSpecs.size(); ++i)
    EXPECT_NEAR(fit->params[i], kOrdinary[i], 1e-3 * kOrdinary[i]) << kSpecs[i].name;
}

TEST(PartialCoverage, LessOfTheSpectrumGivesWiderStandardErrors) {
  // The same skin, the same noise level: 400-700 nm knows less than 380-780 nm.
  const auto full = fit_on(Spectrum::uniform_grid(380, 780, 4));
  const auto part = fit_on(Spectrum::uniform_grid(400, 700, 4));
  EXPECT_TRUE(full.coverage_note.empty());
  EXPECT_THAT(part.coverage_note, HasSubstr("400-700 nm"));
  EXPECT_TRUE(part.converged);
  std::size_t wider = 0;
  for (std::size_t i = 0; i < kSpecs.size(); ++i)
    if (std::isfinite(full.standard_error[i]) && part.standard_error[i] > full.standard_error[i]) ++wider;
  EXPECT_GE(wider, kSpecs.size() - 1);
}

TEST(PartialCoverage, LessThan420To680NmIsRefused) {
  for (const auto& [first, last] : {std::pair{450.0, 650.0}, std::pair{425.0, 780.0}, std::pair{380.0, 675.0}}) {
    const auto grid = Spectrum::uniform_grid(first, last, 5);
    const auto fit = fitter().fit(*Spectrum::create(grid, model_reflectance(kOrdinary, grid)), extended_options());
    ASSERT_FALSE(fit.has_value()) << first << "-" << last;
    EXPECT_THAT(fit.error(), HasSubstr("420-680 nm")) << first << "-" << last;
  }
}

// ---------------------------------------------------------------------------------------------
// Held parameters

TEST(HeldParameters, StayAtTheirValueAndAreReportedAsHeld) {
  FitOptions options = extended_options();
  options.held = {{kDermisScatteringPower, 1.3}, {kBilirubin, 1.0}};
  const auto fit = fitter().fit(noisy(kOrdinary, pr650_grid(), 31), options);
  ASSERT_TRUE(fit) << fit.error();
  EXPECT_EQ(fit->params[kDermisScatteringPower], 1.3);
  EXPECT_EQ(fit->params[kBilirubin], 1.0);
  EXPECT_EQ(fit->determination[kDermisScatteringPower].status, Determination::held);
  EXPECT_FALSE(std::isfinite(fit->standard_error[kBilirubin]));
  EXPECT_NEAR(fit->params[kMelanin], kOrdinary[kMelanin], 0.1 * kOrdinary[kMelanin]);
}

TEST(HeldParameters, OutsideTheirRangeOrUnknownAreRefused) {
  FitOptions options = extended_options();
  options.held = {{kOxygenSaturation, kSpecs[kOxygenSaturation].upper + 0.005}};
  auto fit = fitter().fit(noisy(kOrdinary, pr650_grid(), 32), options);
  ASSERT_FALSE(fit);
  EXPECT_THAT(fit.error(), HasSubstr("oxygen_saturation"));
  options.held = {{99, 1.0}};
  fit = fitter().fit(noisy(kOrdinary, pr650_grid(), 32), options);
  ASSERT_FALSE(fit);
  EXPECT_THAT(fit.error(), HasSubstr("99"));
}

TEST(Models, AFitterWithoutAModelSaysSo) {
  const Fitter paper_only(testing::shipped_optics(ModelKind::paper), testing::colorimetry());
  const auto fit = paper_only.fit(noisy(kOrdinary, pr650_grid(), 33), extended_options());
  ASSERT_FALSE(fit);
  EXPECT_THAT(fit.error(), HasSubstr("extended"));
}

}  // namespace
}  // namespace skinspec
