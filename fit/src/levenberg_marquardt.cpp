#include "levenberg_marquardt.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <limits>

#include "skinspec/fit/model_spec.hpp"
#include "kernels/kernels.hpp"
#include "small_qr.hpp"

namespace skinspec::detail {

namespace {

// The trust region's largest radius, and the least share of the decrease the linear model
// promised that a step must deliver to be taken.
constexpr double kMaxRadius = 1e16;
constexpr double kMinStepQuality = 1e-3;
// Limits of the damping's diagonal (the scaled columns' squared norms): a column that vanishes
// still gets damped.
constexpr double kMinDiagonal = 1e-6, kMaxDiagonal = 1e32;

// The residuals and their Jacobian at one point.
template <int N>
struct Point {
  std::array<double, N> p{};
  Eigen::VectorXd residuals;
  Eigen::MatrixXd jacobian;
  double cost = 0;
};

// A solve's matrices the size of the Jacobian that it does not hand back, kept by each thread
// from one solve to the next: a fit runs several solves, and allocating them afresh each time
// showed in the profile (and, with many threads fitting, in page faults as the heap grew and
// shrank).
struct SpareMatrices {
  Eigen::VectorXd residuals;
  Eigen::MatrixXd jacobian, r;
  Eigen::VectorXd qtr;
};

SpareMatrices& thread_spares() {
  thread_local SpareMatrices spares;
  return spares;
}

template <int N>
class Minimizer {
 public:
  Minimizer(LeastSquares& problem, const std::array<bool, N>& free, const std::vector<double>& plausible_lower,
            const std::vector<double>& plausible_upper, const LmOptions& options)
      : f_(problem), options_(options), plausible_lower_(plausible_lower), plausible_upper_(plausible_upper) {
    for (int i = 0; i < N; ++i)
      if (free[static_cast<std::size_t>(i)]) free_[k_++] = i;
    exchange_spares();
    const auto rows = static_cast<Eigen::Index>(problem.residual_count());
    for (Point<N>* point : {&x_, &candidate_}) {
      point->residuals.resize(rows);
      point->jacobian.resize(rows, N);
    }
    // At least as many rows as free columns, the extra ones zero: a spectrum of fewer samples
    // than free parameters still gets a square R, whose damping keeps the steps finite.
    r_.setZero(std::max<Eigen::Index>(rows, k_), k_);
    qtr_.setZero(r_.rows());
  }
  // x_'s matrices go to the result; the candidate's and R's stay for the thread's next solve.
  ~Minimizer() { exchange_spares(); }
  Minimizer(const Minimizer&) = delete;
  Minimizer& operator=(const Minimizer&) = delete;

  LmResult<N> run(const std::array<double, N>& start) {
    x_.p = start;
    if (!evaluate(x_) || !differentiate(x_))
      return {start,
              std::numeric_limits<double>::infinity(),
              0,
              LmStop::ended,
              Termination::failed,
              "the start could not be evaluated",
              {},
              {}};
    const double initial_cost = x_.cost;
    choose_scaling();
    factorize();
    int iterations = 0;
    const Outcome outcome = iterate(iterations);
    const std::string_view reason =
        outcome.stop == LmStop::ended ? to_string(outcome.termination) : "left its plausible range";
    return {x_.p,
            x_.cost,
            iterations,
            outcome.stop,
            outcome.termination,
            fmt::format("{}; {} iterations, cost {:.6g} to {:.6g}", reason, iterations, initial_cost, x_.cost),
            std::move(x_.residuals),
            std::move(x_.jacobian)};
  }

 private:
  struct Outcome {
    LmStop stop = LmStop::ended;
    Termination termination = Termination::iteration_limit;
  };
  static Outcome ended(Termination t) { return {LmStop::ended, t}; }

