// A fit's judgement as the store keeps it (fit/io/fit_json.hpp, assessment_text): written as
// text without building JSON values first, yet the same JSON as the values it was built from
// before (kept here as the reference), and read back exactly.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
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

// The judgement as it was built before it was written as text: the reference for its shape.
json finite_or_null(double v) { return std::isfinite(v) ? json(v) : json(); }

std::string name_of(ModelKind model, std::size_t i) { return std::string(model_spec(model).params[i].name); }

json reference_assessment(const FitResult& fit) {
  json out = json::object();
  const std::size_t n = fit.params.size();
  if (fit.determination.size() == n && n > 0) {
    json determination = json::object();
    for (std::size_t i = 0; i < n; ++i) {
      const auto& d = fit.determination[i];
      json one = {{"determined", d.determined()}};
      if (!d.determined()) one["reason"] = to_string(d.status);
      if (d.correlated_with >= 0)
        one["correlated_with"] = name_of(fit.model, static_cast<std::size_t>(d.correlated_with));
      determination[name_of(fit.model, i)] = one;
    }
    out["determination"] = determination;
    const auto derived = [](const DerivedQuantity& q) {
      json one = {{"value", finite_or_null(q.value)},
                  {"stderr", q.determined() ? finite_or_null(q.standard_error) : json()},
                  {"determined", q.determined()}};
      if (!q.determined()) one["reason"] = to_string(q.status);
      return one;
    };
    out["derived"] = {{"oxygen_saturation", derived(fit.oxygen_saturation)},
                      {"blood_volume_fraction", derived(fit.blood_volume_fraction)}};
  }
  if (fit.correlation.size() == n * n && n > 0) {
    json names = json::array(), matrix = json::array();
    for (std::size_t i = 0; i < n; ++i) {
      names.push_back(name_of(fit.model, i));
      json row = json::array();
      for (std::size_t j = 0; j < n; ++j) row.push_back(finite_or_null(fit.correlation_between(i, j)));
      matrix.push_back(row);
    }
    out["correlation"] = {{"params", names}, {"matrix", matrix}};
  }
  if (!fit.coverage_note.empty()) out["note"] = fit.coverage_note;
  if (fit.skin_tone) {
    const auto index = [](const std::optional<double>& v) { return v ? json(*v) : json(); };
    out["skin_tone"] = {{"ita_deg", fit.skin_tone->ita_deg},
                        {"ita_class", to_string(fit.skin_tone->ita_class)},
                        {"melanin_index", index(fit.skin_tone->melanin_index)},
                        {"erythema_index", index(fit.skin_tone->erythema_index)}};
  }
  if (fit.termination) out["termination"] = to_string(*fit.termination);
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
  ASSERT_EQ(back.skin_tone.has_value(), fit.skin_tone.has_value());
  if (fit.skin_tone) {
    EXPECT_EQ(back.skin_tone->ita_deg, fit.skin_tone->ita_deg);
    EXPECT_EQ(back.skin_tone->ita_class, fit.skin_tone->ita_class);
    EXPECT_EQ(back.skin_tone->melanin_index, fit.skin_tone->melanin_index);
    EXPECT_EQ(back.skin_tone->erythema_index, fit.skin_tone->erythema_index);
  }
  ASSERT_EQ(back.determination.size(), fit.determination.size());
  for (std::size_t i = 0; i < fit.determination.size(); ++i) {
    EXPECT_EQ(back.determination[i].status, fit.determination[i].status) << i;
    // The reader keeps the other parameter's name only where it says why one is not determined.
    if (!fit.determination[i].determined()) {
      EXPECT_EQ(back.determination[i].correlated_with, fit.determination[i].correlated_with) << i;
    }
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
    if (std::isfinite(ours->value)) {
      EXPECT_EQ(theirs->value, ours->value);
    } else {
      EXPECT_TRUE(std::isnan(theirs->value));  // stored as null
    }
    if (ours->determined()) {
      EXPECT_EQ(theirs->standard_error, ours->standard_error);
    }
  }
  EXPECT_EQ(back.coverage_note, fit.coverage_note);
  EXPECT_EQ(back.termination, fit.termination);
}

// The order of an object's keys as written in `text`, object by object in the order they open.
std::vector<std::vector<std::string>> keys_as_written(const std::string& text) {
  std::vector<std::vector<std::string>> out;
  std::vector<std::size_t> open;  // the objects being read, innermost last
  json::parser_callback_t note = [&](int, json::parse_event_t event, json& parsed) {
    if (event == json::parse_event_t::object_start) {
      open.push_back(out.size());
      out.emplace_back();
    }
    if (event == json::parse_event_t::key) out[open.back()].push_back(parsed.get<std::string>());
    if (event == json::parse_event_t::object_end) open.pop_back();
    return true;
  };
  const json parsed = json::parse(text, note);
  EXPECT_FALSE(parsed.is_discarded());
  return out;
}

void expect_as_before(const FitResult& fit) {
  const auto text = assessment_text(fit);
  ASSERT_TRUE(json::accept(text)) << text;
  EXPECT_EQ(json::parse(text), reference_assessment(fit)) << text;
  for (const auto& keys : keys_as_written(text)) EXPECT_TRUE(std::ranges::is_sorted(keys)) << text;
  expect_same_judgement(fit, read_back(fit, text));
}

TEST(AssessmentText, IsTheJudgementAsBeforeAndReadsBackExactly) {
  for (const ModelKind kind : {ModelKind::extended, ModelKind::paper}) {
    for (const auto& fit : fits(kind)) {
      for (const char* key : {"correlation", "derived", "determination"})
        EXPECT_TRUE(json::parse(assessment_text(fit)).contains(key));
      expect_as_before(fit);
    }
  }
}

