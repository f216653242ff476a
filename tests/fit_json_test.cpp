// A fit's judgement as the store keeps it (fit/io/fit_json.hpp, assessment_text): written as
// text without building JSON values first, yet the very bytes the JSON library would write for
// those values, and read back exactly.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "fit_json.hpp"
#include "skinspec/fit/model.hpp"
#include "support/data.hpp"

namespace skinspec {
namespace {

using nlohmann::json;

// The fits of a few skins, light to dark, on the PR-650's grid with measurement-like noise.
std::vector<FitResult> fits(ModelKind kind) {
  const auto grid = Spectrum::uniform_grid(380, 780, 4);
  const SkinOptics& optics = testing::shipped_optics(ModelKind::extended);
  const SkinModel model(optics, *optics.site("forearm"), grid, true);
  std::mt19937 random(7);
  std::normal_distribution<double> noise(0, 0.002);
  FitOptions options;
  options.model = kind;
  std::vector<FitResult> out;
  for (const double melanin : {2.0, 8.0, 25.0}) {
    Params p = default_params(ModelKind::extended);
    p[kMelanin] = melanin;
    auto r = model.reflectance(p);
    for (double& v : r) v += noise(random);
    auto fit = testing::shipped_fitter().fit(*Spectrum::create(grid, r), options);
    if (!fit) throw std::runtime_error(fit.error());
    out.push_back(std::move(*fit));
  }
  return out;
}

// A fit with its judgement read back from the stored text.
FitResult read_back(const FitResult& fit, const std::string& text) {
  FitResult back;
  back.model = fit.model;
  back.params = fit.params;
  EXPECT_TRUE(assessment_from_json(json::parse(text), back)) << text;
  return back;
}

void expect_same_judgement(const FitResult& fit, const FitResult& back) {
  ASSERT_EQ(back.determination.size(), fit.determination.size());
  for (std::size_t i = 0; i < fit.determination.size(); ++i) {
    EXPECT_EQ(back.determination[i].status, fit.determination[i].status) << i;
    EXPECT_EQ(back.determination[i].correlated_with, fit.determination[i].correlated_with) << i;
  }
  ASSERT_EQ(back.correlation.size(), fit.correlation.size());
  for (std::size_t i = 0; i < fit.correlation.size(); ++i) {
    if (std::isfinite(fit.correlation[i])) {
      EXPECT_EQ(back.correlation[i], fit.correlation[i]) << i;
    } else {
      EXPECT_TRUE(std::isnan(back.correlation[i])) << i;
    }
  }
  for (const auto& [ours, theirs] : {std::pair{&fit.oxygen_saturation, &back.oxygen_saturation},
                                     std::pair{&fit.blood_volume_fraction, &back.blood_volume_fraction}}) {
    EXPECT_EQ(theirs->status, ours->status);
    EXPECT_EQ(theirs->value, ours->value);
    if (ours->determined()) {
      EXPECT_EQ(theirs->standard_error, ours->standard_error);
    }
  }
  EXPECT_EQ(back.coverage_note, fit.coverage_note);
}

TEST(AssessmentText, IsWhatTheJsonLibraryWritesAndReadsBackExactly) {
  for (const ModelKind kind : {ModelKind::extended, ModelKind::paper}) {
    for (const auto& fit : fits(kind)) {
      const auto text = assessment_text(fit);
      EXPECT_EQ(json::parse(text).dump(), text);
      for (const char* key : {"correlation", "derived", "determination"}) EXPECT_TRUE(json::parse(text).contains(key));
      expect_same_judgement(fit, read_back(fit, text));
      EXPECT_EQ(assessment_to_json(fit), json::parse(text));
    }
  }
}

TEST(AssessmentText, NotesOfAnyTextAndValuesThatAreNotNumbers) {
  auto fit = fits(ModelKind::paper).front();
  fit.coverage_note = "380-400 nm \"missing\"\\\n\ttab \x01 caf\xC3\xA9";
  fit.correlation[1] = std::numeric_limits<double>::quiet_NaN();
  fit.oxygen_saturation.value = std::numeric_limits<double>::infinity();
  fit.blood_volume_fraction.value = -0.0;
  const auto text = assessment_text(fit);
  ASSERT_TRUE(json::accept(text)) << text;
  EXPECT_EQ(json::parse(text).dump(), text);
  EXPECT_TRUE(json::parse(text)["correlation"]["matrix"][0][1].is_null());
  EXPECT_TRUE(json::parse(text)["derived"]["oxygen_saturation"]["value"].is_null());
  const auto back = read_back(fit, text);
  EXPECT_EQ(back.coverage_note, fit.coverage_note);
  EXPECT_TRUE(std::signbit(back.blood_volume_fraction.value));
  EXPECT_TRUE(std::isnan(back.correlation[1]));

  fit.coverage_note = "a bad \xFF byte";
  EXPECT_EQ(read_back(fit, assessment_text(fit)).coverage_note, "a bad \xEF\xBF\xBD byte");
}

TEST(AssessmentText, AFitNotJudgedIsAnEmptyObject) {
  FitResult fit;
  fit.model = ModelKind::paper;
  fit.params = {0.05, 7, 3, 0.7, 1};
  EXPECT_EQ(assessment_text(fit), "{}");
}

}  // namespace
}  // namespace skinspec
