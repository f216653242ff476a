#include "solver.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <optional>

#include "kernels/kernels.hpp"
#include "levenberg_marquardt.hpp"
#include "spectrum_residuals.hpp"

namespace skinspec::detail {

Bounds bounds_of(const SkinModel& model) {
  const ModelSpec& spec = model_spec(model.kind());
  const Params safe = model.lowest_safe_weights();
  Bounds b;
  for (std::size_t i = 0; i < spec.params.size(); ++i) {
    const ParamSpec& param = spec.params[i];
    const double overshoot = spec.bound_overshoot * (param.upper - param.lower);
    b.lower.push_back(param.lower);
    b.upper.push_back(param.upper);
    b.solver_lower.push_back(param.absorber ? std::min(safe[i], param.lower) : param.lower - overshoot);
    b.solver_upper.push_back(param.upper + overshoot);
  }
  return b;
}

namespace {

// A start point: melanin, an amount of blood and its oxygen share in each model's terms;
// every other parameter at its default, held parameters at their values.
Params start_point(ModelKind kind, const std::vector<bool>& held, const Params& held_values, double melanin,
                   double blood, double oxygen_share) {
  Params p = default_params(kind);
  if (kind == ModelKind::paper) {
    p = {0.03, melanin, blood * oxygen_share, blood * (1 - oxygen_share), 1.0};
  } else {
    p[kSurfaceReflectance] = 0.03;
    p[kMelanin] = melanin;
    p[kTotalHemoglobin] = blood;
    p[kOxygenSaturation] = oxygen_share;
    p[kBilirubin] = 1.0;
  }
  for (std::size_t i = 0; i < p.size(); ++i)
    if (held[i]) p[i] = held_values[i];
  return p;
}

// problem.start inside the bounds, with the held parameters at their values.
Params given_start(const Problem& problem) {
  Params p = *problem.start;
  for (std::size_t i = 0; i < p.size(); ++i)
    p[i] =
        problem.held[i] ? problem.held_values[i] : std::clamp(p[i], problem.bounds.lower[i], problem.bounds.upper[i]);
  return p;
}

double blood_of(ModelKind kind, const Params& p) {
  return kind == ModelKind::paper ? p[kOxyhemoglobin] + p[kDeoxyhemoglobin] : p[kTotalHemoglobin];
}

// The coarse search's grid: log-spaced levels of what shapes skin most (melanin and blood), on
// every fourth sample.
constexpr double kMelaninLevels[] = {0.25, 1, 3, 8, 20, 50, 120};
constexpr double kBloodLevels[] = {0.25, 1, 3, 8, 20};
constexpr double kOxygenShares[] = {0.4, 0.8};
constexpr std::size_t kStride = 4;

double melanin_level(ModelKind kind, double m) { return std::min(m, model_spec(kind).params[kMelanin].upper); }

// Start points for the solver from a coarse search over melanin and blood. Returns the best
// few, best first, each with a different amount of blood: dark skin has a second basin where
// melanin explains the blue and haemoglobin drops to zero, and starts from one blood level all
// fall into it. The epidermis varies with melanin alone and the dermis with blood alone, so
// each layer is computed once per level (CoarseLayers, kept between fits of one model) and the
// points of the grid only combine them.
std::vector<Params> coarse_starts(const Problem& problem, std::size_t how_many) {
  const ModelKind kind = problem.model.kind();
  const CoarseLayers& layers = problem.coarse;
  const std::size_t samples = layers.samples, dermis_levels = layers.dermis_total.size() / samples;
  std::vector<double> measured(samples), weights(samples), squared(samples);
  for (std::size_t k = 0; k < samples; ++k)
    measured[k] = problem.measured[k * kStride], weights[k] = problem.weights[k * kStride];
  const bool corneum = !layers.corneum_r.empty();
  std::vector<double> errors(std::size(kMelaninLevels) * dermis_levels);
  fit_kernels().coarse_errors(
      {static_cast<int>(samples), static_cast<int>(std::size(kMelaninLevels)), static_cast<int>(dermis_levels),
       layers.epidermis_r.data(), layers.epidermis_t2.data(), layers.dermis_total.data(), layers.dermis_kept.data(),
       corneum ? layers.corneum_r.data() : nullptr, corneum ? layers.corneum_t2.data() : nullptr,
       start_point(kind, problem.held, problem.held_values, 0, 0, 0)[kSurfaceReflectance], measured.data(),
       weights.data(), squared.data(), errors.data()});
  struct Scored {
    double score;
    std::size_t epidermis, dermis;
  };
  std::vector<Scored> scored;
  scored.reserve(errors.size());
  for (std::size_t e = 0; e < std::size(kMelaninLevels); ++e)
    for (std::size_t d = 0; d < dermis_levels; ++d) scored.push_back({errors[e * dermis_levels + d], e, d});
  std::ranges::sort(scored, {}, &Scored::score);
  std::vector<Params> starts;
  for (const Scored& s : scored) {
    if (starts.size() == how_many) break;
    const double blood = kBloodLevels[s.dermis / std::size(kOxygenShares)];
    const double share = kOxygenShares[s.dermis % std::size(kOxygenShares)];
    Params p = start_point(kind, problem.held, problem.held_values, melanin_level(kind, kMelaninLevels[s.epidermis]),
                           blood, share);
    if (std::ranges::none_of(starts, [&](const Params& q) { return blood_of(kind, q) == blood_of(kind, p); }))
      starts.push_back(std::move(p));
  }
  return starts;
}

// One spectrum's residuals as the solver asks for them, evaluated in this thread's workspace.
class SpectrumLeastSquares final : public LeastSquares {
 public:
  SpectrumLeastSquares(const SpectrumResiduals& residuals, Workspace& work) : f_(residuals), work_(work) {}
  std::size_t residual_count() const override { return f_.size(); }
  bool residuals(const double* p, double* out) override { return f_.evaluate(p, work_, out); }
  void jacobian(const double* p, double* out) override { f_.jacobian(p, work_, out); }

