#include "skinspec/fit/model.hpp"

#include <ceres/ceres.h>
#include <ceres/gradient_checker.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <array>
#include <cctype>
#include <cmath>
#include <expected>
#include <functional>
#include <string>
#include <vector>

#include "skinspec/fit/optics.hpp"
#include "skinspec/spectral/spectrum.hpp"
#include "support/data.hpp"
#include "support/reference_model.hpp"
#include "spectrum_model.hpp"  // fit/src: the solver's model at every sample at once

namespace skinspec {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

// ---------------------------------------------------------------------------------------------
// Shared fixtures

using testing::shipped_optics;
using testing::source_data_reader;
using testing::textbook_optics;

const Site& shipped_forearm() {
  static const Site site = *shipped_optics().site("forearm");
  return site;
}

const Site& textbook_forearm() {
  static const Site site = *textbook_optics().site("forearm");
  return site;
}

// Parameter sets spanning light to dark skin with ordinary blood and bilirubin.
const std::vector<Params> kOrdinarySkins = {
    {0.02, 0.5, 1.0, 0.5, 0.5},
    {0.04, 3.0, 3.0, 1.0, 1.0},
    {0.05, 15.0, 5.0, 2.0, 2.0},
    {0.06, 45.0, 6.0, 2.0, 3.0},
};

// ---------------------------------------------------------------------------------------------
// Eq. 1 written out independently of model.hpp, in the paper's hyperbolic forms
// (support/reference_model.hpp).

namespace reference = testing::reference;

// R(lambda) of eq. 1 at index i of the tables' 1 nm grid.
double plain_eq1(const LayerOptics& o, std::size_t i, const Site& site, const Params& p) {
  return reference::eq1({o.Ke[i], o.Se[i], o.Kd[i], o.Sd[i], o.Km[i], o.Kh[i], o.Kdh[i], o.Kb[i]}, site.epidermis_mm,
                        site.dermis_mm,
                        {p[kSurfaceReflectance], p[kMelanin], p[kOxyhemoglobin], p[kDeoxyhemoglobin], p[kBilirubin]});
}

// Index of a whole wavelength on the tables' grid (380-780 nm every 1 nm).
std::size_t table_index(double wavelength_nm) { return static_cast<std::size_t>(wavelength_nm - SkinOptics::kFirstNm); }

// ---------------------------------------------------------------------------------------------
// Hand-computed values

TEST(KubelkaLayer, MatchesHandComputedValuesForMadeUpConstants) {
  // K = 0.5, S = 2, D = 0.3: a = 1.25, b = 0.75, C = 0.45; reference R and T to 30 significant digits.
  const auto thin = kubelka_layer(0.5, 2.0, 0.3);
  EXPECT_NEAR(thin.r, 0.330286263579865367900182787913, 1e-14);
  EXPECT_NEAR(thin.t, 0.532328241745527606569081615778, 1e-14);
  // K = 3, S = 0.8, D = 0.05: a = 4.75, b = 4.6435439052516775, C = 0.18574175621006710.
  const auto absorbing = kubelka_layer(3.0, 0.8, 0.05);
  EXPECT_NEAR(absorbing.r, 0.0332924491900764360811833647572, 1e-14);
  EXPECT_NEAR(absorbing.t, 0.8275446331572380382707601946, 1e-14);
}

TEST(KubelkaLayer, AgreesWithTheHyperbolicFormsOverAWideRangeOfConstants) {
  for (const double K : {1e-4, 0.01, 0.3, 2.0, 40.0})
    for (const double S : {0.5, 3.0, 30.0})
      for (const double D : {0.01, 0.1, 1.0}) {
        const auto layer = kubelka_layer(K, S, D);
        const auto plain = reference::kubelka(K, S, D);
        EXPECT_NEAR(layer.r, plain.r, 1e-12) << "K=" << K << " S=" << S << " D=" << D;
        EXPECT_NEAR(layer.t, plain.t, 1e-12) << "K=" << K << " S=" << S << " D=" << D;
      }
}

TEST(SkinModel, MatchesEquationOneWrittenOutByHandAtChosenWavelengths) {
  const std::vector<double> grid = {420, 555, 660};  // Soret band, Q bands, red
  const Params p = {0.035, 2.5, 3.0, 1.2, 0.8};
  const SkinModel model(shipped_optics(), shipped_forearm(), grid, /*lateral_diffusion=*/false);
  const auto r = model.reflectance(p);
  ASSERT_EQ(r.size(), grid.size());
  for (std::size_t i = 0; i < grid.size(); ++i) {
    const double expected = plain_eq1(shipped_optics().optics(), table_index(grid[i]), shipped_forearm(), p);
    EXPECT_NEAR(r[i], expected, 1e-12) << grid[i] << " nm";
  }
}

TEST(SkinModel, MatchesEquationOneOnEverySiteAndTheWholeGrid) {
  const auto& optics = shipped_optics().optics();
  const auto grid = Spectrum::uniform_grid(SkinOptics::kFirstNm, SkinOptics::kLastNm, 1);
  for (const auto& name : shipped_optics().site_names()) {
    const Site site = *shipped_optics().site(name);
    const SkinModel model(shipped_optics(), site, grid, false);
    for (const Params& p : kOrdinarySkins) {
      const auto r = model.reflectance(p);
      for (std::size_t i = 0; i < grid.size(); ++i)
        ASSERT_NEAR(r[i], plain_eq1(optics, i, site, p), 1e-12) << name << " " << grid[i] << " nm";
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Limits

TEST(KubelkaLayer, VeryThickLayerTendsToRInfinityAndNoTransmission) {
  const double S = 2.0;
  for (const double K : {1e-8, 1e-3, 0.5, 20.0})
    for (const double D : {1e6, 1e300}) {  // optical depth C from 200 to 1e301
      const auto layer = kubelka_layer(K, S, D);
      const double a = (S + K) / S;
      const double b = std::sqrt(a * a - 1);
      ASSERT_TRUE(std::isfinite(layer.r) && std::isfinite(layer.t)) << "K=" << K << " D=" << D;
      EXPECT_NEAR(layer.r, a - b, 1e-12) << "K=" << K << " D=" << D;
      EXPECT_GE(layer.t, 0.0) << "K=" << K << " D=" << D;
      EXPECT_LT(layer.t, 1e-80) << "K=" << K << " D=" << D;
    }
}

TEST(KubelkaLayer, NonAbsorbingLimitIsFinite) {
  // With K -> 0 the layer conserves light: R + T -> 1.
  const auto layer = kubelka_layer(1e-12, 2.0, 0.5);
  ASSERT_TRUE(std::isfinite(layer.r) && std::isfinite(layer.t));
  EXPECT_NEAR(layer.r + layer.t, 1.0, 1e-5);
}

TEST(SkinModel, ZeroPigmentWeightsGiveTheBaselineTissue) {
  const auto& o = shipped_optics().optics();
  const auto grid = Spectrum::uniform_grid(SkinOptics::kFirstNm, SkinOptics::kLastNm, 1);
  const SkinModel model(shipped_optics(), shipped_forearm(), grid, false);
  const double rs = 0.04;
  const auto r = model.reflectance({rs, 0, 0, 0, 0});
  for (std::size_t i = 0; i < grid.size(); ++i) {
    // Only the baseline absorption Ke, Kd: the pigment rows must play no part at all.
    const double baseline =
        reference::skin_reflectance(reference::kubelka(o.Ke[i], o.Se[i], shipped_forearm().epidermis_mm),
                                    reference::kubelka(o.Kd[i], o.Sd[i], shipped_forearm().dermis_mm), rs);
    ASSERT_NEAR(r[i], baseline, 1e-12) << grid[i] << " nm";
  }
}

TEST(SkinModel, SurfaceReflectanceOfOneReflectsEverything) {
  const auto grid = Spectrum::uniform_grid(SkinOptics::kFirstNm, SkinOptics::kLastNm, 5);
  for (const bool lateral : {false, true}) {
    const SkinModel model(shipped_optics(), shipped_forearm(), grid, lateral);
    for (double value : model.reflectance({1.0, 30, 5, 2, 3})) EXPECT_NEAR(value, 1.0, 1e-15);
  }
}

TEST(SkinModel, ReflectanceStaysStrictlyBetweenZeroAndOneForOrdinarySkin) {
  const auto grid = Spectrum::uniform_grid(SkinOptics::kFirstNm, SkinOptics::kLastNm, 1);
  for (const SkinOptics* optics_under_test : {&shipped_optics(), &textbook_optics()}) {
    const SkinOptics& optics = *optics_under_test;
    for (const auto& name : optics.site_names())
      for (const bool lateral : {false, true}) {
        const SkinModel model(optics, *optics.site(name), grid, lateral);
        for (const Params& p : kOrdinarySkins) {
          const auto r = model.reflectance(p);
          for (std::size_t i = 0; i < grid.size(); ++i) {
            ASSERT_GT(r[i], 0.0) << name << " " << grid[i] << " nm";
            ASSERT_LT(r[i], 1.0) << name << " " << grid[i] << " nm";
          }
        }
      }
  }
}

TEST(SkinModel, MoreMelaninLowersReflectanceAtEveryWavelength) {
  const auto grid = Spectrum::uniform_grid(SkinOptics::kFirstNm, SkinOptics::kLastNm, 1);
  for (const bool lateral : {false, true}) {
    const SkinModel model(shipped_optics(), shipped_forearm(), grid, lateral);
    std::vector<double> previous;
    for (const double melanin : {0.0, 1.0, 3.0, 10.0, 30.0, 100.0}) {
      const auto r = model.reflectance({0.04, melanin, 3.0, 1.0, 1.0});
      for (std::size_t i = 0; i < previous.size(); ++i)
        ASSERT_LT(r[i], previous[i]) << "melanin " << melanin << " at " << grid[i] << " nm";
      previous = r;
    }
  }
}

TEST(SkinModel, LateralDiffusionOnlyRemovesLight) {
  const auto grid = Spectrum::uniform_grid(SkinOptics::kFirstNm, SkinOptics::kLastNm, 1);
  const SkinModel with_loss(textbook_optics(), textbook_forearm(), grid, true);
  const SkinModel without_loss(textbook_optics(), textbook_forearm(), grid, false);
  for (const Params& p : kOrdinarySkins) {
    const auto lossy = with_loss.reflectance(p);
    const auto full = without_loss.reflectance(p);
    for (std::size_t i = 0; i < grid.size(); ++i) {
      // In the blue, light is absorbed long before it reaches the radius: the loss is there
      // but below rounding. In the red it must be visible.
      if (grid[i] >= 600) ASSERT_LT(lossy[i], full[i]) << grid[i] << " nm";
      else ASSERT_LE(lossy[i], full[i]) << grid[i] << " nm";
      ASSERT_GT(lossy[i], p[kSurfaceReflectance]) << grid[i] << " nm";
    }
  }
}

// Dermis absorption at one wavelength for ordinary blood and bilirubin.
double ordinary_dermis_K(std::size_t i) {
  const auto& o = textbook_optics().optics();
  return o.Kd[i] + 3.0 * o.Kh[i] + 1.0 * o.Kdh[i] + 1.0 * o.Kb[i];
}

// The fit's coarse search computes each layer once per level of what it varies and combines
// them: that holds only while the epidermis depends on melanin alone and the dermis on
// neither melanin nor Rs, in every model.
TEST(SkinModel, EachLayerDependsOnlyOnItsOwnParameters) {
  for (const ModelKind kind : kModelKinds) {
    const SkinOptics& optics = shipped_optics(kind);
    const SkinModel model(optics, *optics.site("forearm"), Spectrum::uniform_grid(380, 780, 4), true);
    const Params base = default_params(kind);
    const auto specs = model_spec(kind).params;
    for (std::size_t changed = 0; changed < base.size(); ++changed) {
      Params p = base;
      p[changed] = specs[changed].lower + 0.3 * (specs[changed].upper - specs[changed].lower);
      ASSERT_NE(p[changed], base[changed]) << specs[changed].name;
      const bool epidermal = changed == kMelanin, surface = changed == kSurfaceReflectance;
      bool epidermis_changed = false, dermis_changed = false;
      for (std::size_t i = 0; i < model.size(); ++i) {
        const auto epidermis = model.epidermis_at(i, p.data()), epidermis_before = model.epidermis_at(i, base.data());
        const auto dermis = model.dermis_at(i, p.data()), dermis_before = model.dermis_at(i, base.data());
        epidermis_changed |= epidermis.r != epidermis_before.r || epidermis.t != epidermis_before.t;
        dermis_changed |= dermis.total != dermis_before.total || dermis.kept != dermis_before.kept;
        EXPECT_EQ(model.reflectance_at(i, p.data()),
                  combined_reflectance(model.optics_at(i), p[kSurfaceReflectance], epidermis, dermis));
      }
      EXPECT_EQ(epidermis_changed, epidermal) << to_string(kind) << " " << specs[changed].name;
      EXPECT_EQ(dermis_changed, !epidermal && !surface) << to_string(kind) << " " << specs[changed].name;
    }
  }
}

TEST(LateralLoss, IsZeroWithoutARadius) {
  const auto& o = textbook_optics().optics();
  const std::size_t i = table_index(550);
  EXPECT_EQ(lateral_loss(ordinary_dermis_K(i), o.Sd[i], 0.0), 0.0);
}

TEST(LateralLoss, IsAFractionForPositiveRadii) {
  const auto& o = textbook_optics().optics();
  for (const double radius : {0.1, 1.0, 3.0, 10.0})
    for (std::size_t i = 0; i < o.wavelength_nm.size(); i += 10) {
      const double loss = lateral_loss(ordinary_dermis_K(i), o.Sd[i], radius);
      ASSERT_GT(loss, 0.0) << radius << " mm at " << o.wavelength_nm[i] << " nm";
      ASSERT_LT(loss, 1.0) << radius << " mm at " << o.wavelength_nm[i] << " nm";
    }
}

TEST(LateralLoss, IsLargerInTheRedThanInTheBlue) {
  // Red light is absorbed less by blood, so it diffuses further and more of it escapes the
  // instrument: the reason Doi et al. compensate for lateral diffusion at long wavelengths.
  const auto& o = textbook_optics().optics();
  const std::size_t blue = table_index(450), red = table_index(700);
  for (const double radius : {0.5, 1.0, 3.0}) {
    const double loss_blue = lateral_loss(ordinary_dermis_K(blue), o.Sd[blue], radius);
    const double loss_red = lateral_loss(ordinary_dermis_K(red), o.Sd[red], radius);
    EXPECT_GT(loss_red, loss_blue) << radius << " mm";
  }
}

// ---------------------------------------------------------------------------------------------
// Derivatives: the fitter differentiates the templated model with Ceres' Jets; check those
// against numeric differentiation of the same residual.

struct ModelResidual {
  const SkinModel& model;
  std::vector<double> measured;

  template <typename T>
  bool operator()(const T* p, T* residuals) const {
    for (std::size_t i = 0; i < model.size(); ++i) residuals[i] = model.reflectance_at(i, p) - measured[i];
    return true;
  }
};

using ModelCost = ceres::AutoDiffCostFunction<ModelResidual, ceres::DYNAMIC, kPaperParamCount>;

// A measured spectrum close to, but not on, the model, so residuals are not all zero.
std::vector<double> nearby_measurement(const SkinModel& model) {
  auto r = model.reflectance({0.03, 4.0, 2.5, 1.0, 1.0});
  for (std::size_t i = 0; i < r.size(); ++i) r[i] += 0.01 * std::sin(0.1 * static_cast<double>(i));
  return r;
}

class ModelGradient : public ::testing::TestWithParam<bool> {
 protected:
  ModelGradient()
      : model_(textbook_optics(), textbook_forearm(),
               Spectrum::uniform_grid(SkinOptics::kFirstNm, SkinOptics::kLastNm, 4), GetParam()),
        cost_(new ModelResidual{model_, nearby_measurement(model_)}, static_cast<int>(model_.size())),
        checker_(&cost_, kEuclidean, numeric_options()) {}

  // Ridders' method from Ceres' default first step (1e-2 of the value) loses accuracy at small
  // pigment weights (1e-5 relative at deoxy-haemoglobin 0.05 in the Soret band); starting from
  // 1e-3 it agrees with the automatic derivatives to 1e-8 at every point below.
  static ceres::NumericDiffOptions numeric_options() {
    ceres::NumericDiffOptions options;
    options.ridders_relative_initial_step_size = 1e-3;
    return options;
  }

  static constexpr const std::vector<const ceres::Manifold*>* kEuclidean = nullptr;
  static constexpr double kRelativePrecision = 1e-6;

  SkinModel model_;
  ModelCost cost_;
  ceres::GradientChecker checker_;
};

// From nearly unpigmented to dark skin whose dermis is still seen.
const std::vector<Params> kCheckPoints = {
    {0.01, 0.05, 0.1, 0.05, 0.02},
    {0.02, 0.5, 1.0, 0.5, 0.5},
    {0.04, 3.0, 3.0, 1.0, 1.0},
    {0.05, 15.0, 5.0, 2.0, 2.0},
};

TEST_P(ModelGradient, AutomaticDerivativesMatchNumericOnes) {
  for (const Params& p : kCheckPoints) {
    const double* parameters[] = {p.data()};
    ceres::GradientChecker::ProbeResults results;
    EXPECT_TRUE(checker_.Probe(parameters, kRelativePrecision, &results))
        << "melanin " << p[kMelanin] << ": worst relative error " << results.maximum_relative_error << "\n"
        << results.error_log;
  }
}

TEST_P(ModelGradient, AutomaticDerivativesMatchNumericOnesUnderHeavyMelanin) {
  // Under melanin 60 the blue hardly sees the dermis: d R / d w_blood falls to 1e-13, below what
  // differencing a reflectance of 0.1 can resolve, so entry-wise relative errors are noise
  // there. Each entry is judged against the largest derivative for the same parameter instead.
  const Params p = {0.10, 60.0, 10.0, 8.0, 6.0};
  const double* parameters[] = {p.data()};
  ceres::GradientChecker::ProbeResults results;
  checker_.Probe(parameters, kRelativePrecision, &results);
  ASSERT_TRUE(results.return_value) << results.error_log;
  const auto& automatic = results.jacobians.at(0);
  const auto& numeric = results.numeric_jacobians.at(0);
  const auto params = model_spec(ModelKind::paper).params;
  for (int j = 0; j < kPaperParamCount; ++j) {
    const double scale = automatic.col(j).cwiseAbs().maxCoeff();
    ASSERT_GT(scale, 0.0) << params[static_cast<std::size_t>(j)].name;
    for (int i = 0; i < automatic.rows(); ++i)
      EXPECT_LE(std::abs(automatic(i, j) - numeric(i, j)), kRelativePrecision * scale)
          << params[static_cast<std::size_t>(j)].name << " at " << model_.grid()[static_cast<std::size_t>(i)] << " nm";
  }
}

INSTANTIATE_TEST_SUITE_P(LateralDiffusion, ModelGradient, ::testing::Bool(),
                         [](const auto& test) { return test.param ? "On" : "Off"; });

// ---------------------------------------------------------------------------------------------
// Loading the tables

// Every file SkinOptics::load reads.
const std::vector<std::string> kModelFiles = {
    "optics/hemoglobin_prahl.csv",
    "optics/bilirubin_photochemcad.csv",
    "optics/melanosome_jacques2013.csv",
    "optics/skin_baseline_jacques1998.csv",
    "optics/scattering_salomatina.csv",
    "model/sites.csv",
    "model/constants.csv",
};

// The files only the extended model reads.
const std::string kExtendedConstantsFile = "model/constants-extended.csv";
const std::string kExtendedSitesFile = "model/sites-extended.csv";

// The source data directory, with `file`'s bytes passed through `change` (or replaced by a
// read error when change is null).
DataReader reader_changing(std::string file, std::function<std::string(std::string)> change) {
  return [file = std::move(file),
          change = std::move(change)](std::string_view path) -> std::expected<std::string, std::string> {
    auto bytes = source_data_reader()(path);
    if (path != file || !bytes) return bytes;
    if (!change) return std::unexpected(std::string("disk on fire"));
    return change(std::move(*bytes));
  };
}

std::string without_source_line(std::string bytes) {
  const auto start = bytes.find("# source:");
  if (start == std::string::npos) return bytes;
  const auto end = bytes.find('\n', start);
  bytes.erase(start, end == std::string::npos ? std::string::npos : end - start + 1);
  return bytes;
}

std::string with_malformed_row(std::string bytes) {
  if (!bytes.empty() && bytes.back() != '\n') bytes += '\n';
  return bytes + "1000\n";  // one cell where every table has at least two columns
}

class TableLoading : public ::testing::TestWithParam<std::string> {};

TEST(TableLoadingBaseline, ShippedTablesLoad) {
  const auto optics = SkinOptics::load(source_data_reader(), ModelKind::paper);
  ASSERT_TRUE(optics.has_value()) << optics.error().what();
  EXPECT_EQ(optics->optics().wavelength_nm.size(), 401u);
  EXPECT_FALSE(optics->tables_digest().empty());
}

TEST_P(TableLoading, ReadErrorNamesTheFile) {
  const auto optics = SkinOptics::load(reader_changing(GetParam(), nullptr), ModelKind::paper);
  ASSERT_FALSE(optics.has_value());
  EXPECT_EQ(optics.error().source, GetParam());
  EXPECT_THAT(optics.error().what(), AllOf(HasSubstr(GetParam()), HasSubstr("disk on fire")));
}

TEST_P(TableLoading, MalformedTableNamesTheFileAndLine) {
  const auto optics = SkinOptics::load(reader_changing(GetParam(), with_malformed_row), ModelKind::paper);
  ASSERT_FALSE(optics.has_value());
  EXPECT_EQ(optics.error().source, GetParam());
  EXPECT_GT(optics.error().line, 0u);
  EXPECT_THAT(optics.error().what(), HasSubstr(GetParam()));
}

TEST_P(TableLoading, MissingSourceLineIsRefused) {
  const auto optics = SkinOptics::load(reader_changing(GetParam(), without_source_line), ModelKind::paper);
  ASSERT_FALSE(optics.has_value());
  EXPECT_EQ(optics.error().source, GetParam());
  EXPECT_THAT(optics.error().what(), AllOf(HasSubstr(GetParam()), HasSubstr("source")));
}

TEST_P(TableLoading, ChangingATableChangesTheDigest) {
  const auto changed =
      SkinOptics::load(reader_changing(GetParam(),
                                       [](std::string bytes) {
                                         return bytes + "\n";  // a blank line: same numbers, different bytes
                                       }),
                       ModelKind::paper);
  ASSERT_TRUE(changed.has_value()) << changed.error().what();
  EXPECT_NE(changed->tables_digest(), shipped_optics().tables_digest());
}

INSTANTIATE_TEST_SUITE_P(EachFile, TableLoading, ::testing::ValuesIn(kModelFiles), [](const auto& test) {
  std::string name = test.param;
  for (char& c : name)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return name;
});

// ---------------------------------------------------------------------------------------------
// Sites

TEST(Sites, KnownSiteHasPositiveThicknesses) {
  const auto site = shipped_optics().site("forearm");
  ASSERT_TRUE(site.has_value()) << site.error();
  EXPECT_EQ(site->name, "forearm");
  EXPECT_GT(site->epidermis_mm, 0.0);
  EXPECT_GT(site->dermis_mm, site->epidermis_mm);
}

TEST(Sites, UnknownSiteListsTheKnownOnes) {
  const auto site = shipped_optics().site("elbow");
  ASSERT_FALSE(site.has_value());
  EXPECT_THAT(site.error(), HasSubstr("elbow"));
  const auto names = shipped_optics().site_names();
  ASSERT_FALSE(names.empty());
  for (const auto& name : names) EXPECT_THAT(site.error(), HasSubstr(name));
}

TEST(Sites, ThicknessScalesApply) {
  ModelConstants constants = shipped_optics().constants();
  const Site before = *shipped_optics().site("forearm");
  constants.epidermis_thickness_scale *= 2;
  constants.dermis_thickness_scale *= 3;
  const Site after = *shipped_optics().with_constants(constants).site("forearm");
  EXPECT_NEAR(after.epidermis_mm, 2 * before.epidermis_mm, 1e-15);
  EXPECT_NEAR(after.dermis_mm, 3 * before.dermis_mm, 1e-15);
}

// The extended model keeps the stratum corneum apart from the melanin-bearing epidermis at
// every site, scaled with it; the paper model's epidermis is the whole epidermis.
TEST(Sites, OnlyTheExtendedModelHasAStratumCorneumAndItScalesWithTheEpidermis) {
  const SkinOptics& extended = shipped_optics(ModelKind::extended);
  for (const auto& name : extended.site_names()) {
    EXPECT_GT(extended.site(name)->stratum_corneum_mm, 0.0) << name;
    EXPECT_EQ(shipped_optics(ModelKind::paper).site(name)->stratum_corneum_mm, 0.0) << name;
  }
  ModelConstants constants = extended.constants();
  const Site before = *extended.site("palm");
  constants.epidermis_thickness_scale *= 2;
  EXPECT_NEAR(extended.with_constants(constants).site("palm")->stratum_corneum_mm, 2 * before.stratum_corneum_mm,
              1e-15);
}

TEST(Sites, ANegativeStratumCorneumIsRefused) {
  const auto negative = [](std::string bytes) {
    const auto at = bytes.find("forearm,0.0566,");
    return at == std::string::npos ? bytes : bytes.replace(at, 15, "forearm,0.0566,-");
  };
  const auto optics = SkinOptics::load(reader_changing(kExtendedSitesFile, negative), ModelKind::extended);
  ASSERT_FALSE(optics.has_value());
  EXPECT_THAT(optics.error().what(), AllOf(HasSubstr(kExtendedSitesFile), HasSubstr("forearm")));
}

// ---------------------------------------------------------------------------------------------
// The extended model: its equations written out by hand (support/reference_model.hpp), its
// derivatives, vessel packaging and the baseline-absorption correction.

using testing::reference::ExtendedParams;

// From nearly unpigmented to dark skin, with the free shapes away from their defaults.
const std::vector<Params> kExtendedSkins = {
    {0.03, 0.5, 2.0, 0.6, 0.5, 25, 1.0},
    {0.04, 3.0, 5.0, 0.75, 1.0, 35, 1.6},
    {0.05, 15.0, 8.0, 0.9, 2.0, 15, 2.2},
    {0.06, 45.0, 12.0, 0.45, 3.0, 50, 3.5},
};

double plain_extended(const SkinOptics& optics, std::size_t i, const Site& site, const Params& p) {
  const LayerOptics& o = optics.optics();
  return testing::reference::extended({o.Ke[i], o.Se[i], o.Kd[i], o.Sd[i], o.Km[i], o.Kh[i], o.Kdh[i], o.Kb[i]},
                                      o.wavelength_nm[i], site.epidermis_mm, site.dermis_mm,
                                      optics.constants().vessel_radius_um / 1000,
                                      {p[0], p[1], p[2], p[3], p[4], p[5], p[6]}, site.stratum_corneum_mm);
}

TEST(ExtendedModel, MatchesItsEquationsWrittenOutByHandOnEverySiteAndTheWholeGrid) {
  const SkinOptics& optics = shipped_optics(ModelKind::extended);
  ASSERT_GT(optics.constants().vessel_radius_um, 0.0);  // so that packaging is exercised
  const auto grid = Spectrum::uniform_grid(SkinOptics::kFirstNm, SkinOptics::kLastNm, 1);
  for (const auto& name : optics.site_names()) {
    const Site site = *optics.site(name);
    const SkinModel model(optics, site, grid, false);
    ASSERT_EQ(model.param_count(), static_cast<std::size_t>(kExtendedParamCount));
    for (const Params& p : kExtendedSkins) {
      const auto r = model.reflectance(p);
      for (std::size_t i = 0; i < grid.size(); ++i)
        ASSERT_NEAR(r[i], plain_extended(optics, i, site, p), 1e-12) << name << " " << grid[i] << " nm";
    }
  }
}

TEST(ExtendedModel, ReflectanceStaysStrictlyBetweenZeroAndOneAcrossItsRanges) {
  const auto grid = Spectrum::uniform_grid(SkinOptics::kFirstNm, SkinOptics::kLastNm, 1);
  const auto specs = model_spec(ModelKind::extended).params;
  for (const SkinOptics* optics : {&shipped_optics(ModelKind::extended), &textbook_optics(ModelKind::extended)})
    for (const bool lateral : {false, true}) {
      const SkinModel model(*optics, *optics->site("forearm"), grid, lateral);
      // Every corner of the plausible ranges of the scattering, ordinary pigments.
      for (const double a : {specs[kDermisScattering].lower, specs[kDermisScattering].upper})
        for (const double b : {specs[kDermisScatteringPower].lower, specs[kDermisScatteringPower].upper}) {
          const Params p = {0.04, 5, 5, 0.75, 1, a, b};
          for (const double r : model.reflectance(p)) {
            ASSERT_GT(r, 0.0);
            ASSERT_LT(r, 1.0);
          }
        }
    }
}

TEST(ExtendedModel, MoreOxygenMovesTheSoretPeakFrom433To415Nm) {
  // Deoxy-haemoglobin's Soret band peaks near 433 nm, oxy-haemoglobin's near 415 nm: raising
  // the saturation darkens 415 nm and brightens 433 nm.
  const SkinOptics& optics = textbook_optics(ModelKind::extended);
  const std::vector<double> grid = {415, 433};
  const SkinModel model(optics, *optics.site("forearm"), grid, false);
  Params venous = default_params(ModelKind::extended), arterial = venous;
  venous[kOxygenSaturation] = 0.4;
  arterial[kOxygenSaturation] = 0.95;
  const auto r_venous = model.reflectance(venous), r_arterial = model.reflectance(arterial);
  EXPECT_LT(r_arterial[0], r_venous[0]);
  EXPECT_GT(r_arterial[1], r_venous[1]);
}

TEST(VesselPackaging, IsOneForEvenlySpreadBloodAndFallsAsAbsorptionGrows) {
  EXPECT_EQ(vessel_packaging(100.0, 0.0), 1.0);
  EXPECT_NEAR(vessel_packaging(1e-6, 0.01), 1.0 - 1e-8, 1e-15);  // x = 2e-8: C = 1 - x/2 to first order
  double previous = 1;
  for (const double mu_a : {1.0, 10.0, 100.0, 1000.0}) {
    const double c = vessel_packaging(mu_a, 0.01);
    EXPECT_LT(c, previous) << mu_a;
    previous = c;
  }
  // A very strong band inside a vessel of radius r: only its surface layer absorbs, C -> 1 / x.
  EXPECT_NEAR(vessel_packaging(1e4, 0.01), 1.0 / 200, 1e-12);
  // x = 2 mu_a r = 1 exactly: C = 1 - 1/e.
  EXPECT_NEAR(vessel_packaging(50.0, 0.01), 1 - std::exp(-1.0), 1e-15);
}

TEST(MelaninExponent, ScalesTheTabulatedMelaninAroundItsPivot) {
  const SkinOptics& base = textbook_optics(ModelKind::extended);
  ModelConstants constants = base.constants();
  ASSERT_EQ(constants.melanin_exponent, 3.0);  // the table's own
  constants.melanin_exponent = 3.6;
  const SkinOptics steeper = base.with_constants(constants);
  for (std::size_t i = 0; i < base.optics().wavelength_nm.size(); i += 25) {
    const double w = base.optics().wavelength_nm[i];
    EXPECT_NEAR(steeper.optics().Km[i], base.optics().Km[i] * std::pow(w / 500, -0.6), 1e-12 * base.optics().Km[i])
        << w;
  }
}

TEST(BaselineCorrection, MultipliesTheBaselineAbsorptionByTheExpOfALegendreSeries) {
  const SkinOptics& base = textbook_optics(ModelKind::extended);
  ModelConstants constants = base.constants();
  constants.baseline_absorption[0] = 0.3;
  constants.baseline_absorption[1] = -0.2;
  constants.baseline_absorption[2] = 0.1;
  const SkinOptics corrected = base.with_constants(constants);
  for (std::size_t i = 0; i < base.optics().wavelength_nm.size(); i += 25) {
    const double x = (base.optics().wavelength_nm[i] - 580) / 200;
    const double factor = std::exp(0.3 - 0.2 * x + 0.1 * (3 * x * x - 1) / 2);
    EXPECT_NEAR(corrected.optics().Ke[i], factor * base.optics().Ke[i], 1e-12 * corrected.optics().Ke[i]);
    EXPECT_NEAR(corrected.optics().Kd[i], factor * base.optics().Kd[i], 1e-12 * corrected.optics().Kd[i]);
    EXPECT_EQ(corrected.optics().Kh[i], base.optics().Kh[i]);  // pigments untouched
    EXPECT_EQ(corrected.optics().Km[i], base.optics().Km[i]);
  }
}

TEST(ExtendedModel, AutomaticDerivativesMatchNumericOnes) {
  for (const bool lateral : {false, true}) {
    const SkinOptics& optics = shipped_optics(ModelKind::extended);
    const SkinModel model(optics, *optics.site("forearm"),
                          Spectrum::uniform_grid(SkinOptics::kFirstNm, SkinOptics::kLastNm, 4), lateral);
    auto measured = model.reflectance(kExtendedSkins[1]);
    for (std::size_t i = 0; i < measured.size(); ++i) measured[i] += 0.01 * std::sin(0.1 * static_cast<double>(i));
    ceres::AutoDiffCostFunction<ModelResidual, ceres::DYNAMIC, kExtendedParamCount> cost(
        new ModelResidual{model, measured}, static_cast<int>(model.size()));
    ceres::NumericDiffOptions numeric;
    numeric.ridders_relative_initial_step_size = 1e-3;
    ceres::GradientChecker checker(&cost, static_cast<const std::vector<const ceres::Manifold*>*>(nullptr), numeric);
    for (const Params& p : std::vector<Params>(kExtendedSkins.begin(), kExtendedSkins.begin() + 3)) {
      const double* parameters[] = {p.data()};
      ceres::GradientChecker::ProbeResults results;
      EXPECT_TRUE(checker.Probe(parameters, 1e-6, &results))
          << "lateral " << lateral << ", melanin " << p[kMelanin] << ": worst relative error "
          << results.maximum_relative_error << "\n"
          << results.error_log;
    }
  }
}

// The fit's Jacobian comes from reflectance_and_gradient, which differentiates through the
// layers' inputs; it must equal automatic differentiation of reflectance_at by every parameter.
template <int N>
void expect_model_gradient_is_automatic(const SkinModel& model, const std::vector<Params>& points) {
  ceres::AutoDiffCostFunction<ModelResidual, ceres::DYNAMIC, N> cost(
      new ModelResidual{model, std::vector<double>(model.size(), 0.0)}, static_cast<int>(model.size()));
  for (const Params& p : points) {
    std::vector<double> residuals(model.size()), automatic(model.size() * N);
    const double* parameters[] = {p.data()};
    double* jacobians[] = {automatic.data()};
    ASSERT_TRUE(cost.Evaluate(parameters, residuals.data(), jacobians));
    std::array<double, kMaxParamCount> gradient{};
    for (std::size_t i = 0; i < model.size(); ++i) {
      EXPECT_NEAR(model.reflectance_and_gradient(i, p.data(), gradient.data()), residuals[i], 1e-15);
      for (std::size_t j = 0; j < N; ++j) {
        const double expected = automatic[i * N + j];
        EXPECT_NEAR(gradient[j], expected, 1e-10 * std::abs(expected) + 1e-15)
            << model_spec(model.kind()).params[j].name << " at " << model.grid()[i] << " nm, melanin " << p[kMelanin];
      }
    }
  }
}

TEST(ModelGradientThroughLayers, EqualsAutomaticDifferentiationByEveryParameter) {
  for (const bool lateral : {false, true}) {
    const auto grid = Spectrum::uniform_grid(SkinOptics::kFirstNm, SkinOptics::kLastNm, 4);
    const SkinOptics& extended = shipped_optics(ModelKind::extended);
    expect_model_gradient_is_automatic<kExtendedParamCount>(SkinModel(extended, *extended.site("cheek"), grid, lateral),
                                                            kExtendedSkins);
    const SkinOptics& paper = shipped_optics(ModelKind::paper);
    expect_model_gradient_is_automatic<kPaperParamCount>(SkinModel(paper, *paper.site("forearm"), grid, lateral),
                                                         kCheckPoints);
  }
}

// The solver evaluates the model at every sample at once (fit/src/spectrum_model.hpp), with
// derivatives written out by hand: the same reflectance and derivatives as the model sample by
// sample, to rounding.
void expect_spectrum_model_is_the_model(const SkinModel& model, const std::vector<Params>& points) {
  const detail::SpectrumModel columns(model);
  detail::Workspace work;
  const std::size_t n = model.size(), count = model.param_count();
  std::vector<double> reflectance(n), jacobian(n * count);
  std::array<double, kMaxParamCount> gradient{};
  for (const Params& p : points) {
    columns.reflectance(p.data(), work, reflectance.data());
    columns.jacobian(p.data(), work, jacobian.data());
    for (std::size_t i = 0; i < n; ++i) {
      EXPECT_NEAR(reflectance[i], model.reflectance_and_gradient(i, p.data(), gradient.data()), 1e-14);
      for (std::size_t k = 0; k < count; ++k)
        EXPECT_NEAR(jacobian[k * n + i], gradient[k], 1e-10 * std::abs(gradient[k]) + 1e-15)
            << model_spec(model.kind()).params[k].name << " at " << model.grid()[i] << " nm, melanin " << p[kMelanin];
    }
  }
}

// On the kernels of every target the processor runs (fit/src/kernels/).
TEST(SpectrumModel, EqualsTheModelSampleBySampleWithItsDerivatives) {
  const auto grid = Spectrum::uniform_grid(SkinOptics::kFirstNm, SkinOptics::kLastNm, 3);
  const detail::FitKernels& before = detail::fit_kernels();
  for (const detail::FitKernels* kernels : detail::runnable_fit_kernels()) {
    detail::use_fit_kernels(*kernels);
    SCOPED_TRACE(detail::kernels_name(*kernels));
    for (const bool lateral : {false, true})
      // Shipped constants pack blood in vessels; textbook ones spread it evenly.
      for (const SkinOptics* optics : {&shipped_optics(ModelKind::extended), &textbook_optics(ModelKind::extended),
                                       &shipped_optics(ModelKind::paper), &textbook_optics(ModelKind::paper)}) {
        const bool extended = optics->model() == ModelKind::extended;
        expect_spectrum_model_is_the_model(SkinModel(*optics, *optics->site("cheek"), grid, lateral),
                                           extended ? kExtendedSkins : kCheckPoints);
      }
  }
  detail::use_fit_kernels(before);
}

TEST(ModelDigest, EachModelHasItsOwnAndOnlyItsConstantsChangeIt) {
  const auto& paper = shipped_optics(ModelKind::paper);
  const auto& extended = shipped_optics(ModelKind::extended);
  EXPECT_NE(paper.tables_digest(), extended.tables_digest());
  const auto blank_line = [](std::string bytes) { return bytes + "\n"; };
  const auto paper_again = SkinOptics::load(reader_changing(kExtendedConstantsFile, blank_line), ModelKind::paper);
  const auto extended_again =
      SkinOptics::load(reader_changing(kExtendedConstantsFile, blank_line), ModelKind::extended);
  ASSERT_TRUE(paper_again && extended_again);
  EXPECT_EQ(paper_again->tables_digest(), paper.tables_digest());
  EXPECT_NE(extended_again->tables_digest(), extended.tables_digest());
  const auto paper_sites = SkinOptics::load(reader_changing(kExtendedSitesFile, blank_line), ModelKind::paper);
  const auto extended_sites = SkinOptics::load(reader_changing(kExtendedSitesFile, blank_line), ModelKind::extended);
  ASSERT_TRUE(paper_sites && extended_sites);
  EXPECT_EQ(paper_sites->tables_digest(), paper.tables_digest());
  EXPECT_NE(extended_sites->tables_digest(), extended.tables_digest());
}

TEST(ModelConstantsFile, AMissingConstantIsRefusedNamingIt) {
  const auto without_vessels = [](std::string bytes) {
    const auto start = bytes.find("vessel_radius_um,");
    return bytes.erase(start, bytes.find('\n', start) - start + 1);
  };
  const auto optics = SkinOptics::load(reader_changing(kExtendedConstantsFile, without_vessels), ModelKind::extended);
  ASSERT_FALSE(optics.has_value());
  EXPECT_EQ(optics.error().source, kExtendedConstantsFile);
  EXPECT_THAT(optics.error().what(), HasSubstr("vessel_radius_um"));
}

TEST(ModelNames, MapBothWays) {
  for (const ModelKind kind : kModelKinds) EXPECT_EQ(parse_model_kind(to_string(kind)), kind);
  EXPECT_EQ(parse_model_kind("Paper"), std::nullopt);
  EXPECT_EQ(model_names(), "paper, extended");
  EXPECT_EQ(kDefaultModel, ModelKind::extended);
}

}  // namespace
}  // namespace skinspec
