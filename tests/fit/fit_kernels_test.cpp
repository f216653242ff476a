// The fit's kernels (fit/src/kernels/) on every target the processor runs: Highway's exp and
// expm1 against the standard library's over the arguments the model gives them, the choice of
// target, the QR against a plain one, and the coarse search's scores against the plain formula.
// The model through each target is checked against automatic differentiation in model_test,
// and the fits of real spectra in engine_reference_test.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "kernels/kernels.hpp"  // fit/src
#include "skinspec/fit/model.hpp"
#include "support/kernel_choice.hpp"

namespace skinspec {
namespace {

using detail::FitKernels;

std::vector<const FitKernels*> runnable() {
  const auto all = detail::runnable_fit_kernels();
  return {all.begin(), all.end()};
}

std::string name_of(const FitKernels* kernels) { return detail::kernels_name(*kernels); }

std::vector<std::string> runnable_names() {
  std::vector<std::string> names;
  for (const FitKernels* kernels : runnable()) names.push_back(name_of(kernels));
  return names;
}

// The distance between want and the next double away from zero: one unit in the last place.
double ulp_of(double want) {
  return std::abs(std::nextafter(want, std::copysign(std::numeric_limits<double>::infinity(), want)) - want);
}

// Arguments over [from, to]: evenly spaced, then as many at random, then the ends.
std::vector<double> arguments(double from, double to, int count) {
  std::vector<double> x;
  for (int i = 0; i <= count; ++i) x.push_back(from + (to - from) * i / count);
  std::mt19937_64 random(7);
  std::uniform_real_distribution<double> uniform(from, to);
  for (int i = 0; i < count; ++i) x.push_back(uniform(random));
  return x;
}

using Function = void (*)(const double*, int, double*);

std::vector<double> applied(Function f, const std::vector<double>& x) {
  std::vector<double> out(x.size());
  f(x.data(), static_cast<int>(x.size()), out.data());
  return out;
}

// The largest error of f against `reference` over x, in units in the last place of the reference.
double worst_ulps(Function f, double (*reference)(double), const std::vector<double>& x) {
  const std::vector<double> got = applied(f, x);
  double worst = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double want = reference(x[i]);
    worst = std::max(worst, want == got[i] ? 0.0 : std::abs(got[i] - want) / ulp_of(want));
  }
  return worst;
}

double std_exp(double x) { return std::exp(x); }
double std_expm1(double x) { return std::expm1(x); }

// Highway states 1 ulp for exp over [-DBL_MAX, 706] (normal results) and 4 for expm1.
TEST(KernelsExp, AgreesWithStdExpWithinOneUlpWhereverTheResultIsNormal) {
  for (const FitKernels* kernels : runnable()) {
    // The model takes exp(-x) of x >= 0: optical depths, lateral losses; and of either sign
    // (the scattering's power law).
    EXPECT_LE(worst_ulps(kernels->exp, std_exp, arguments(-707.7, 0, 200'000)), 1.0) << name_of(kernels);
    EXPECT_LE(worst_ulps(kernels->exp, std_exp, arguments(-1, 1, 100'000)), 1.0) << name_of(kernels);
    EXPECT_LE(worst_ulps(kernels->exp, std_exp, arguments(0, 706, 100'000)), 1.0) << name_of(kernels);
  }
}

TEST(KernelsExp, IsOneAtZeroAndAtMostTheSmallestNormalBelowTheNormalRange) {
  constexpr double inf = std::numeric_limits<double>::infinity();
  const std::vector<double> below = {-708.5, -745, -1e4, -1e300, -inf};
  for (const FitKernels* kernels : runnable()) {
    for (const double y : applied(kernels->exp, below)) {
      EXPECT_GE(y, 0.0) << name_of(kernels);
      EXPECT_LE(y, std::numeric_limits<double>::min()) << name_of(kernels);
    }
    EXPECT_EQ(applied(kernels->exp, {0.0, -0.0}), (std::vector{1.0, 1.0})) << name_of(kernels);
  }
}

TEST(KernelsExpm1, AgreesWithStdExpm1WithinFourUlp) {
  for (const FitKernels* kernels : runnable()) {
    // The model takes expm1(-x) of x >= 0 (blood packed in vessels), x from near 0 upwards.
    EXPECT_LE(worst_ulps(kernels->expm1, std_expm1, arguments(-60, 0, 200'000)), 4.0) << name_of(kernels);
    EXPECT_LE(worst_ulps(kernels->expm1, std_expm1, arguments(-1e-3, 1e-3, 100'000)), 4.0) << name_of(kernels);
    EXPECT_LE(worst_ulps(kernels->expm1, std_expm1, arguments(0, 706, 100'000)), 4.0) << name_of(kernels);
    std::vector<double> tiny;
    for (double x = 1e-300; x < 1e-5; x *= 3.7) tiny.insert(tiny.end(), {x, -x});
    EXPECT_LE(worst_ulps(kernels->expm1, std_expm1, tiny), 4.0) << name_of(kernels);
  }
}

TEST(KernelsExpm1, IsMinusOneFarBelowZero) {
  const std::vector<double> x = {-50, -800, -1e300, -std::numeric_limits<double>::infinity()};
  for (const FitKernels* kernels : runnable())
    EXPECT_EQ(applied(kernels->expm1, x), std::vector<double>(x.size(), -1.0)) << name_of(kernels);
}

// Highway finds what the processor has: on x86-64 the AVX-512 and AVX2 targets run exactly where
// the processor reports their instructions, and the portable one (`emu128`, or `scalar` where
// Highway finds the compiler unfit for it) always; the best runs first.
TEST(KernelChoice, TheTargetsRunAreThoseTheProcessorHasBestFirst) {
  const auto names = runnable_names();
  ASSERT_FALSE(names.empty());
#if defined(__x86_64__)
  for (const std::string target : {"avx3", "avx2"})
    EXPECT_EQ(std::ranges::count(names, target), testing::x86_processor_has(target) ? 1 : 0) << target;
  EXPECT_TRUE(names.back() == "emu128" || names.back() == "scalar") << names.back();
  if (testing::x86_processor_has("avx2")) {
    EXPECT_EQ(names.front(), testing::x86_processor_has("avx3") ? "avx3" : "avx2");
  }
#endif
  for (std::size_t i = 1; i < runnable().size(); ++i) EXPECT_LT(runnable()[i - 1]->target, runnable()[i]->target);
}

TEST(KernelChoice, TheBestRunsUnlessAnotherIsAskedFor) {
  const auto names = runnable_names();
  const std::string expected = testing::expected_kernels(names);
  EXPECT_EQ(detail::kernels_name(detail::fit_kernels()), expected);
  ::testing::Test::RecordProperty("kernels", expected);
}

TEST(KernelChoice, CanBeSwitchedForTheTests) {
  const FitKernels& before = detail::fit_kernels();
  for (const FitKernels* kernels : runnable()) {
    detail::use_fit_kernels(*kernels);
    EXPECT_EQ(&detail::fit_kernels(), kernels);
  }
  detail::use_fit_kernels(before);
}

// Householder QR written plainly, one column and one sum at a time, as the kernels' reference.
void plain_triangularize(std::vector<double>& a, int rows, int cols, std::vector<double>& b) {
  const auto at = [&](int i, int j) -> double& { return a[static_cast<std::size_t>(j * rows + i)]; };
  for (int j = 0; j < cols; ++j) {
    double norm2 = 0;
    for (int i = j; i < rows; ++i) norm2 += at(i, j) * at(i, j);
    if (norm2 == 0) continue;
    const double diagonal = at(j, j) > 0 ? -std::sqrt(norm2) : std::sqrt(norm2);
    std::vector<double> v(static_cast<std::size_t>(rows), 0.0);
    for (int i = j; i < rows; ++i) v[static_cast<std::size_t>(i)] = at(i, j);
    v[static_cast<std::size_t>(j)] -= diagonal;
    double v_norm2 = 0;
    for (const double x : v) v_norm2 += x * x;
    const auto reflect = [&](auto&& entry) {
      double product = 0;
      for (int i = j; i < rows; ++i) product += v[static_cast<std::size_t>(i)] * entry(i);
      for (int i = j; i < rows; ++i) entry(i) -= 2 * product / v_norm2 * v[static_cast<std::size_t>(i)];
    };
    for (int l = j + 1; l < cols; ++l) reflect([&](int i) -> double& { return at(i, l); });
    reflect([&](int i) -> double& { return b[static_cast<std::size_t>(i)]; });
    at(j, j) = diagonal;
  }
}

TEST(KernelsQr, TriangulariseAsPlainHouseholderDoes) {
  std::mt19937_64 random(3);
  std::normal_distribution<double> normal;
  // The fit's shapes: a spectrum's samples by the free parameters, and the damped steps' R over
  // a diagonal; lengths that leave every remainder of the vector width.
  for (const auto& [rows, cols] : {std::pair{133, 7}, {101, 5}, {14, 7}, {10, 5}, {7, 7}, {3, 1}, {40, 16}}) {
    std::vector<double> a(static_cast<std::size_t>(rows * cols)), b(static_cast<std::size_t>(rows));
    for (double& x : a) x = normal(random);
    for (double& x : b) x = normal(random);
    std::vector<double> plain_a = a, plain_b = b;
    plain_triangularize(plain_a, rows, cols, plain_b);
    for (const FitKernels* kernels : runnable()) {
      std::vector<double> kernel_a = a, kernel_b = b;
      kernels->triangularize(kernel_a.data(), rows, cols, kernel_b.data());
      for (int j = 0; j < cols; ++j) {
        for (int i = 0; i <= j; ++i) {
          const double want = plain_a[static_cast<std::size_t>(j * rows + i)];
          EXPECT_NEAR(kernel_a[static_cast<std::size_t>(j * rows + i)], want, 1e-12 * (1 + std::abs(want)))
              << name_of(kernels) << " " << rows << "x" << cols << " R(" << i << "," << j << ")";
        }
        EXPECT_NEAR(kernel_b[static_cast<std::size_t>(j)], plain_b[static_cast<std::size_t>(j)], 1e-12)
            << name_of(kernels) << " " << rows << "x" << cols << " (Q^T b)(" << j << ")";
      }
    }
  }
}

TEST(KernelsQr, ScaleColumnsAndTakeTheirNormsAndProductsAsPlainLoopsDo) {
  std::mt19937_64 random(5);
  std::normal_distribution<double> normal;
  for (const int rows : {135, 101, 6, 3}) {
    const int all = 7, out_rows = rows + 2;
    std::vector<double> jacobian(static_cast<std::size_t>(rows * all)), residuals(static_cast<std::size_t>(rows));
    for (double& x : jacobian) x = normal(random);
    for (double& x : residuals) x = normal(random);
    const std::vector<int> columns = {0, 2, 3, 6};
    const std::vector<double> scales = {0.5, 2.0, 1e-3, 7.0};
    for (const FitKernels* kernels : runnable()) {
      const int count = static_cast<int>(columns.size());
      std::vector<double> out(static_cast<std::size_t>(out_rows * count), -1.0), norms(columns.size()),
          products(columns.size());
      kernels->scaled_columns({jacobian.data(), rows, columns.data(), count, scales.data(), residuals.data(),
                               out.data(), out_rows, norms.data(), products.data()});
      for (std::size_t j = 0; j < columns.size(); ++j) {
        double norm = 0, product = 0;
        for (int i = 0; i < out_rows; ++i) {
          const double want = i < rows ? scales[j] * jacobian[static_cast<std::size_t>(columns[j] * rows + i)] : 0.0;
          EXPECT_EQ(out[j * static_cast<std::size_t>(out_rows) + static_cast<std::size_t>(i)], want)
              << name_of(kernels) << " row " << i << " column " << j;
          norm += want * want;
          if (i < rows)
            product +=
                jacobian[static_cast<std::size_t>(columns[j] * rows + i)] * residuals[static_cast<std::size_t>(i)];
        }
        EXPECT_NEAR(norms[j], norm, 1e-13 * norm) << name_of(kernels) << " column " << j;
        EXPECT_NEAR(products[j], product, 1e-12 * (1 + std::abs(product))) << name_of(kernels) << " column " << j;
      }
    }
  }
}

TEST(KernelsQr, TakeTheNormalMatrixAsPlainLoopsDo) {
  std::mt19937_64 random(7);
  std::normal_distribution<double> normal;
  for (const int rows : {135, 101, 6, 3}) {
    const int all = 7;
    std::vector<double> jacobian(static_cast<std::size_t>(rows * all));
    for (double& x : jacobian) x = normal(random);
    for (const std::vector<int>& columns : {std::vector<int>{0, 1, 2, 3, 4, 5, 6}, {6, 2, 3}, {4}}) {
      const auto count = static_cast<int>(columns.size());
      for (const FitKernels* kernels : runnable()) {
        std::vector<double> out(static_cast<std::size_t>(count * count), -1.0);
        kernels->normal_matrix({jacobian.data(), rows, columns.data(), count, out.data()});
        for (int a = 0; a < count; ++a)
          for (int b = 0; b < count; ++b) {
            double product = 0;
            for (int i = 0; i < rows; ++i)
              product += jacobian[static_cast<std::size_t>(columns[static_cast<std::size_t>(a)] * rows + i)] *
                         jacobian[static_cast<std::size_t>(columns[static_cast<std::size_t>(b)] * rows + i)];
            EXPECT_NEAR(out[static_cast<std::size_t>(b * count + a)], product, 1e-13 * rows)
                << name_of(kernels) << " " << rows << " rows, (" << a << "," << b << ") of " << count;
          }
      }
    }
  }
}

// The coarse search's scores: each the plain formula's (model.hpp) summed in sample order, on
// every target, with and without a stratum corneum, over whole vectors and a short tail.
TEST(KernelsSearch, ScoreTheGridAsThePlainFormulaDoes) {
  std::mt19937_64 random(11);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (const int n : {21, 3}) {
    for (const bool corneum : {false, true}) {
      const int epidermis_levels = 3, dermis_levels = 4;
      const auto column = [&](int levels, double low, double high) {
        std::vector<double> c(static_cast<std::size_t>(levels * n));
        for (double& x : c) x = low + (high - low) * unit(random);
        return c;
      };
      const auto er = column(epidermis_levels, 0.0, 0.6), et = column(epidermis_levels, 0.2, 0.95);
      const auto total = column(dermis_levels, 0.1, 0.9), kept = column(dermis_levels, 0.6, 1.0);
      const auto cr = column(1, 0.02, 0.08), ct2 = column(1, 0.8, 0.95);
      const auto measured = column(1, 0.1, 0.6), weights = column(1, 0.5, 2.0);
      std::vector<double> et2(et.size());
      std::ranges::transform(et, et2.begin(), [](double t) { return t * t; });
      const double rs = 0.03;
      for (const FitKernels* kernels : runnable()) {
        std::vector<double> squared(static_cast<std::size_t>(n)),
            errors(static_cast<std::size_t>(epidermis_levels * dermis_levels));
        kernels->coarse_errors({n, epidermis_levels, dermis_levels, er.data(), et2.data(), total.data(), kept.data(),
                                corneum ? cr.data() : nullptr, corneum ? ct2.data() : nullptr, rs, measured.data(),
                                weights.data(), squared.data(), errors.data()});
        for (int e = 0; e < epidermis_levels; ++e)
          for (int d = 0; d < dermis_levels; ++d) {
            double want = 0;
            for (int k = 0; k < n; ++k) {
              const auto at = [&](const std::vector<double>& c, int level) {
                return c[static_cast<std::size_t>(level * n + k)];
              };
              OpticsAt optics;
              if (corneum) optics.corneum_r = at(cr, 0), optics.corneum_t2 = at(ct2, 0);
              const double r = combined_reflectance(optics, rs, ReflectanceTransmittance<double>{at(er, e), at(et, e)},
                                                    DermisRemittance<double>{at(total, d), at(kept, d)}) -
                               at(measured, 0);
              want += at(weights, 0) * r * r;
            }
            EXPECT_NEAR(errors[static_cast<std::size_t>(e * dermis_levels + d)], want, 1e-14 * want)
                << name_of(kernels) << " n " << n << " corneum " << corneum << " pair " << e << "," << d;
          }
      }
    }
  }
}

}  // namespace
}  // namespace skinspec