  // The rules are tested in Ceres' order: the gradient and the trust region at the current
  // point before a step, the step's length before the residuals are evaluated there, and the
  // change of the cost before the step is taken or refused.
  Outcome iterate(int& iterations) {
    double radius = options_.initial_trust_region_radius, shrink = 2;
    for (;;) {
      if (left_plausible_range()) return {LmStop::left_plausible_range, Termination::iteration_limit};
      if (gradient_max_ <= options_.gradient_tolerance) return ended(Termination::gradient_tolerance);
      if (radius <= options_.min_trust_region_radius) return ended(Termination::min_trust_region_radius);
      if (iterations >= options_.max_iterations) return ended(Termination::iteration_limit);
      ++iterations;
      double predicted = 0;
      if (!step(radius, predicted)) {
        radius /= shrink, shrink *= 2;
        continue;
      }
      if (step_norm() <= options_.parameter_tolerance * (norm(x_.p) + options_.parameter_tolerance))
        return ended(Termination::parameter_tolerance);
      const double candidate_cost = evaluate_candidate(predicted);
      if (cost_settled(candidate_cost)) return ended(Termination::function_tolerance);
      const double quality = (x_.cost - candidate_cost) / predicted;
      if (quality <= kMinStepQuality) {
        radius /= shrink, shrink *= 2;
        continue;
      }
      std::swap(x_, candidate_);
      // A point outside the plausible range ends the solve at the top of the loop, unfactorised.
      if (!left_plausible_range()) factorize();
      radius = std::min(kMaxRadius, radius / std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * quality - 1.0, 3)));
      shrink = 2;
    }
  }

  // The function tolerance: the step changed the cost by less than its share of the cost.
  bool cost_settled(double candidate_cost) const {
    return std::abs(x_.cost - candidate_cost) <= options_.function_tolerance * x_.cost;
  }

  // The residuals and cost at the point; false where they cannot be had or are not finite.
  bool evaluate(Point<N>& point) {
    if (!f_.residuals(point.p.data(), point.residuals.data())) return false;
    point.cost = 0.5 * point.residuals.squaredNorm();
    return std::isfinite(point.cost);
  }

  // The Jacobian at the point last evaluated; false where it is not finite. Every entry times 0
  // is 0 unless it is infinite or NaN, so their sum is 0 exactly when all are finite: a sum
  // Eigen vectorises, where allFinite() tests the entries one by one.
  bool differentiate(Point<N>& point) {
    f_.jacobian(point.p.data(), point.jacobian.data());
    return (point.jacobian.array() * 0.0).sum() == 0.0;
  }

  // The candidate's cost, the largest double where it cannot be evaluated or, for a step that
  // is taken, its Jacobian is not finite. The Jacobian is computed only for a step taken: a
  // rejected step needs none (about half the steps are rejected), nor does one whose cost
  // settles the solve, which ends at x, not at the candidate (most of a map's pixels end so).
  double evaluate_candidate(double predicted) {
    constexpr double kRefused = std::numeric_limits<double>::max();
    if (!evaluate(candidate_)) return kRefused;
    const double cost = candidate_.cost;
    const bool converges = cost_settled(cost);
    const bool taken = !((x_.cost - cost) / predicted <= kMinStepQuality);
    if (!converges && taken && !differentiate(candidate_)) return kRefused;
    return cost;
  }

  // Each free column divided by 1 + its norm at the start, so that parameters of very
  // different scales are damped alike; fixed for the solve, as the trust region's radius is
  // measured in these units.
  void choose_scaling() {
    for (int j = 0; j < k_; ++j) scale_[j] = 1.0 / (1.0 + x_.jacobian.col(free_[j]).norm());
  }

  // R of the QR factorisation of the scaled free columns at x, Q^T r, the damping's diagonal
  // and the gradient's largest component: what every step from x needs. The columns are
  // scaled, and their norms and products taken, in one pass (a kernel, kernels.hpp).
  void factorize() {
    const auto rows = static_cast<int>(x_.residuals.size());
    std::array<double, N> squared_norms{}, products{};
    fit_kernels().scaled_columns({x_.jacobian.data(), rows, free_.data(), k_, scale_.data(), x_.residuals.data(),
                                  r_.data(), static_cast<int>(r_.rows()), squared_norms.data(), products.data()});
    gradient_max_ = 0;
    for (int j = 0; j < k_; ++j) {
      diagonal_[j] = std::clamp(squared_norms[j], kMinDiagonal, kMaxDiagonal);
      gradient_max_ = std::max(gradient_max_, std::abs(products[j]));
    }
    qtr_.head(rows) = x_.residuals;
    qtr_.tail(qtr_.size() - rows).setZero();
    triangularize(r_.data(), static_cast<int>(r_.rows()), k_, qtr_.data());
  }

