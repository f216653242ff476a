#include "skinspec/fit/fitter.hpp"

#include <ceres/ceres.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <span>
#include <vector>
#include <limits>
#include <span>
#include <vector>
#include <fmt/format.h>

namespace skinspec {

namespace {

// Weighted residuals sqrt(w_i) (model_i - measured_i), differentiated by Ceres.
struct SpectrumResidual {
  const SkinModel& model;
  const std::vector<double>& measured;
  const std::vector<double>& sqrt_weights;

  template <typename T>
  bool operator()(const T* p, T* residuals) const {
    for (std::size_t i = 0; i < model.size(); ++i)
      residuals[i] = sqrt_weights[i] * (model.reflectance_at(i, p) - measured[i]);
    return true;
  }
};

using ResidualCost = ceres::AutoDiffCostFunction<SpectrumResidual, ceres::DYNAMIC, kParamCount>;

double weighted_sum_of_squares(const SkinModel& model, const std::vector<double>& measured,
                               const std::vector<double>& weights, const Params& p, std::size_t stride) {
  double sum = 0;
  for (std::size_t i = 0; i < model.size(); i += stride) {
    const double r = model.reflectance_at(i, p.data()) - measured[i];
    sum += weights[i] * r * r;
  }
  return sum;
}

// Start points for the solver: a coarse log-spaced search over the pigments that shape skin
// most (melanin and blood), on every fourth sample. Returns the best few, best first, each
// with a different amount of blood: dark skin has a second basin where melanin explains the
// blue and haemoglobin drops to zero, and starts from one blood level all fall into it.
std::vector<Params> coarse_starts(const SkinModel& model, const std::vector<double>& measured,
                                  const std::vector<double>& weights, std::size_t how_many) {
  constexpr double kMelanin[] = {0.25, 1, 3, 8, 20, 50, 120};
  constexpr double kBlood[] = {0.25, 1, 3, 8, 20};
  constexpr double kOxygenShare[] = {0.4, 0.8};
  std::vector<std::pair<double, Params>> scored;
  for (double m : kMelanin)
    for (double blood : kBlood)
      for (double share : kOxygenShare) {
        const Params p = {0.03, m, blood * share, blood * (1 - share), 1.0};
        scored.emplace_back(weighted_sum_of_squares(model, measured, weights, p, 4), p);
      }
  std::ranges::sort(scored, {}, &std::pair<double, Params>::first);
  std::vector<Params> starts;
  const auto blood_of = [](const Params& p) { return p[kOxyhemoglobin] + p[kDeoxyhemoglobin]; };
  for (const auto& [score, p] : scored) {
    if (starts.size() == how_many) break;
    if (std::ranges::none_of(starts, [&](const Params& s) { return blood_of(s) == blood_of(p); })) starts.push_back(p);
  }
  return starts;
}

struct Solution {
  Params params{};
  double cost = 0;
  int iterations = 0;
  bool converged = false;
  std::string message;
};

using HeldAtZero = std::array<bool, kParamCount>;

// Ends a solve as soon as a free pigment weight turns negative, so that the active-set loop
// can pin it at zero: continuing would only fit a physically meaningless weight.
class StopWhenNegative : public ceres::IterationCallback {
 public:
  StopWhenNegative(const Params& p, const std::array<bool, kParamCount>& held) : p_(p), held_(held) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    for (std::size_t i = kMelanin; i < kParamCount; ++i)
      if (!held_[i] && p_[i] < 0) return ceres::SOLVER_TERMINATE_SUCCESSFULLY;
    return ceres::SOLVER_CONTINUE;
  }

