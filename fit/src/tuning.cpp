#include "skinspec/fit/tuning.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <limits>
#include <optional>

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

// Adds one to each watched parameter (ModelSpec::bound_watched) the fit left on a bound.
void count_at_bound(const FitResult& fit, std::vector<std::size_t>& at_bound) {
  const auto watched = model_spec(fit.model).bound_watched;
  at_bound.resize(watched.size());
  for (std::size_t w = 0; w < watched.size(); ++w)
    at_bound[w] += fit.determination[static_cast<std::size_t>(watched[w])].status == Determination::at_bound ? 1 : 0;
}

// How much a parameter piled on a bound costs the search: the mean RMSE is multiplied by 1 +
// this times the share of fits beyond the model's limit. Large enough that one fit too many
// outweighs any gain in RMSE the constants can buy, so the limit acts as a constraint, yet
// graded, so that the search is led back inside it from a start outside.
constexpr double kBoundPenalty = 10;

// The search keeps its training fits within this share of the model's limit: a limit met
// exactly on the training spectra was exceeded on held-out ones.
constexpr double kBoundMargin = 0.75;

double bound_excess(ModelKind model, const std::vector<std::size_t>& at_bound, std::size_t fits) {
  const double most = kBoundMargin * model_spec(model).most_at_bound;
  double excess = 0;
  for (const std::size_t count : at_bound)
    excess += std::max(0.0, static_cast<double>(count) / static_cast<double>(fits) - most);
  return excess;
}

}  // namespace

void FitScores::add(const FitResult& fit) {
  rmse.push_back(fit.rmse);
  delta_e00.push_back(fit.delta_e00_d65);
  converged += fit.converged ? 1 : 0;
  count_at_bound(fit, at_bound);
}

void FitScores::append(const FitScores& other) {
  rmse.insert(rmse.end(), other.rmse.begin(), other.rmse.end());
  delta_e00.insert(delta_e00.end(), other.delta_e00.begin(), other.delta_e00.end());
  converged += other.converged;
  at_bound.resize(std::max(at_bound.size(), other.at_bound.size()));
  for (std::size_t w = 0; w < other.at_bound.size(); ++w) at_bound[w] += other.at_bound[w];
}

FitQuality summarize(const FitScores& scores) {
  FitQuality q;
  q.count = scores.rmse.size();
  q.converged = scores.converged;
  q.at_bound = scores.at_bound;
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
    scores.add(*fit);
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
  // The training fits' mean RMSE and the objective for constants x.
  const auto assess = [&](const Vector& x) {
    constexpr double kNever = std::numeric_limits<double>::infinity();
    if (!space.plausible(x)) return std::pair{kNever, kNever};
    const Fitter candidate = start.with_optics(optics.with_constants(space.constants(x)));
    std::vector<std::optional<FitResult>> fits(training.size());
    parallel_for(training.size(), options.threads, [&](std::size_t i) {
      if (auto fit = candidate.fit(training[i], options.fit)) fits[i] = std::move(*fit);
    });
    double sum = 0;
    std::vector<std::size_t> at_bound;
    for (const auto& fit : fits) {
      if (!fit) return std::pair{kNever, kNever};
      sum += fit->rmse;
      count_at_bound(*fit, at_bound);
    }
    const double mean = sum / static_cast<double>(fits.size());
    return std::pair{mean, mean * (1 + kBoundPenalty * bound_excess(model, at_bound, fits.size()))};
  };
  // A model with no limit on bounds takes one simplex search for the best fit. Otherwise, first
  // the best fit alone, then, from there, within the limit: the penalty is a count, flat
  // between steps, and a simplex started where it already bites stalls on its plateaus. Each
  // phase restarts the simplex around its best point while that still helps, which frees a
  // simplex collapsed onto a ridge.
  TuningResult result;
  Vector best = space.start_point();
  const bool limited = !model_spec(model).bound_watched.empty();
  const auto search = [&](auto&& objective, int budget) {
    double value = objective(best);
    for (int used = 0; used < budget;) {
      int evaluations = 0;
      auto [x, f] = nelder_mead(objective, best, 0.3, budget - used, evaluations);
      used += evaluations;
      result.evaluations += evaluations;
      const bool improved = f < value * (1 - 1e-4);
      if (f < value) best = std::move(x), value = f;
      if (!improved || !limited) break;
    }
  };
  search([&](const Vector& x) { return assess(x).first; },
         limited ? options.max_evaluations / 2 : options.max_evaluations);
  if (limited) search([&](const Vector& x) { return assess(x).second; }, options.max_evaluations - result.evaluations);
  std::tie(result.mean_rmse, result.objective) = assess(best);
  result.constants = space.constants(best);
  return result;
}

}  // namespace skinspec
