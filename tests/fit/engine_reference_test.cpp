// The fit engine gives the answers it gave when tests/data/engine-reference/ was written
// (its README says by which commit, and how to write it again): every parameter, standard
// error, correlation, verdict and figure of the fits of the 50 NIST forearms, for each model.
// A change meant only to make the engine faster must pass this unchanged. It runs on the kernels
// of every target the processor runs (fit/src/kernels/), one after the other.

#include <gtest/gtest.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fmt/format.h>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>

#include "kernels/kernels.hpp"  // fit/src
#include "support/engine_reference.hpp"

namespace skinspec {
namespace {

// Numbers agree within this share of the larger of the two...
constexpr double kRelativeTolerance = 1e-6;
// ...or within this much, for values at or near zero (parameters range from 0.02 to 500).
constexpr double kAbsoluteFloor = 1e-9;
// Correlations lie in [-1, 1]: they agree within this much.
constexpr double kCorrelationTolerance = 1e-6;

std::string reference_file(ModelKind model) {
  const std::string path = std::string(ENGINE_REFERENCE_DIR) + "/" + std::string(to_string(model)) + ".csv";
  std::ifstream in(path);
  EXPECT_TRUE(in) << "cannot read " << path;
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

std::optional<double> finite_number(const std::string& text) {
  double v = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (error != std::errc() || end != text.data() + text.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

bool agree(const std::string& quantity, const std::string& expected, const std::string& actual) {
  const auto e = finite_number(expected), a = finite_number(actual);
  // Words, counts written as words, infinities and NaN must match exactly.
  if (!e || !a || quantity == "converged" || quantity == "fitted_samples" ||
      quantity.find("determination") != std::string::npos)
    return expected == actual;
  if (quantity.starts_with("correlation.")) return std::abs(*e - *a) <= kCorrelationTolerance;
  return std::abs(*e - *a) <= kRelativeTolerance * std::max(std::abs(*e), std::abs(*a)) + kAbsoluteFloor;
}

void expect_same_answers(ModelKind model, const std::string& kernels) {
  const std::string file = std::string(to_string(model)) + ".csv";
  SCOPED_TRACE(kernels + " kernels");
  const auto expected = testing::parse_engine_answers(reference_file(model));
  const auto actual = testing::engine_answers(model);
  ASSERT_EQ(expected.size(), actual.size()) << file;
  int differences = 0;
  double largest_parameter_change = 0;  // relative, for the record
  for (std::size_t i = 0; i < expected.size(); ++i) {
    const auto& e = expected[i];
    const auto& a = actual[i];
    ASSERT_EQ(e.spectrum + " " + e.quantity, a.spectrum + " " + a.quantity) << file << " line order";
    // How many steps the solver took is how it got there, not what it found.
    if (e.quantity == "iterations") continue;
    if (e.quantity.starts_with("param.")) {
      const auto before = finite_number(e.value), after = finite_number(a.value);
      if (before && after && *before != *after)
        largest_parameter_change = std::max(largest_parameter_change,
                                            std::abs(*after - *before) / std::max(std::abs(*before), std::abs(*after)));
    }
    if (!agree(e.quantity, e.value, a.value)) {
      ++differences;
      ADD_FAILURE() << e.model << " " << e.spectrum << " " << e.quantity << ": expected " << e.value << ", got "
                    << a.value;
    }
  }
  EXPECT_EQ(differences, 0);
  ::testing::Test::RecordProperty("largest_relative_parameter_change." + kernels,
                                  fmt::format("{:.3g}", largest_parameter_change));
  std::printf("%s, %s kernels: largest relative parameter change %.3g\n", file.c_str(), kernels.c_str(),
              largest_parameter_change);
}

void expect_same_answers_on_every_target(ModelKind model) {
  const detail::FitKernels& before = detail::fit_kernels();
  for (const detail::FitKernels* kernels : detail::runnable_fit_kernels()) {
    detail::use_fit_kernels(*kernels);
    expect_same_answers(model, detail::kernels_name(*kernels));
  }
  detail::use_fit_kernels(before);
}

TEST(FitEngineReference, ExtendedModelGivesTheRecordedAnswers) {
  expect_same_answers_on_every_target(ModelKind::extended);
}

TEST(FitEngineReference, PaperModelGivesTheRecordedAnswers) { expect_same_answers_on_every_target(ModelKind::paper); }

}  // namespace
}  // namespace skinspec