  // The damped Gauss-Newton step at x for this radius, min |J s + r|^2 + |D s|^2 / radius in
  // scaled units, from R of J = QR rather than from J itself; false when it is not finite or
  // promises no decrease. Sets the candidate point and the cost decrease the linear model
  // predicts.
  bool step(double radius, double& predicted) {
    const int rows = 2 * k_;  // R over the damping's diagonal
    std::array<double, 2 * N * N> a{};
    std::array<double, 2 * N> s{};
    for (int j = 0; j < k_; ++j) {
      for (int i = 0; i <= j; ++i) a[j * rows + i] = r_(i, j);
      a[j * rows + k_ + j] = std::sqrt(diagonal_[j] / radius);
      s[j] = -qtr_[j];
    }
    triangularize(a.data(), rows, k_, s.data());
    solve_upper(a.data(), rows, k_, s.data());
    if (!std::all_of(s.begin(), s.begin() + k_, [](double v) { return std::isfinite(v); })) return false;
    // J s = Q R s: the linear model's change of the residuals, in Q's basis.
    predicted = 0;
    for (int i = 0; i < k_; ++i) {
      double rs = 0;
      for (int l = i; l < k_; ++l) rs += r_(i, l) * s[l];
      predicted -= rs * (qtr_[i] + 0.5 * rs);
    }
    if (!(predicted > 0)) return false;
    candidate_.p = x_.p;
    for (int j = 0; j < k_; ++j) candidate_.p[free_[j]] += scale_[j] * s[j];
    return true;
  }

  void exchange_spares() {
    SpareMatrices& spares = thread_spares();
    candidate_.residuals.swap(spares.residuals);
    candidate_.jacobian.swap(spares.jacobian);
    r_.swap(spares.r);
    qtr_.swap(spares.qtr);
  }

  double step_norm() const {
    double sum = 0;
    for (int i = 0; i < N; ++i) sum += (candidate_.p[i] - x_.p[i]) * (candidate_.p[i] - x_.p[i]);
    return std::sqrt(sum);
  }

  static double norm(const std::array<double, N>& p) {
    double sum = 0;
    for (const double v : p) sum += v * v;
    return std::sqrt(sum);
  }

  bool left_plausible_range() const {
    for (int j = 0; j < k_; ++j) {
      const auto i = static_cast<std::size_t>(free_[j]);
      if (x_.p[i] < plausible_lower_[i] || x_.p[i] > plausible_upper_[i]) return true;
    }
    return false;
  }

  LeastSquares& f_;
  const LmOptions& options_;
  const std::vector<double>& plausible_lower_;
  const std::vector<double>& plausible_upper_;
  std::array<int, N> free_{};  // the free parameters' indices, k_ of them
  int k_ = 0;
  std::array<double, N> scale_{}, diagonal_{};
  double gradient_max_ = 0;
  Point<N> x_, candidate_;
  Eigen::MatrixXd r_;  // the scaled free columns, then R in their upper triangle
  Eigen::VectorXd qtr_;
};

}  // namespace

template <int N>
LmResult<N> levenberg_marquardt(LeastSquares& problem, const std::array<double, N>& start,
                                const std::array<bool, N>& free, const std::vector<double>& plausible_lower,
                                const std::vector<double>& plausible_upper, const LmOptions& options) {
  return Minimizer<N>(problem, free, plausible_lower, plausible_upper, options).run(start);
}

// Both skin models' parameter counts, and the NIST StRD problems' of tests/fit/strd_test.cpp.
static_assert(kPaperParamCount >= 2 && kMaxParamCount <= 7);
#define SKINSPEC_LEVENBERG_MARQUARDT(N)                                                                                \
  template LmResult<N> levenberg_marquardt<N>(LeastSquares&, const std::array<double, N>&, const std::array<bool, N>&, \
                                              const std::vector<double>&, const std::vector<double>&,                  \
                                              const LmOptions&);
SKINSPEC_LEVENBERG_MARQUARDT(2)
SKINSPEC_LEVENBERG_MARQUARDT(3)
SKINSPEC_LEVENBERG_MARQUARDT(4)
SKINSPEC_LEVENBERG_MARQUARDT(5)
SKINSPEC_LEVENBERG_MARQUARDT(6)
SKINSPEC_LEVENBERG_MARQUARDT(7)
#undef SKINSPEC_LEVENBERG_MARQUARDT

}  // namespace skinspec::detail