 private:
  const SpectrumResiduals& f_;
  Workspace& work_;
};

// The active-set loop's rounds, per parameter: a dark spectrum can pin and release most of the
// parameters in turn on its way down (14 rounds of 7 parameters, each lowering the cost, were
// seen), and the cap only guards against a cycle.
constexpr int kRoundsPerParameter = 6;

template <int N>
class Engine {
 public:
  Engine(const Problem& problem, Workspace& work)
      : problem_(problem), bounds_(problem.bounds), model_(problem.columns), work_(work) {}

  // Bounded least squares by active sets: solve; pin every parameter that crossed a bound at
  // that bound and solve again; release a pinned parameter whose gradient points back inside.
  Solution solve_from(const Params& start) const {
    Solution solution{start, 0, 0, Termination::failed, {}, std::vector<Pin>(N, Pin::none), {}, {}};
    int iterations = 0;
    bool settled = false;
    for (int round = 0; round < kRoundsPerParameter * N && !settled; ++round) {
      solve_once(solution);
      iterations += solution.iterations;
      settled = !pin_crossed(solution) && !release_pinned(solution);
    }
    // Out of rounds with the active set still changing: the last solve's end is not the fit's.
    if (!settled) solution.termination = Termination::iteration_limit;
    solution.iterations = iterations;
    know_derivatives(solution);
    return solution;
  }

 private:
  // The residuals and Jacobian at the solution's parameters, where the solve did not leave them.
  void know_derivatives(Solution& s) const {
    if (s.jacobian.size() != 0) return;
    const auto n = static_cast<Eigen::Index>(problem_.model.size());
    s.residuals.resize(n);
    s.jacobian.resize(n, N);
    const SpectrumResiduals residuals(model_, problem_.measured, problem_.sqrt_weights);
    residuals.evaluate(s.params.data(), work_, s.residuals.data());
    residuals.jacobian(s.params.data(), work_, s.jacobian.data());
  }

  bool fixed(const Solution& s, std::size_t i) const { return problem_.held[i] || s.pinned[i] != Pin::none; }

