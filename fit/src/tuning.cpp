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

using Vector = std::vector<double>;

// The tuned constants as a point of the search: logarithms of scales and lengths, so every
// value stays positive and a step means the same relative change whatever the scale. Held
// constants are not part of it.
double to_coordinate(const ConstantSpec& spec, double value) {
  return spec.scale == ConstantScale::logarithmic ? std::log(std::max(value, 1e-3)) : value;
}
double from_coordinate(const ConstantSpec& spec, double x) {
  return spec.scale == ConstantScale::logarithmic ? std::exp(x) : x;
}

class SearchSpace {
 public:
  SearchSpace(ModelKind model, ModelConstants start, const std::vector<std::pair<std::string, double>>& held)
      : model_(model), start_(std::move(start)) {
    for (const auto& [name, value] : held) *constant_field(start_, name) = value;
    const auto specs = model_spec(model).constants;
    for (std::size_t i = 0; i < specs.size(); ++i)
      if (std::ranges::none_of(held, [&](const auto& h) { return h.first == specs[i].name; })) searched_.push_back(i);
  }

  Vector start_point() const {
    const auto specs = model_spec(model_).constants;
    const auto values = constant_values(model_, start_);
    Vector x;
    for (const std::size_t i : searched_) x.push_back(to_coordinate(specs[i], values[i]));
    return x;
  }

  ModelConstants constants(const Vector& x) const {
    const auto specs = model_spec(model_).constants;
    auto values = constant_values(model_, start_);
    for (std::size_t k = 0; k < searched_.size(); ++k)
      values[searched_[k]] = from_coordinate(specs[searched_[k]], x[k]);
    return constants_from_values(model_, values);
  }

  // Each constant's range (ConstantSpec): wide enough for the tuning to matter, narrow enough
  // that the layers stay recognisable skin (without it the search can trade a scattering
  // epidermis for a thick clear one that fits a little better and means nothing).
  bool plausible(const Vector& x) const {
    const auto specs = model_spec(model_).constants;
    for (std::size_t k = 0; k < searched_.size(); ++k) {
      const ConstantSpec& spec = specs[searched_[k]];
      if (x[k] < to_coordinate(spec, spec.lower) || x[k] > to_coordinate(spec, spec.upper)) return false;
    }
    return true;
  }

 private:
  ModelKind model_;
  ModelConstants start_;
  std::vector<std::size_t> searched_;
};

// Nelder & Mead (1965) with the usual coefficients, minimising f from x0 with initial step.
template <typename F>
std::pair<Vector, double> nelder_mead(F&& f, const Vector& x0, double step, int max_evaluations, int& evaluations) {
  const std::size_t n = x0.size();
  std::vector<std::pair<Vector, double>> simplex(n + 1);
  simplex[0] = {x0, f(x0)};
  for (std::size_t i = 0; i < n; ++i) {
    Vector x = x0;
    x[i] += step;
    simplex[i + 1] = {x, f(x)};
  }
  evaluations = static_cast<int>(n + 1);
  const auto along = [n](const Vector& from, const Vector& to, double t) {
    Vector out(n);
    for (std::size_t i = 0; i < n; ++i) out[i] = from[i] + t * (to[i] - from[i]);
    return out;
  };
  while (evaluations < max_evaluations) {
    std::ranges::sort(simplex, {}, &std::pair<Vector, double>::second);
    if (simplex[n].second - simplex[0].second < 1e-7) break;
    Vector centroid(n, 0.0);
    for (std::size_t k = 0; k < n; ++k)
      for (std::size_t i = 0; i < n; ++i) centroid[i] += simplex[k].first[i] / static_cast<double>(n);
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
  const ModelKind model = options.fit.model;
  if (!start.has(model)) return std::unexpected(fmt::format("the {} model is not loaded", to_string(model)));
  const SkinOptics& optics = start.optics(model);
  if (auto site = optics.site(options.fit.site); !site) return std::unexpected(site.error());
  for (const auto& [name, value] : options.held_constants)
    if (std::ranges::none_of(model_spec(model).constants, [&](const ConstantSpec& c) { return c.name == name; }))
      return std::unexpected(fmt::format("the {} model has no constant '{}'", to_string(model), name));
  ModelConstants initial = optics.constants();
  if (initial.lateral_radius_mm <= 0) initial.lateral_radius_mm = 3;  // the search needs a finite start
  const SearchSpace space(model, initial, options.held_constants);
  const auto mean_rmse = [&](const Vector& x) {
    if (!space.plausible(x)) return std::numeric_limits<double>::infinity();
    const Fitter candidate = start.with_optics(optics.with_constants(space.constants(x)));
    std::vector<double> rmse(training.size(), std::numeric_limits<double>::infinity());
    parallel_for(training.size(), options.threads, [&](std::size_t i) {
      if (auto fit = candidate.fit(training[i], options.fit)) rmse[i] = fit->rmse;
    });
    return std::accumulate(rmse.begin(), rmse.end(), 0.0) / static_cast<double>(rmse.size());
  };
  TuningResult result;
  const auto [best, value] =
      nelder_mead(mean_rmse, space.start_point(), 0.3, options.max_evaluations, result.evaluations);
  result.constants = space.constants(best);
  result.mean_rmse = value;
  return result;
}

}  // namespace skinspec