TEST(AssessmentText, EveryKindOfDeterminationAndNumber) {
  auto fit = fits(ModelKind::extended).front();
  fit.determination[0] = {Determination::determined, 3};  // determined, yet named beside another
  fit.determination[1] = {Determination::correlated, 5};
  fit.determination[2].status = Determination::imprecise;
  fit.oxygen_saturation.status = Determination::imprecise;  // its stderr then null
  fit.blood_volume_fraction = {0.0007, 1e-4, Determination::determined};
  const double numbers[] = {1e-4, 7e-4, 1e5, 1.2e7, 1234567890123456.7, 0.042296347138180757, 5e-324, 1e300, -0.5};
  for (std::size_t i = 0; i < std::size(numbers); ++i) fit.correlation[i] = numbers[i];
  expect_as_before(fit);
}

TEST(AssessmentText, NotesOfAnyTextAndValuesThatAreNotNumbers) {
  auto fit = fits(ModelKind::paper).front();
  fit.coverage_note = "380-400 nm \"missing\"\\\n\ttab \x01 caf\xC3\xA9";
  fit.correlation[1] = std::numeric_limits<double>::quiet_NaN();
  fit.oxygen_saturation.value = std::numeric_limits<double>::infinity();
  fit.blood_volume_fraction.value = -0.0;
  expect_as_before(fit);
  const auto text = assessment_text(fit);
  EXPECT_TRUE(json::parse(text)["correlation"]["matrix"][0][1].is_null());
  EXPECT_TRUE(json::parse(text)["derived"]["oxygen_saturation"]["value"].is_null());
  const auto back = read_back(fit, text);
  EXPECT_EQ(back.coverage_note, fit.coverage_note);
  EXPECT_TRUE(std::signbit(back.blood_volume_fraction.value));
  EXPECT_TRUE(std::isnan(back.correlation[1]));

  fit.coverage_note = "a bad \xFF byte";
  EXPECT_EQ(read_back(fit, assessment_text(fit)).coverage_note, "a bad \xEF\xBF\xBD byte");
}

TEST(OptionsText, IsWhatTheJsonLibraryWritesForThem) {
  // A bad byte, which only a site the fitter does not know could hold, is replaced, as in the
  // service's other JSON (the library's default would throw).
  for (const bool lateral : {true, false}) {
    for (const char* site : {"forearm", "", "cheek \"left\"\\", "caf\xC3\xA9", "a bad \xFF byte"}) {
      FitOptions options;
      options.site = site;
      options.lateral_diffusion = lateral;
      const json reference{{"site", options.site}, {"lateral_diffusion", lateral}};
      EXPECT_EQ(options_text(options), reference.dump(-1, ' ', false, json::error_handler_t::replace)) << site;
    }
  }
}

// Every way the solver can end reads back as itself; a fit stored before terminations were
// recorded has none, and a name this version does not know refuses the assessment.
TEST(AssessmentText, TheTerminationReadsBackAndAnOlderFitHasNone) {
  auto fit = fits(ModelKind::extended).front();
  for (const auto& [termination, name] : termination_names()) {
    fit.termination = termination;
    expect_as_before(fit);
    EXPECT_EQ(json::parse(assessment_text(fit))["termination"], name);
  }
  fit.termination.reset();
  EXPECT_FALSE(json::parse(assessment_text(fit)).contains("termination"));
  EXPECT_EQ(read_back(fit, assessment_text(fit)).termination, std::nullopt);
  FitResult back;
  back.model = fit.model;
  back.params = fit.params;
  EXPECT_FALSE(assessment_from_json(json{{"termination", "converged"}}, back));
  EXPECT_FALSE(assessment_from_json(json{{"termination", 3}}, back));
}

TEST(AssessmentText, TheSkinToneReadsBackAndAnOlderFitHasNone) {
  auto fit = fits(ModelKind::extended).front();
  ASSERT_TRUE(fit.skin_tone);
  fit.skin_tone->erythema_index.reset();  // a reflectance at or below zero at 568 nm
  expect_as_before(fit);
  EXPECT_TRUE(json::parse(assessment_text(fit))["skin_tone"]["erythema_index"].is_null());
  fit.skin_tone.reset();
  EXPECT_FALSE(json::parse(assessment_text(fit)).contains("skin_tone"));
  EXPECT_EQ(read_back(fit, assessment_text(fit)).skin_tone.has_value(), false);
  FitResult back;
  back.model = fit.model;
  back.params = fit.params;
  const json good = {{"ita_deg", 30.5}, {"ita_class", "intermediate"}, {"melanin_index", 30}, {"erythema_index", nullptr}};
  EXPECT_TRUE(assessment_from_json(json{{"skin_tone", good}}, back));
  for (const char* key : {"ita_deg", "ita_class", "melanin_index", "erythema_index"}) {
    json missing = good;
    missing.erase(key);
    EXPECT_FALSE(assessment_from_json(json{{"skin_tone", missing}}, back)) << key;
  }
  json unknown_class = good;
  unknown_class["ita_class"] = "olive";
  EXPECT_FALSE(assessment_from_json(json{{"skin_tone", unknown_class}}, back));
  json text_index = good;
  text_index["melanin_index"] = "30";
  EXPECT_FALSE(assessment_from_json(json{{"skin_tone", text_index}}, back));
}

TEST(AssessmentText, AFitNotJudgedIsAnEmptyObject) {
  FitResult fit;
  fit.model = ModelKind::paper;
  fit.params = {0.05, 7, 3, 0.7, 1};
  EXPECT_EQ(assessment_text(fit), "{}");
}

}  // namespace
}  // namespace skinspec