  // One Levenberg-Marquardt solve in the solver's box (steps out of it are rejected), fixed
  // parameters held, ended early when a free parameter leaves its plausible range. Bounds are
  // kept by the active-set loop rather than by projecting steps onto them, which makes the
  // trust region shrink step after step while a parameter creeps along an active bound: tens
  // of iterations instead of a handful.
  void solve_once(Solution& s) const {
    std::array<double, N> start{};
    std::array<bool, N> free{};
    for (std::size_t i = 0; i < N; ++i) {
      start[i] = s.params[i];
      free[i] = !fixed(s, i);
    }
    if (std::ranges::none_of(free, std::identity{})) {
      s.jacobian.resize(0, 0);
      know_derivatives(s);
      s.cost = 0.5 * s.residuals.squaredNorm();
      s.iterations = 0;
      // The gradient over no free parameters is empty, its largest component 0.
      s.termination = Termination::gradient_tolerance;
      s.message = "every parameter held";
      return;
    }
    const SpectrumResiduals residuals(model_, problem_.measured, problem_.sqrt_weights,
                                      Box{bounds_.solver_lower, bounds_.solver_upper});
    SpectrumLeastSquares least_squares(residuals, work_);
    LmResult<N> result =
        levenberg_marquardt<N>(least_squares, start, free, bounds_.lower, bounds_.upper, solve_options(free));
    s.params.assign(result.params.begin(), result.params.end());
    s.cost = result.cost;
    s.iterations = result.iterations;
    // A solve that left the plausible range is followed by another once the loop has pinned.
    s.termination = result.stop == LmStop::ended ? result.termination : Termination::iteration_limit;
    s.message = result.message;
    s.residuals = std::move(result.residuals);
    s.jacobian = std::move(result.jacobian);
  }

  // MINPACK's limit (lmder1's 200 evaluations per free parameter and one), not a tighter one:
  // dark skin, its dermis seen through much melanin, can take hundreds of short steps down a
  // curved valley, and the fit at their end is better (RMSE lower by up to a sixth), not the same.
  static LmOptions solve_options(const std::array<bool, N>& free) {
    LmOptions options;
    options.max_iterations = 200 * (static_cast<int>(std::ranges::count(free, true)) + 1);
    return options;
  }

  bool pin_crossed(Solution& s) const {
    bool changed = false;
    for (std::size_t i = 0; i < N; ++i) {
      if (fixed(s, i)) continue;
      if (s.params[i] < bounds_.lower[i]) s.params[i] = bounds_.lower[i], s.pinned[i] = Pin::lower, changed = true;
      else if (s.params[i] > bounds_.upper[i]) s.params[i] = bounds_.upper[i], s.pinned[i] = Pin::upper, changed = true;
    }
    if (changed) s.jacobian.resize(0, 0);
    return changed;
  }

  // d(cost)/d(p_i): where it points back inside for a pinned parameter, the fit would improve
  // by letting that parameter move again.
  bool release_pinned(Solution& s) const {
    if (std::ranges::none_of(s.pinned, [](Pin pin) { return pin != Pin::none; })) return false;
    know_derivatives(s);
    bool changed = false;
    for (std::size_t i = 0; i < N; ++i) {
      if (s.pinned[i] == Pin::none) continue;
      const double gradient = s.jacobian.col(static_cast<Eigen::Index>(i)).dot(s.residuals);
      if ((s.pinned[i] == Pin::lower && gradient < 0) || (s.pinned[i] == Pin::upper && gradient > 0))
        s.pinned[i] = Pin::none, changed = true;
    }
    return changed;
  }

