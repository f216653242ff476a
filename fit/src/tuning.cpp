#include "skinspec/fit/tuning.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <limits>
#include <numeric>

#include "skinspec/spectral/parallel.hpp"

namespace skinspec {

namespace {

double quantile(std::vector<double> values, double q) {
  std::ranges::sort(values);
  const double position = q * static_cast<double>(values.size() - 1);
  const auto below = static_cast<std::size_t>(std::floor(position));
  const auto above = std::min(below + 1, values.size() - 1);
  return values[below] + (position - static_cast<double>(below)) * (values[above] - values[below]);
}

constexpr std::size_t kTunedCount = 5;
using Vector = std::array<double, kTunedCount>;

// The tuned constants as a point of the search: logarithms, so every value stays positive
// and a step means the same relative change whatever the scale.
Vector to_point(const ModelConstants& c) {
  Vector x{};
  const auto fields = model_constant_fields();
  for (std::size_t i = 0; i < kTunedCount; ++i) x[i] = std::log(std::max(c.*fields[i].second, 1e-3));
  return x;
}

// The range each constant may take: wide enough for the tuning to matter, narrow enough that
// the layers stay recognisable skin (without it the search can trade a scattering epidermis
// for a thick clear one that fits a little better and means nothing).
constexpr std::array<std::pair<double, double>, kTunedCount> kPlausible = {{
    {0.33, 3.0},  // epidermis_scattering_scale
    {0.33, 3.0},  // dermis_scattering_scale
    {0.5, 2.0},   // epidermis_thickness_scale
    {0.5, 5.0},   // dermis_thickness_scale: also stands in for a hypodermis that is not quite white
    {0.5, 20.0},  // lateral_radius_mm
}};

bool plausible(const Vector& x) {
  for (std::size_t i = 0; i < kTunedCount; ++i)
    if (x[i] < std::log(kPlausible[i].first) || x[i] > std::log(kPlausible[i].second)) return false;
  return true;
}

ModelConstants from_point(const Vector& x) {
  ModelConstants c;
  const auto fields = model_constant_fields();
  for (std::size_t i = 0; i < kTunedCount; ++i) c.*fields[i].second = std::exp(x[i]);
  return c;
}

// Nelder & Mead (1965) with the usual coefficients, minimising f from x0 with initial step.
template <typename F>
std::pair<Vector, double> nelder_mead(F&& f, const Vector& x0, double step, int max_evaluations, int& evaluations) {
  constexpr std::size_t n = kTunedCount;
  std::array<std::pair<Vector, double>, n + 1> simplex;
  simplex[0] = {x0, f(x0)};
  for (std::size_t i = 0; i < n; ++i) {
    Vector x = x0;
    x[i] += step;
    simplex[i + 1] = {x, f(x)};
  }
  evaluations = static_cast<int>(n + 1);
  const auto along = [](const Vector& from, const Vector& to, double t) {
    Vector out{};
    for (std::size_t i = 0; i < n; ++i) out[i] = from[i] + t * (to[i] - from[i]);
    return out;
  };
  while (evaluations < max_evaluations) {
    std::ranges::sort(simplex, {}, &std::pair<Vector, double>::second);
    if (simplex[n].second - simplex[0].second < 1e-7) break;
    Vector centroid{};
    for (std::size_t k = 0; k < n; ++k)
      for (std::size_t i = 0; i < n; ++i) centroid[i] += simplex[k].first[i] / n;
    auto& worst = simplex[n];
    const Vector reflected = along(worst.first, centroid, 2.0);
    const double fr = f(reflected);
    ++evaluations;
    if (fr < simplex[0].second) {
      const Vector expanded = along(worst.first, centroid, 3.0);
      const double fe = f(expanded);
      ++evaluations;
      worst = fe < fr ? std::pair{expanded, fe} : std::pair{reflected, fr};
    } else if (fr < simplex[n - 1].second) {
      worst = {reflected, fr};
    } else {
      const Vector contracted = along(worst.first, centroid, fr < worst.second ? 1.5 : 0.5);
      const double fc = f(contracted);
      ++evaluations;
      if (fc < std::min(fr, worst.second)) {
        worst = {contracted, fc};
      } else {
        for (std::size_t k = 1; k <= n; ++k) {
          simplex[k].first = along(simplex[0].first, simplex[k].first, 0.5);
          simplex[k].second = f(simplex[k].first);
          ++evaluations;
        }
      }
    }
  }
  std::ranges::sort(simplex, {}, &std::pair<Vector, double>::second);
  return simplex[0];
}

}  // namespace

void FitScores::append(const FitScores& other) {
  rmse.insert(rmse.end(), other.rmse.begin(), other.rmse.end());
  delta_e00.insert(delta_e00.end(), other.delta_e00.begin(), other.delta_e00.end());
  converged += other.converged;
}

FitQuality summarize(const FitScores& scores) {
  FitQuality q;
  q.count = scores.rmse.size();
  q.converged = scores.converged;
  if (q.count == 0) return q;
  q.median_rmse = quantile(scores.rmse, 0.5);
  q.p95_rmse = quantile(scores.rmse, 0.95);
  q.max_rmse = *std::ranges::max_element(scores.rmse);
  q.median_delta_e00 = quantile(scores.delta_e00, 0.5);
  q.p95_delta_e00 = quantile(scores.delta_e00, 0.95);
  return q;
}

std::expected<FitScores, std::string> score_fits(const Fitter& fitter, const std::vector<Spectrum>& spectra,
                                                 const FitOptions& options, unsigned threads) {
  std::vector<std::expected<FitResult, std::string>> fits(spectra.size());
  parallel_for(spectra.size(), threads, [&](std::size_t i) { fits[i] = fitter.fit(spectra[i], options); });
  FitScores scores;
  for (const auto& fit : fits) {
    if (!fit) return std::unexpected(fit.error());
    scores.converged += fit->converged ? 1 : 0;
    scores.rmse.push_back(fit->rmse);
    scores.delta_e00.push_back(fit->delta_e00_d65);
  }
  return scores;
}

std::expected<TuningResult, std::string> tune_constants(const Fitter& start, const std::vector<Spectrum>& training,
                                                        const TuningOptions& options) {
  if (auto site = start.optics().site(options.site); !site) return std::unexpected(site.error());
  const FitOptions fit_options{.site = options.site, .lateral_diffusion = true, .weights = {}};
  const auto mean_rmse = [&](const Vector& x) {
    if (!plausible(x)) return std::numeric_limits<double>::infinity();
    const Fitter candidate(start.optics().with_constants(from_point(x)), start.colorimetry());
    std::vector<double> rmse(training.size(), std::numeric_limits<double>::infinity());
    parallel_for(training.size(), options.threads, [&](std::size_t i) {
      if (auto fit = candidate.fit(training[i], fit_options)) rmse[i] = fit->rmse;
    });
    return std::accumulate(rmse.begin(), rmse.end(), 0.0) / static_cast<double>(rmse.size());
  };
  ModelConstants initial = start.optics().constants();
  if (initial.lateral_radius_mm <= 0) initial.lateral_radius_mm = 3;  // the search needs a finite start
  TuningResult result;
  const auto [best, value] =
      nelder_mead(mean_rmse, to_point(initial), 0.3, options.max_evaluations, result.evaluations);
  result.constants = from_point(best);
  result.mean_rmse = value;
  return result;
}

}  // namespace skinspec