 private:
  const Params& p_;
  const std::array<bool, kParamCount>& held_;
};

// One Levenberg-Marquardt solve. Pigment weights may dip a little below zero here (never so
// far that an absorption turns negative) and those in `held` stay at zero: non-negativity is
// kept by the active-set loop in solve_from rather than by a bound at zero, because Ceres's
// projection onto an active bound shrinks the trust region step after step while the
// solution creeps along the bound.
Solution solve_once(const SkinModel& model, const std::vector<double>& measured,
                    const std::vector<double>& sqrt_weights, Params p, const HeldAtZero& held) {
  ceres::Problem::Options problem_options;
  problem_options.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  problem_options.manifold_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  auto* cost = new ResidualCost(new SpectrumResidual{model, measured, sqrt_weights}, static_cast<int>(model.size()));
  problem.AddResidualBlock(cost, nullptr, p.data());
  const Params lowest = model.lowest_safe_weights();
  for (std::size_t i = 0; i < kParamCount; ++i) {
    problem.SetParameterLowerBound(p.data(), static_cast<int>(i), std::min(lowest[i], kLowerBounds[i]));
    problem.SetParameterUpperBound(p.data(), static_cast<int>(i), kUpperBounds[i]);
  }
  std::vector<int> constant;
  for (int i = 0; i < kParamCount; ++i)
    if (held[static_cast<std::size_t>(i)]) constant.push_back(i);
  if (!constant.empty()) problem.SetManifold(p.data(), new ceres::SubsetManifold(kParamCount, constant));

  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  options.logging_type = ceres::SILENT;
  options.max_num_iterations = 100;
  options.function_tolerance = 1e-7;
  options.gradient_tolerance = 1e-12;
  options.parameter_tolerance = 1e-8;
  options.num_threads = 1;
  StopWhenNegative stop_when_negative(p, held);
  options.callbacks.push_back(&stop_when_negative);
  options.update_state_every_iteration = true;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  return {p, summary.final_cost, static_cast<int>(summary.iterations.size()),
          summary.termination_type == ceres::CONVERGENCE, summary.BriefReport()};
}

// d(cost)/d(p_i) at p: where it is negative for a weight held at zero, the fit would improve
// by letting that weight grow again.
Params cost_gradient(const SkinModel& model, const std::vector<double>& measured,
                     const std::vector<double>& sqrt_weights, const Params& p) {
  const auto n = model.size();
  std::vector<double> residuals(n), jacobian(n * kParamCount);
  const double* parameters[] = {p.data()};
  double* jacobians[] = {jacobian.data()};
  ResidualCost cost(new SpectrumResidual{model, measured, sqrt_weights}, static_cast<int>(n));
  cost.Evaluate(parameters, residuals.data(), jacobians);
  Params gradient{};
  for (std::size_t r = 0; r < n; ++r)
    for (std::size_t i = 0; i < kParamCount; ++i) gradient[i] += residuals[r] * jacobian[r * kParamCount + i];
  return gradient;
}

// Bounded least squares by active sets: solve; pin every weight that went negative at zero
// and solve again; release a pinned weight whose gradient asks for it to grow.
Solution solve_from(const SkinModel& model, const std::vector<double>& measured,
                    const std::vector<double>& sqrt_weights, const Params& start) {
  HeldAtZero held{};
  Solution solution{start, 0, 0, false, {}};
  int iterations = 0;
  for (int round = 0; round < 2 * kParamCount; ++round) {
    solution = solve_once(model, measured, sqrt_weights, solution.params, held);
    iterations += solution.iterations;
    bool changed = false;
    for (std::size_t i = kMelanin; i < kParamCount; ++i)
      if (!held[i] && solution.params[i] < 0) {
        solution.params[i] = 0;
        held[i] = changed = true;
      }
    if (!changed) {
      const Params gradient = cost_gradient(model, measured, sqrt_weights, solution.params);
      for (std::size_t i = kMelanin; i < kParamCount; ++i)
        if (held[i] && gradient[i] < 0) held[i] = false, changed = true;
    }
    if (!changed) break;
  }
  solution.iterations = iterations;
  return solution;
}

// Standard errors from the Gauss-Newton covariance sigma^2 (J^T J)^-1, with sigma^2 estimated
// from the residuals. A pseudo-inverse keeps parameters the data cannot see (a dermis hidden
// by melanin) from poisoning the others: their error is reported as very large instead.
Params standard_errors(const SkinModel& model, const std::vector<double>& measured,
                       const std::vector<double>& sqrt_weights, const Params& p, double cost) {
  const auto n = static_cast<int>(model.size());
  Eigen::Matrix<double, Eigen::Dynamic, kParamCount, Eigen::RowMajor> jacobian(n, kParamCount);
  std::vector<double> residuals(model.size());
  const double* parameters[] = {p.data()};
  double* jacobians[] = {jacobian.data()};
  ResidualCost cost_function(new SpectrumResidual{model, measured, sqrt_weights}, n);
  cost_function.Evaluate(parameters, residuals.data(), jacobians);

  const double dof = std::max(1, n - kParamCount);
  const double sigma2 = 2 * cost / dof;
  const Eigen::Matrix<double, kParamCount, kParamCount> jtj = jacobian.transpose() * jacobian;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, kParamCount, kParamCount>> eigen(jtj);
  const auto& values = eigen.eigenvalues();
  const auto& vectors = eigen.eigenvectors();
  const double tiny = values.maxCoeff() * 1e-14;
  Params errors{};
  for (int j = 0; j < kParamCount; ++j) {
    double variance = 0;
    bool in_null_space = false;
    for (int i = 0; i < kParamCount; ++i) {
      const double share = vectors(j, i) * vectors(j, i);
      if (values(i) > tiny) variance += share / values(i);
      else in_null_space = in_null_space || share > 1e-6;
    }
    errors[static_cast<std::size_t>(j)] =
        in_null_space ? std::numeric_limits<double>::infinity() : std::sqrt(sigma2 * variance);
  }
  return errors;
}

}  // namespace

