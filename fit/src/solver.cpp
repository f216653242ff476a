#include "solver.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>

#include "levenberg_marquardt.hpp"
#include "spectrum_residuals.hpp"

namespace skinspec::detail {

namespace {

// The plausible range of each parameter, and the wider box the solver may roam before the
// active-set loop pins a parameter at the bound it crossed.
struct Bounds {
  Params lower, upper, solver_lower, solver_upper;
};

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

// A start point: melanin, an amount of blood and its oxygen share in each model's terms;
// every other parameter at its default, held parameters at their values.
Params start_point(const Problem& problem, double melanin, double blood, double oxygen_share) {
  const ModelKind kind = problem.model.kind();
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
    if (problem.held[i]) p[i] = problem.held_values[i];
  return p;
}

double blood_of(ModelKind kind, const Params& p) {
  return kind == ModelKind::paper ? p[kOxyhemoglobin] + p[kDeoxyhemoglobin] : p[kTotalHemoglobin];
}

// Start points for the solver: a coarse log-spaced search over what shapes skin most (melanin
// and blood), on every fourth sample. Returns the best few, best first, each with a different
// amount of blood: dark skin has a second basin where melanin explains the blue and
// haemoglobin drops to zero, and starts from one blood level all fall into it. The epidermis
// varies with melanin alone and the dermis with blood alone, so each layer is computed once per
// level and the points of the grid only combine them.
std::vector<Params> coarse_starts(const Problem& problem, std::size_t how_many) {
  constexpr double kMelaninLevels[] = {0.25, 1, 3, 8, 20, 50, 120};
  constexpr double kBloodLevels[] = {0.25, 1, 3, 8, 20};
  constexpr double kOxygenShares[] = {0.4, 0.8};
  constexpr std::size_t kStride = 4;
  const SkinModel& model = problem.model;
  const ModelKind kind = model.kind();
  const double melanin_limit = model_spec(kind).params[kMelanin].upper;
  const auto melanin_level = [&](double m) { return std::min(m, melanin_limit); };

  std::vector<ReflectanceTransmittance<double>> epidermis;
  for (double m : kMelaninLevels) {
    const Params p = start_point(problem, melanin_level(m), kBloodLevels[0], kOxygenShares[0]);
    for (std::size_t i = 0; i < model.size(); i += kStride) epidermis.push_back(model.epidermis_at(i, p.data()));
  }
  std::vector<DermisRemittance<double>> dermis;
  for (double blood : kBloodLevels)
    for (double share : kOxygenShares) {
      const Params p = start_point(problem, kMelaninLevels[0], blood, share);
      for (std::size_t i = 0; i < model.size(); i += kStride) dermis.push_back(model.dermis_at(i, p.data()));
    }

  const std::size_t samples = epidermis.size() / std::size(kMelaninLevels);
  std::vector<std::pair<double, Params>> scored;
  for (std::size_t e = 0; e < std::size(kMelaninLevels); ++e)
    for (std::size_t d = 0; d < dermis.size() / samples; ++d) {
      const double blood = kBloodLevels[d / std::size(kOxygenShares)];
      const double share = kOxygenShares[d % std::size(kOxygenShares)];
      const Params p = start_point(problem, melanin_level(kMelaninLevels[e]), blood, share);
      double sum = 0;
      for (std::size_t k = 0; k < samples; ++k) {
        const std::size_t i = k * kStride;
        const double r =
            combined_reflectance(p[kSurfaceReflectance], epidermis[e * samples + k], dermis[d * samples + k]) -
            problem.measured[i];
        sum += problem.weights[i] * r * r;
      }
      scored.emplace_back(sum, p);
    }
  std::ranges::sort(scored, {}, &std::pair<double, Params>::first);
  std::vector<Params> starts;
  for (const auto& [score, p] : scored) {
    if (starts.size() == how_many) break;
    if (std::ranges::none_of(starts, [&](const Params& s) { return blood_of(kind, s) == blood_of(kind, p); }))
      starts.push_back(p);
  }
  return starts;
}

template <int N>
class Engine {
 public:
  Engine(const Problem& problem, Workspace& work)
      : problem_(problem), bounds_(bounds_of(problem.model)), model_(problem.model), work_(work) {}

  // Bounded least squares by active sets: solve; pin every parameter that crossed a bound at
  // that bound and solve again; release a pinned parameter whose gradient points back inside.
  Solution solve_from(const Params& start) const {
    Solution solution{start, 0, 0, false, {}, std::vector<Pin>(N, Pin::none), {}, {}};
    int iterations = 0;
    for (int round = 0; round < 2 * N; ++round) {
      solve_once(solution);
      iterations += solution.iterations;
      bool changed = pin_crossed(solution);
      if (!changed) changed = release_pinned(solution);
      if (!changed) break;
    }
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
      s.converged = true;
      s.message = "every parameter held";
      return;
    }
    const SpectrumResiduals residuals(model_, problem_.measured, problem_.sqrt_weights,
                                      Box{bounds_.solver_lower, bounds_.solver_upper});
    LmResult<N> result = levenberg_marquardt<N>(residuals, start, free, bounds_.lower, bounds_.upper, work_);
    s.params.assign(result.params.begin(), result.params.end());
    s.cost = result.cost;
    s.iterations = result.iterations;
    s.converged = result.end == LmEnd::converged;
    s.message = result.message;
    s.residuals = std::move(result.residuals);
    s.jacobian = std::move(result.jacobian);
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
  Bounds bounds_;
  SpectrumModel model_;
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

template <int N>
Solution solve_with(const Problem& problem) {
  thread_local Workspace work;  // reused by every fit on this thread
  const Engine<N> engine(problem, work);
  Solution best;
  best.cost = std::numeric_limits<double>::infinity();
  for (const Params& start : coarse_starts(problem, model_spec(problem.model.kind()).starts)) {
    Solution s = engine.solve_from(start);
    if (s.cost < best.cost) best = std::move(s);
  }
  const auto params = model_spec(problem.model.kind()).params;
  bool restart = false;
  Params reseeded = best.params;
  for (std::size_t i = 0; i < N; ++i)
    if (restarts_at_zero(problem.model.kind(), i) && !problem.held[i] && reseeded[i] == params[i].lower) {
      reseeded[i] = kRestartAbsorber;
      restart = true;
    }
  if (restart) {
    Solution s = engine.solve_from(reseeded);
    s.iterations += best.iterations;
    if (s.cost < best.cost) best = std::move(s);
  }
  return best;
}

}  // namespace

Solution solve(const Problem& problem) {
  return problem.model.kind() == ModelKind::paper ? solve_with<kPaperParamCount>(problem)
                                                  : solve_with<kExtendedParamCount>(problem);
}

}  // namespace skinspec::detail
