#include "skinspec/fit/fitter.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ostream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "support/data.hpp"

namespace skinspec {
namespace {

using ::testing::HasSubstr;

// ---------------------------------------------------------------------------------------------
// Synthetic measurements: the model itself plus instrument-like noise, so that the true
// parameters are known.
//
// Two sets of constants. The shipped ones (data/model/constants.csv, re-tuned from time to
// time) are what users fit with, so everything is checked on them, without assuming their
// values. The recovery requirement is also checked under fixed textbook constants, so that a
// failure can be told apart: the fitter's (fails under both) or the tuned model's (shipped only).

enum class Constants { kShipped, kTextbook };

std::string name_of(Constants constants) { return constants == Constants::kShipped ? "Shipped" : "Textbook"; }
void PrintTo(Constants constants, std::ostream* out) { *out << name_of(constants); }

// The shipped constants, and every scale 1 with a lateral radius typical of a contact probe so
// that the lateral-diffusion path is exercised (support/data.hpp).
using testing::shipped_optics;
using testing::textbook_optics;

const SkinOptics& optics(Constants constants) {
  return constants == Constants::kShipped ? shipped_optics() : textbook_optics();
}

const Fitter& fitter(Constants constants = Constants::kShipped) {
  static const Fitter shipped(shipped_optics(), testing::colorimetry());
  static const Fitter textbook(textbook_optics(), testing::colorimetry());
  return constants == Constants::kShipped ? shipped : textbook;
}

constexpr double kNoiseSigma = 0.002;  // a good spectrophotometer's reflectance noise
const std::string kSite = "forearm";

// The grid of the synthetic spectra: 380-780 nm every 4 nm, 101 samples.
const std::vector<double>& measurement_grid() {
  static const std::vector<double> grid = Spectrum::uniform_grid(380, 780, 4);
  return grid;
}

std::vector<double> model_reflectance(const Params& truth, bool lateral_diffusion,
                                      const std::vector<double>& grid = measurement_grid(),
                                      Constants constants = Constants::kShipped) {
  const SkinOptics& o = optics(constants);
  const SkinModel model(o, *o.site(kSite), grid, lateral_diffusion);
  return model.reflectance(truth);
}

// Gaussian noise of kNoiseSigma from a fixed seed, so that every run sees the same spectra.
std::vector<double> with_noise(std::vector<double> values, unsigned seed) {
  std::mt19937 generator(seed);
  std::normal_distribution<double> noise(0.0, kNoiseSigma);
  for (double& v : values) v += noise(generator);
  return values;
}

Spectrum spectrum(const std::vector<double>& grid, const std::vector<double>& values) {
  auto s = Spectrum::create(grid, values);
  if (!s) {
    std::fprintf(stderr, "bad synthetic spectrum: %s\n", s.error().c_str());
    std::abort();
  }
  return *s;
}

Spectrum synthetic_measurement(const Params& truth, unsigned seed, bool lateral_diffusion = true,
                               Constants constants = Constants::kShipped) {
  return spectrum(measurement_grid(),
                  with_noise(model_reflectance(truth, lateral_diffusion, measurement_grid(), constants), seed));
}

FitOptions options_for(bool lateral_diffusion = true, std::vector<double> weights = {}) {
  return {.model = ModelKind::paper,
          .site = kSite,
          .lateral_diffusion = lateral_diffusion,
          .weights = std::move(weights),
          .held = {},
          .start = {}};
}

const auto& kSpecs = model_spec(ModelKind::paper).params;

double relative_error(double fitted, double truth) { return std::abs(fitted - truth) / truth; }

std::string describe(const Params& p) {
  std::ostringstream out;
  for (std::size_t i = 0; i < p.size(); ++i) out << (i ? ", " : "") << kSpecs[i].name << " " << p[i];
  return out.str();
}

// ---------------------------------------------------------------------------------------------
// Tolerances of the recovery requirement

constexpr double kMelaninRelativeTolerance = 0.05;
constexpr double kSurfaceReflectanceTolerance = 0.005;
constexpr double kOxyRelativeTolerance = 0.10;
// Oxy-haemoglobin is only required where the fit itself says the dermis is seen: a reported
// relative standard error below 3 %, which puts the 10 % tolerance beyond 3 standard errors.
// Under much melanin the blood is hidden, the standard error says so, and any value is honest.
constexpr double kOxyVisibleRelativeStandardError = 0.03;
constexpr double kStandardErrorMultiple = 3;
constexpr double kRequiredCoverage = 0.80;

bool oxy_visible(const FitResult& fit) {
  return fit.standard_error[kOxyhemoglobin] < kOxyVisibleRelativeStandardError * fit.params[kOxyhemoglobin];
}

struct RecoveryErrors {
  double melanin_error = 0;  // relative
  double surface_error = 0;  // absolute
  double oxy_error = 0;      // relative
};

RecoveryErrors recovery(const FitResult& fit, const Params& truth) {
  return {relative_error(fit.params[kMelanin], truth[kMelanin]),
          std::abs(fit.params[kSurfaceReflectance] - truth[kSurfaceReflectance]),
          relative_error(fit.params[kOxyhemoglobin], truth[kOxyhemoglobin])};
}

// Whether a fit meets the recovery requirement (oxy only where visible).
bool recovered(const FitResult& fit, const Params& truth) {
  const RecoveryErrors r = recovery(fit, truth);
  return r.melanin_error <= kMelaninRelativeTolerance && r.surface_error <= kSurfaceReflectanceTolerance &&
         (!oxy_visible(fit) || r.oxy_error <= kOxyRelativeTolerance);
}

// ---------------------------------------------------------------------------------------------
// The recovery cases: very light to very dark skin (melanin over 45x) crossed with blood and
// bilirubin levels and surface reflectances, each with its own noise.

constexpr double kMelaninLevels[] = {1, 3, 8, 15, 30, 45};

struct DermisLevel {
  double surface, oxy, deoxy, bilirubin;
};
constexpr DermisLevel kDermisLevels[] = {
    {0.02, 1.0, 0.5, 0.5},  // pale, little blood
    {0.03, 2.0, 1.5, 1.0},  // venous: much deoxy-haemoglobin
    {0.04, 3.0, 1.0, 1.5},  // ordinary
    {0.05, 4.0, 0.5, 3.0},  // jaundiced
    {0.06, 6.0, 2.0, 3.0},  // flushed
};

struct RecoveryCase {
  Params truth;
  unsigned seed;
  FitResult fit;
};

std::vector<RecoveryCase> run_recovery_cases(Constants constants) {
  std::vector<RecoveryCase> cases;
  unsigned seed = 1;
  for (const double melanin : kMelaninLevels)
    for (const DermisLevel& d : kDermisLevels) {
      const Params truth = {d.surface, melanin, d.oxy, d.deoxy, d.bilirubin};
      auto fit = fitter(constants).fit(synthetic_measurement(truth, seed, true, constants), options_for());
      if (!fit) {
        std::fprintf(stderr, "fit refused a synthetic spectrum: %s\n", fit.error().c_str());
        std::abort();
      }
      cases.push_back({truth, seed++, std::move(*fit)});
    }
  return cases;
}

// Fitted once per set of constants for all the recovery tests below.
const std::vector<RecoveryCase>& recovery_cases(Constants constants) {
  static const std::vector<RecoveryCase> shipped = run_recovery_cases(Constants::kShipped);
  static const std::vector<RecoveryCase> textbook = run_recovery_cases(Constants::kTextbook);
  return constants == Constants::kShipped ? shipped : textbook;
}

std::string describe(const RecoveryCase& c) {
  std::ostringstream out;
  out << "true {" << describe(c.truth) << "}\n  fitted {" << describe(c.fit.params) << "}\n  standard errors {"
      << describe(c.fit.standard_error) << "}\n  seed " << c.seed << ", " << c.fit.iterations << " iterations, "
      << c.fit.solver_message;
  return out.str();
}

class Recovery : public ::testing::TestWithParam<Constants> {
 protected:
  static const std::vector<RecoveryCase>& cases() { return recovery_cases(GetParam()); }
};

TEST_P(Recovery, CoversSkinFromVeryLightToVeryDark) {
  const auto [lightest, darkest] = std::ranges::minmax(kMelaninLevels);
  EXPECT_GE(darkest / lightest, 30.0);
  EXPECT_EQ(cases().size(), std::size(kMelaninLevels) * std::size(kDermisLevels));
}

TEST_P(Recovery, EveryFitConverges) {
  for (const auto& c : cases()) EXPECT_TRUE(c.fit.converged) << describe(c);
}

TEST_P(Recovery, ResidualsAreTheNoise) {
  // A fit that found the true minimum leaves residuals of the noise's size.
  for (const auto& c : cases()) {
    EXPECT_LT(c.fit.rmse, 1.3 * kNoiseSigma) << describe(c);
    EXPECT_GT(c.fit.rmse, 0.7 * kNoiseSigma) << describe(c);
  }
}

TEST_P(Recovery, MelaninWithinFivePercentThroughout) {
  double worst = 0;
  for (const auto& c : cases()) {
    const double error = recovery(c.fit, c.truth).melanin_error;
    worst = std::max(worst, error);
    EXPECT_LE(error, kMelaninRelativeTolerance) << describe(c);
  }
  RecordProperty("worst_melanin_relative_error", std::to_string(worst));
}

TEST_P(Recovery, SurfaceReflectanceWithinHalfAPercentThroughout) {
  double worst = 0;
  for (const auto& c : cases()) {
    const double error = recovery(c.fit, c.truth).surface_error;
    worst = std::max(worst, error);
    EXPECT_LE(error, kSurfaceReflectanceTolerance) << describe(c);
  }
  RecordProperty("worst_surface_reflectance_error", std::to_string(worst));
}

TEST_P(Recovery, OxyhaemoglobinWithinTenPercentWhereTheDermisIsSeen) {
  std::size_t visible = 0;
  double worst = 0;
  for (const auto& c : cases()) {
    if (!oxy_visible(c.fit)) continue;
    ++visible;
    const double error = recovery(c.fit, c.truth).oxy_error;
    worst = std::max(worst, error);
    EXPECT_LE(error, kOxyRelativeTolerance) << describe(c);
  }
  // The criterion must not excuse everything: light skin with ordinary blood must show it.
  EXPECT_GE(visible, std::size(kDermisLevels)) << "too few cases where the fit sees oxy-haemoglobin";
  for (const auto& c : cases()) {
    if (c.truth[kMelanin] <= 1 && c.truth[kOxyhemoglobin] >= 3) {
      EXPECT_TRUE(oxy_visible(c.fit)) << "light skin hides its blood?\n" << describe(c);
    }
  }
  RecordProperty("oxy_visible_cases", static_cast<int>(visible));
  RecordProperty("worst_visible_oxy_relative_error", std::to_string(worst));
}

TEST_P(Recovery, StandardErrorsAreHonest) {
  // For a correct fit with Gaussian noise, |fitted - true| <= 3 SE should hold for ~99 % of
  // estimates; 80 % allows for the linearisation and for parameters held at a bound.
  std::size_t covered = 0, total = 0;
  std::ostringstream missed;
  for (const auto& c : cases())
    for (std::size_t i = 0; i < kSpecs.size(); ++i) {
      ++total;
      const double error = std::abs(c.fit.params[i] - c.truth[i]);
      if (error <= kStandardErrorMultiple * c.fit.standard_error[i]) ++covered;
      else missed << kSpecs[i].name << " off by " << error / c.fit.standard_error[i] << " SE: " << describe(c) << "\n";
    }
  const double coverage = static_cast<double>(covered) / static_cast<double>(total);
  RecordProperty("three_se_coverage", std::to_string(coverage));
  EXPECT_GE(coverage, kRequiredCoverage) << covered << " of " << total << " covered\n" << missed.str();
}

TEST_P(Recovery, MelaninAndSurfaceStandardErrorsAreFinite) {
  // These two are seen at every melanin level; an infinite error would hide a singular fit.
  for (const auto& c : cases()) {
    EXPECT_TRUE(std::isfinite(c.fit.standard_error[kMelanin])) << describe(c);
    EXPECT_TRUE(std::isfinite(c.fit.standard_error[kSurfaceReflectance])) << describe(c);
  }
}

INSTANTIATE_TEST_SUITE_P(Constants, Recovery, ::testing::Values(Constants::kShipped, Constants::kTextbook),
                         [](const auto& test) { return name_of(test.param); });

// ---------------------------------------------------------------------------------------------
// Without lateral diffusion

class RecoveryWithoutLateralDiffusion : public ::testing::TestWithParam<Constants> {};

TEST_P(RecoveryWithoutLateralDiffusion, RecoversAModelWithoutIt) {
  const Params truths[] = {
      {0.02, 1.0, 1.0, 0.5, 0.5},
      {0.04, 3.0, 3.0, 1.0, 1.5},
      {0.05, 8.0, 4.0, 0.5, 3.0},
      {0.06, 30.0, 6.0, 2.0, 3.0},
  };
  unsigned seed = 1000;
  for (const Params& truth : truths) {
    const auto measured = synthetic_measurement(truth, seed++, false, GetParam());
    const auto fit = fitter(GetParam()).fit(measured, options_for(false));
    ASSERT_TRUE(fit.has_value()) << fit.error();
    EXPECT_TRUE(fit->converged) << describe(truth);
    EXPECT_TRUE(recovered(*fit, truth)) << "true {" << describe(truth) << "}\n  fitted {" << describe(fit->params)
                                        << "}\n  standard errors {" << describe(fit->standard_error) << "}\n  "
                                        << fit->iterations << " iterations";
  }
}

INSTANTIATE_TEST_SUITE_P(Constants, RecoveryWithoutLateralDiffusion,
                         ::testing::Values(Constants::kShipped, Constants::kTextbook),
                         [](const auto& test) { return name_of(test.param); });

// ---------------------------------------------------------------------------------------------
// Weights

const Params kOrdinarySkin = {0.04, 3.0, 3.0, 1.0, 1.5};
constexpr unsigned kOrdinarySeed = 77;

bool in_corrupted_band(double wavelength_nm) { return wavelength_nm >= 600 && wavelength_nm <= 640; }

// The ordinary skin with a +0.2 artefact over 600-640 nm (a lamp line, a fluorescent filter).
Spectrum corrupted_measurement() {
  auto values = with_noise(model_reflectance(kOrdinarySkin, true), kOrdinarySeed);
  for (std::size_t i = 0; i < values.size(); ++i)
    if (in_corrupted_band(measurement_grid()[i])) values[i] += 0.2;
  return spectrum(measurement_grid(), values);
}

std::vector<double> weights_ignoring_corrupted_band() {
  std::vector<double> weights;
  for (const double w : measurement_grid()) weights.push_back(in_corrupted_band(w) ? 0.0 : 1.0);
  return weights;
}

TEST(Weights, CleanOrdinarySkinIsRecovered) {
  // The baseline for the two tests below: without the artefact this case is recovered.
  const auto fit = fitter().fit(synthetic_measurement(kOrdinarySkin, kOrdinarySeed), options_for());
  ASSERT_TRUE(fit.has_value()) << fit.error();
  EXPECT_TRUE(recovered(*fit, kOrdinarySkin)) << describe(fit->params);
}

TEST(Weights, ACorruptedBandSpoilsTheUnweightedFit) {
  const auto fit = fitter().fit(corrupted_measurement(), options_for());
  ASSERT_TRUE(fit.has_value()) << fit.error();
  EXPECT_FALSE(recovered(*fit, kOrdinarySkin)) << describe(fit->params);
}

TEST(Weights, ZeroWeightOnTheCorruptedBandIgnoresIt) {
  const auto fit = fitter().fit(corrupted_measurement(), options_for(true, weights_ignoring_corrupted_band()));
  ASSERT_TRUE(fit.has_value()) << fit.error();
  EXPECT_TRUE(fit->converged);
  EXPECT_TRUE(recovered(*fit, kOrdinarySkin)) << describe(fit->params);
  // The band is still reported (fitted and measured), just not fitted to.
  EXPECT_EQ(fit->wavelength_nm.size(), measurement_grid().size());
}

TEST(Weights, WrongNumberIsAnError) {
  auto weights = weights_ignoring_corrupted_band();
  weights.pop_back();
  const auto fit = fitter().fit(corrupted_measurement(), options_for(true, weights));
  ASSERT_FALSE(fit.has_value());
  EXPECT_THAT(fit.error(), HasSubstr("weights"));
  EXPECT_THAT(fit.error(), HasSubstr(std::to_string(weights.size())));
  EXPECT_THAT(fit.error(), HasSubstr(std::to_string(measurement_grid().size())));
}

TEST(Weights, NegativeWeightIsAnError) {
  auto weights = weights_ignoring_corrupted_band();
  weights[10] = -1;
  const auto fit = fitter().fit(corrupted_measurement(), options_for(true, weights));
  ASSERT_FALSE(fit.has_value());
  EXPECT_THAT(fit.error(), HasSubstr("weight"));
}

// ---------------------------------------------------------------------------------------------
// Input checks

TEST(FitInput, SpectrumNotCovering420To680IsAnError) {
  for (const auto& [first, last] : {std::pair{424.0, 780.0}, std::pair{380.0, 676.0}}) {
    const auto grid = Spectrum::uniform_grid(first, last, 4);
    const auto fit = fitter().fit(spectrum(grid, model_reflectance(kOrdinarySkin, true, grid)), options_for());
    ASSERT_FALSE(fit.has_value()) << first << "-" << last << " nm";
    EXPECT_THAT(fit.error(), HasSubstr("420-680")) << first << "-" << last << " nm";
  }
}

TEST(FitInput, SpectrumCoveringOnly400To700IsAccepted) {
  const auto grid = Spectrum::uniform_grid(400, 700, 5);
  const auto fit = fitter().fit(spectrum(grid, model_reflectance(kOrdinarySkin, true, grid)), options_for());
  ASSERT_TRUE(fit.has_value()) << fit.error();
  EXPECT_TRUE(recovered(*fit, kOrdinarySkin)) << describe(fit->params);
}

// Four samples cannot determine the model's parameters: the fit still ends, with finite
// values, and does not claim to know what it cannot.
TEST(FitInput, FewerSamplesThanParametersGiveAFitThatDeterminesLess) {
  FitOptions options = options_for();
  options.lateral_diffusion = false;
  const auto fit = fitter().fit(spectrum({400, 500, 600, 700}, {0.3, 0.35, 0.5, 0.6}), options);
  ASSERT_TRUE(fit.has_value()) << fit.error();
  ASSERT_GT(fit->params.size(), 4u);
  EXPECT_TRUE(std::ranges::all_of(fit->params, [](double v) { return std::isfinite(v); })) << describe(fit->params);
  EXPECT_TRUE(std::ranges::any_of(fit->determination, [](const auto& d) { return !d.determined(); }));
}

TEST(FitInput, UnknownSiteIsAnErrorListingTheKnownOnes) {
  FitOptions options = options_for();
  options.site = "elbow";
  const auto fit = fitter().fit(synthetic_measurement(kOrdinarySkin, kOrdinarySeed), options);
  ASSERT_FALSE(fit.has_value());
  EXPECT_THAT(fit.error(), HasSubstr("elbow"));
  for (const auto& name : shipped_optics().site_names()) EXPECT_THAT(fit.error(), HasSubstr(name));
}

TEST(FitInput, SamplesOutsideTheModelRangeAreIgnoredAndCounted) {
  // 360-800 nm: five samples below 380 nm and five above 780 nm, holding values no skin has.
  const auto wide_grid = Spectrum::uniform_grid(360, 800, 4);
  const auto inside = with_noise(model_reflectance(kOrdinarySkin, true), kOrdinarySeed);
  std::vector<double> values;
  std::size_t inside_index = 0, outside = 0;
  for (const double w : wide_grid) {
    if (w < SkinOptics::kFirstNm || w > SkinOptics::kLastNm) {
      values.push_back(5.0);
      ++outside;
    } else {
      values.push_back(inside.at(inside_index++));
    }
  }
  ASSERT_EQ(outside, 10u);
  ASSERT_EQ(inside_index, inside.size());

  const auto fit = fitter().fit(spectrum(wide_grid, values), options_for());
  ASSERT_TRUE(fit.has_value()) << fit.error();
  EXPECT_EQ(fit->samples_ignored, outside);
  EXPECT_EQ(fit->wavelength_nm, measurement_grid());
  EXPECT_EQ(fit->measured, inside);
  EXPECT_TRUE(recovered(*fit, kOrdinarySkin)) << describe(fit->params);
}

TEST(FitInput, WeightsStillAlignWithSamplesWhenSomeAreIgnored) {
  // Weights are given per input sample, including the ignored ones.
  const auto wide_grid = Spectrum::uniform_grid(360, 800, 4);
  const auto inside = model_reflectance(kOrdinarySkin, true);
  std::vector<double> values, weights;
  std::size_t inside_index = 0;
  for (const double w : wide_grid) {
    const bool outside = w < SkinOptics::kFirstNm || w > SkinOptics::kLastNm;
    values.push_back(outside ? 5.0 : inside.at(inside_index++) + (in_corrupted_band(w) ? 0.2 : 0.0));
    weights.push_back(outside || in_corrupted_band(w) ? 0.0 : 1.0);
  }
  const auto fit = fitter().fit(spectrum(wide_grid, values), options_for(true, weights));
  ASSERT_TRUE(fit.has_value()) << fit.error();
  EXPECT_TRUE(recovered(*fit, kOrdinarySkin)) << describe(fit->params);
}

// ---------------------------------------------------------------------------------------------
// What the result reports

// One ordinary fit, shared by the checks of what a result reports.
const FitResult& ordinary_fit() {
  static const FitResult fit = [] {
    auto result = fitter().fit(synthetic_measurement(kOrdinarySkin, kOrdinarySeed), options_for());
    if (!result) {
      std::fprintf(stderr, "fit refused a synthetic spectrum: %s\n", result.error().c_str());
      std::abort();
    }
    return *result;
  }();
  return fit;
}

TEST(ReportedFit, MeasuredIsTheInput) {
  const FitResult& fit = ordinary_fit();
  EXPECT_EQ(fit.site, kSite);
  EXPECT_EQ(fit.wavelength_nm, measurement_grid());
  EXPECT_EQ(fit.measured, with_noise(model_reflectance(kOrdinarySkin, true), kOrdinarySeed));
  EXPECT_EQ(fit.samples_ignored, 0u);
}

TEST(ReportedFit, FittedIsTheModelAtTheFittedParameters) {
  const FitResult& fit = ordinary_fit();
  const SkinModel model(shipped_optics(), *shipped_optics().site(kSite), fit.wavelength_nm, true);
  const auto expected = model.reflectance(fit.params);
  ASSERT_EQ(fit.fitted.size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) EXPECT_NEAR(fit.fitted[i], expected[i], 1e-12);
}

TEST(ReportedFit, RmseAndMaxErrorMatchTheResiduals) {
  const FitResult& fit = ordinary_fit();
  double sum_squares = 0, max_abs = 0;
  for (std::size_t i = 0; i < fit.fitted.size(); ++i) {
    const double r = fit.fitted[i] - fit.measured[i];
    sum_squares += r * r;
    max_abs = std::max(max_abs, std::abs(r));
  }
  EXPECT_NEAR(fit.rmse, std::sqrt(sum_squares / static_cast<double>(fit.fitted.size())), 1e-12);
  EXPECT_NEAR(fit.max_abs_error, max_abs, 1e-15);
  EXPECT_GE(fit.max_abs_error, fit.rmse);
}

TEST(ReportedFit, ColourDifferenceIsCiede2000UnderD65) {
  const FitResult& fit = ordinary_fit();
  const auto& colorimetry = testing::colorimetry();
  const auto d65 = colorimetry.illuminant("D65");
  ASSERT_TRUE(d65.has_value()) << d65.error();
  const Lab measured = colorimetry.lab(spectrum(fit.wavelength_nm, fit.measured), *d65);
  const Lab fitted = colorimetry.lab(spectrum(fit.wavelength_nm, fit.fitted), *d65);
  EXPECT_NEAR(fit.delta_e00_d65, delta_e2000(measured, fitted), 1e-9);
  // Noise of 0.002 in reflectance is well under one just-noticeable difference.
  EXPECT_LT(fit.delta_e00_d65, 1.0);
}

TEST(ReportedFit, ParametersStayInsideTheirBounds) {
  const FitResult& fit = ordinary_fit();
  ASSERT_EQ(fit.params.size(), kSpecs.size());
  for (std::size_t i = 0; i < kSpecs.size(); ++i) {
    EXPECT_GE(fit.params[i], kSpecs[i].lower) << kSpecs[i].name;
    EXPECT_LE(fit.params[i], kSpecs[i].upper) << kSpecs[i].name;
    EXPECT_GE(fit.standard_error[i], 0.0) << kSpecs[i].name;
  }
  EXPECT_EQ(fit.model, ModelKind::paper);
  EXPECT_GT(fit.iterations, 0);
  EXPECT_FALSE(fit.solver_message.empty());
}

TEST(FitOfTheModelItself, NoiselessSpectrumIsFittedExactly) {
  const auto fit = fitter().fit(spectrum(measurement_grid(), model_reflectance(kOrdinarySkin, true)), options_for());
  ASSERT_TRUE(fit.has_value()) << fit.error();
  EXPECT_LT(fit->rmse, 1e-6);
  for (std::size_t i = 0; i < kSpecs.size(); ++i)
    EXPECT_NEAR(fit->params[i], kOrdinarySkin[i], 1e-3 * kOrdinarySkin[i]) << kSpecs[i].name;
}

// A Fitter keeps what fits on one grid share (the model on the grid, its bounds, the coarse
// search's layers) between fits. Spectra on other grids, on other sites, with and without
// lateral diffusion and with parameters held, fitted in turn by one Fitter, get exactly what a
// new Fitter gives each of them.
TEST(FitterReuse, WhatAFitterKeepsBetweenFitsChangesNoAnswer) {
  const Fitter reused(shipped_optics(), testing::colorimetry());
  const std::vector<double> coarse_grid = Spectrum::uniform_grid(400, 760, 10);
  struct Case {
    Spectrum measured;
    FitOptions options;
  };
  std::vector<Case> cases;
  for (const bool lateral : {true, false}) {
    cases.push_back({synthetic_measurement(kOrdinarySkin, 7, lateral), options_for(lateral)});
    cases.push_back({spectrum(coarse_grid, with_noise(model_reflectance(kOrdinarySkin, lateral, coarse_grid), 8)),
                     options_for(lateral)});
    FitOptions held = options_for(lateral);
    held.held = {{kMelanin, 4.0}};
    cases.push_back({synthetic_measurement(kOrdinarySkin, 9, lateral), held});
    FitOptions cheek = options_for(lateral);
    cheek.site = "cheek";
    cases.push_back({synthetic_measurement(kOrdinarySkin, 10, lateral), cheek});
  }
  for (int round = 0; round < 2; ++round)
    for (const Case& c : cases) {
      const auto again = reused.fit(c.measured, c.options);
      const auto fresh = Fitter(shipped_optics(), testing::colorimetry()).fit(c.measured, c.options);
      ASSERT_TRUE(again && fresh);
      EXPECT_EQ(again->params, fresh->params);
      EXPECT_EQ(again->iterations, fresh->iterations);
      EXPECT_EQ(again->fitted, fresh->fitted);
    }
}

// Each thread keeps the model it prepared last, marked with the cache it came from. Fitters of
// optics that differ only in the dermis' scattering (so that the site, the grid and the model
// are the same), each made where the one before may just have been destroyed, must each fit
// with their own.
TEST(FitterReuse, AFitterNeverFitsWithAnotherFittersOptics) {
  ModelConstants constants = shipped_optics().constants();
  constants.dermis_scattering_scale *= 1.5;
  const std::array<SkinOptics, 2> optics = {shipped_optics(), shipped_optics().with_constants(constants)};
  ASSERT_EQ(optics[0].site(kSite)->dermis_mm, optics[1].site(kSite)->dermis_mm);
  const Spectrum measured = synthetic_measurement(kOrdinarySkin, 7, false);
  std::array<Params, 2> answers;
  for (std::size_t i = 0; i < 2; ++i) {
    const auto fit = Fitter(optics[i], testing::colorimetry()).fit(measured, options_for(false));
    ASSERT_TRUE(fit);
    answers[i] = fit->params;
  }
  ASSERT_NE(answers[0], answers[1]);
  for (std::size_t round = 0; round < 6; ++round) {
    const auto fit = Fitter(optics[round % 2], testing::colorimetry()).fit(measured, options_for(false));
    ASSERT_TRUE(fit);
    EXPECT_EQ(fit->params, answers[round % 2]) << "round " << round;
  }
}

}  // namespace
}  // namespace skinspec