  const Problem& problem_;
  const Bounds& bounds_;
  const SpectrumModel& model_;
  Workspace& work_;
};

// What to restart from when absorbers end at zero: in dark skin melanin can stand in for blood
// in a second, worse basin with haemoglobin at zero, which no start near it leaves.
constexpr double kRestartAbsorber = 3;

// The absorbers whose zero prompts that restart: every one of the paper's; the extended model's
// haemoglobin alone, since its bilirubin at zero (common in real skin) is no such basin and a
// restart for it would double the cost of most fits for nothing.
bool restarts_at_zero(ModelKind kind, std::size_t i) {
  if (kind == ModelKind::paper) return model_spec(kind).params[i].absorber;
  return i == static_cast<std::size_t>(kTotalHemoglobin);
}

// The start of a second solve when absorbers that restart at zero (restarts_at_zero) ended
// there: those absorbers at kRestartAbsorber.
std::optional<Params> absorber_restart(const Problem& problem, const Params& fitted) {
  const auto params = model_spec(problem.model.kind()).params;
  Params reseeded = fitted;
  bool restart = false;
  for (std::size_t i = 0; i < reseeded.size(); ++i)
    if (restarts_at_zero(problem.model.kind(), i) && !problem.held[i] && reseeded[i] == params[i].lower) {
      reseeded[i] = kRestartAbsorber;
      restart = true;
    }
  return restart ? std::optional(reseeded) : std::nullopt;
}

// A dermal scattering on its upper bound can be a basin of its own: with much melanin and
// blood (melanin 16-18, blood 10-12), 14 of 256 synthetic skins fitted from the coarse search
// ended there (RMSE 0.00227 against the true skin's 0.00182 in one), while the true skin's
// start found it (tests/maps/maps_test.cpp). Solved once more from there with the scattering
// and its power at their defaults, all 256 reach the true skin; on the NIST forearms it costs
// the few fits really on that bound another solve.
std::optional<Params> scattering_restart(const Problem& problem, const Params& fitted) {
  const auto params = model_spec(problem.model.kind()).params;
  if (problem.model.kind() != ModelKind::extended || problem.held[kDermisScattering] ||
      fitted[kDermisScattering] < params[kDermisScattering].upper)
    return std::nullopt;
  Params again = fitted;
  again[kDermisScattering] = params[kDermisScattering].initial;
  if (!problem.held[kDermisScatteringPower]) again[kDermisScatteringPower] = params[kDermisScatteringPower].initial;
  return again;
}

// Room for the model's evaluations, reused by every fit on this thread, so that evaluating
// the model allocates nothing.
Workspace& thread_workspace() {
  thread_local Workspace work;
  return work;
}

template <int N>
Solution solve_with(const Problem& problem) {
  const Engine<N> engine(problem, thread_workspace());
  Solution best;
  best.cost = std::numeric_limits<double>::infinity();
  for (const Params& start : problem.start ? std::vector<Params>{given_start(problem)}
                                           : coarse_starts(problem, model_spec(problem.model.kind()).starts)) {
    Solution s = engine.solve_from(start);
    if (s.cost < best.cost) best = std::move(s);
  }
  // Each second basin the solve may have fallen into, in turn: solved once more from a start
  // out of it, kept where that ends lower.
  for (const auto& restart : {absorber_restart, scattering_restart})
    if (const auto start = restart(problem, best.params)) {
      Solution s = engine.solve_from(*start);
      s.iterations += best.iterations;
      if (s.cost < best.cost) best = std::move(s);
    }
  return best;
}

}  // namespace

CoarseLayers coarse_layers(const SkinModel& model, const std::vector<bool>& held, const Params& held_values) {
  const ModelKind kind = model.kind();
  CoarseLayers layers;
  for (std::size_t i = 0; i < model.size(); i += kStride) {
    ++layers.samples;
    layers.corneum_r.push_back(model.optics_at(i).corneum_r),
        layers.corneum_t2.push_back(model.optics_at(i).corneum_t2);
  }
  if (std::ranges::all_of(layers.corneum_r, [](double r) { return r == 0; }))
    layers.corneum_r.clear(), layers.corneum_t2.clear();
  for (double m : kMelaninLevels) {
    const Params p = start_point(kind, held, held_values, melanin_level(kind, m), kBloodLevels[0], kOxygenShares[0]);
    for (std::size_t i = 0; i < model.size(); i += kStride) {
      const auto epidermis = model.epidermis_at(i, p.data());
      layers.epidermis_r.push_back(epidermis.r), layers.epidermis_t2.push_back(epidermis.t * epidermis.t);
    }
  }
  for (double blood : kBloodLevels)
    for (double share : kOxygenShares) {
      const Params p = start_point(kind, held, held_values, kMelaninLevels[0], blood, share);
      for (std::size_t i = 0; i < model.size(); i += kStride) {
        const auto dermis = model.dermis_at(i, p.data());
        layers.dermis_total.push_back(dermis.total), layers.dermis_kept.push_back(dermis.kept);
      }
    }
  return layers;
}

Solution solve(const Problem& problem) {
  return problem.model.kind() == ModelKind::paper ? solve_with<kPaperParamCount>(problem)
                                                  : solve_with<kExtendedParamCount>(problem);
}

std::vector<double> reflectance(const SpectrumModel& columns, const Params& p) {
  std::vector<double> r(static_cast<std::size_t>(columns.size()));
  columns.reflectance(p.data(), thread_workspace(), r.data());
  return r;
}

}  // namespace skinspec::detail