Fitter::Fitter(SkinOptics optics, Colorimetry colorimetry)
    : optics_(std::move(optics)),
      colorimetry_(std::move(colorimetry)),
      d65_(colorimetry_.weighting(*colorimetry_.illuminant("D65"))) {}

std::expected<FitResult, std::string> Fitter::fit(const Spectrum& measured, const FitOptions& options) const {
  const auto site = optics_.site(options.site);
  if (!site) return std::unexpected(site.error());
  if (!options.weights.empty() && options.weights.size() != measured.size())
    return std::unexpected(fmt::format("{} weights for {} samples", options.weights.size(), measured.size()));

  FitResult result;
  result.site = site->name;
  std::vector<double> weights;
  for (std::size_t i = 0; i < measured.size(); ++i) {
    const double w = measured.wavelengths()[i];
    if (w < SkinOptics::kFirstNm || w > SkinOptics::kLastNm) {
      ++result.samples_ignored;
      continue;
    }
    const double weight = options.weights.empty() ? 1.0 : options.weights[i];
    if (!(weight >= 0) || !std::isfinite(weight))
      return std::unexpected(fmt::format("weight at {} nm must be a finite number >= 0", w));
    result.wavelength_nm.push_back(w);
    result.measured.push_back(measured.values()[i]);
    weights.push_back(weight);
  }
  if (result.wavelength_nm.size() < 2 || result.wavelength_nm.front() > 400 || result.wavelength_nm.back() < 700)
    return std::unexpected(std::string("the spectrum must cover 400-700 nm inside the model's 380-780 nm"));

  const SkinModel model(optics_, *site, result.wavelength_nm, options.lateral_diffusion);
  std::vector<double> sqrt_weights(weights.size());
  std::ranges::transform(weights, sqrt_weights.begin(), [](double w) { return std::sqrt(w); });

  Solution best;
  best.cost = std::numeric_limits<double>::infinity();
  for (const Params& start : coarse_starts(model, result.measured, weights, 2)) {
    Solution s = solve_from(model, result.measured, sqrt_weights, start);
    if (s.cost < best.cost) best = std::move(s);
  }
  // A weight pinned at zero may be a local minimum of its own (melanin standing in for blood
  // in dark skin): try once more with those weights brought back to their reference level.
  if (std::ranges::any_of(std::span(best.params).subspan(kMelanin), [](double w) { return w == 0; })) {
    Params reseeded = best.params;
    for (std::size_t i = kMelanin; i < kParamCount; ++i)
      if (reseeded[i] == 0) reseeded[i] = 3;
    Solution s = solve_from(model, result.measured, sqrt_weights, reseeded);
    s.iterations += best.iterations;
    if (s.cost < best.cost) best = std::move(s);
  }

  result.params = best.params;
  result.iterations = best.iterations;
  result.converged = best.converged;
  result.solver_message = best.message;
  result.fitted = model.reflectance(best.params);
  result.standard_error = standard_errors(model, result.measured, sqrt_weights, best.params, best.cost);
  double sum_squares = 0;
  for (std::size_t i = 0; i < result.fitted.size(); ++i) {
    const double r = result.fitted[i] - result.measured[i];
    sum_squares += r * r;
    result.max_abs_error = std::max(result.max_abs_error, std::abs(r));
  }
  result.rmse = std::sqrt(sum_squares / static_cast<double>(result.fitted.size()));
  const auto measured_lab = Colorimetry::lab(*Spectrum::create(result.wavelength_nm, result.measured), d65_);
  const auto fitted_lab = Colorimetry::lab(*Spectrum::create(result.wavelength_nm, result.fitted), d65_);
  result.delta_e00_d65 = delta_e2000(measured_lab, fitted_lab);
  return result;
}

}  // namespace skinspec
