#include "determination.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>

#include "kernels/kernels.hpp"
#include "solver.hpp"

namespace skinspec::detail {

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

using SmallVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxParamCount, 1>;

// An imprecise parameter correlated above this with another is "correlated" with it: the
// spectrum sees mainly a combination of the two (docs/model.md, "What the spectrum determines").
constexpr double kCorrelationLimit = 0.9;

// The standard error up to which an estimate counts as determined.
double precision(double absolute, double relative, double value) {
  return std::max(absolute, relative * std::abs(value));
}

bool on_bound(const ParamSpec& spec, double value, Pin pin) {
  if (pin != Pin::none) return true;
  const double tolerance = 1e-9 * (spec.upper - spec.lower);
  return value <= spec.lower + tolerance || value >= spec.upper - tolerance;
}

// The normal matrix J^T J of the free columns scaled to unit norm, and the scales: dot
// products of the Jacobian's columns in place (a kernel, kernels.hpp), rather than a copy of
// the columns and a general matrix product (which packed and blocked a 100 x 7 product: a
// quarter of the cost of judging a fit started near its answer, docs/benchmarks.md "Skin
// maps").
struct ScaledNormal {
  SmallMatrix normal;
  SmallVector scale;
  std::vector<bool> invisible;  // columns of zero norm: parameters the spectrum does not see
};

ScaledNormal scaled_normal(const Eigen::MatrixXd& jacobian, const std::vector<std::size_t>& free) {
  const auto k = static_cast<Eigen::Index>(free.size());
  ScaledNormal s{SmallMatrix(k, k), SmallVector(k), std::vector<bool>(free.size())};
  std::array<int, kMaxParamCount> columns{};
  for (std::size_t f = 0; f < free.size(); ++f) columns[f] = static_cast<int>(free[f]);
  fit_kernels().normal_matrix(
      {jacobian.data(), static_cast<int>(jacobian.rows()), columns.data(), static_cast<int>(k), s.normal.data()});
  for (Eigen::Index a = 0; a < k; ++a) {
    const double norm = std::sqrt(s.normal(a, a));
    s.invisible[static_cast<std::size_t>(a)] = !(norm > 0);
    s.scale(a) = norm > 0 ? norm : 1;
  }
  // One scale at a time: the product of two tiny norms could underflow.
  for (Eigen::Index a = 0; a < k; ++a)
    for (Eigen::Index b = 0; b < k; ++b) s.normal(a, b) = s.normal(a, b) / s.scale(a) / s.scale(b);
  return s;
}

// The pseudo-inverse below counts an eigenvalue as zero under kNullEigenvalue times the
// largest. With unit columns the largest is at most k (the trace), and the least at least
// 1 / trace(inverse); so where k trace(inverse) is under 1 / kNullEigenvalue, by a margin for
// the inverse's own rounding, no eigenvalue is zero and the pseudo-inverse is the inverse,
// which Cholesky gives far more cheaply. Most fits are such: this and the normal matrix taken in
// place made map_bench's fitting 15 % faster (docs/benchmarks.md, "Skin maps").
constexpr double kNullEigenvalue = 1e-14, kCholeskyMargin = 100;

// (L Lᵀ)⁻¹ = L⁻ᵀ L⁻¹ from Cholesky's L: L⁻¹ by forward substitution, then the products of its
// columns. Eigen's solve against the identity took the blocked path it has for large
// matrices, which showed in the profile of judging a fit.
SmallMatrix inverse_from_cholesky(const SmallMatrix& l) {
  const Eigen::Index k = l.rows();
  SmallMatrix l_inverse = SmallMatrix::Zero(k, k);
  for (Eigen::Index j = 0; j < k; ++j) {
    l_inverse(j, j) = 1 / l(j, j);
    for (Eigen::Index i = j + 1; i < k; ++i) {
      double sum = 0;
      for (Eigen::Index m = j; m < i; ++m) sum += l(i, m) * l_inverse(m, j);
      l_inverse(i, j) = -sum / l(i, i);
    }
  }
  SmallMatrix inverse(k, k);
  for (Eigen::Index a = 0; a < k; ++a)
    for (Eigen::Index b = 0; b <= a; ++b) {
      double sum = 0;
      for (Eigen::Index m = a; m < k; ++m) sum += l_inverse(m, a) * l_inverse(m, b);
      inverse(a, b) = inverse(b, a) = sum;
    }
  return inverse;
}

std::optional<SmallMatrix> plain_inverse(const SmallMatrix& normal) {
  const Eigen::LLT<SmallMatrix> cholesky(normal);
  if (cholesky.info() != Eigen::Success) return std::nullopt;
  const SmallMatrix inverse = inverse_from_cholesky(cholesky.matrixL());
  const double bound = static_cast<double>(normal.rows()) * inverse.trace();
  if (!(bound > 0 && bound * kNullEigenvalue * kCholeskyMargin < 1)) return std::nullopt;
  return inverse;
}

// The pseudo-inverse from the eigen-decomposition, marking the parameters that take part in
// its null space.
SmallMatrix pseudo_inverse(const SmallMatrix& normal, std::vector<bool>& in_null_space) {
  const Eigen::Index k = normal.rows();
  const Eigen::SelfAdjointEigenSolver<SmallMatrix> eigen(normal);
  const auto& values = eigen.eigenvalues();
  const auto& vectors = eigen.eigenvectors();
  const double tiny = values.maxCoeff() * kNullEigenvalue;
  SmallMatrix inverse = SmallMatrix::Zero(k, k);
  for (Eigen::Index e = 0; e < k; ++e) {
    if (values(e) > tiny) {
      inverse += vectors.col(e) * vectors.col(e).transpose() / values(e);
      continue;
    }
    for (Eigen::Index i = 0; i < k; ++i)
      if (vectors(i, e) * vectors(i, e) > 1e-6) in_null_space[static_cast<std::size_t>(i)] = true;
  }
  return inverse;
}

// A derived quantity as a function of the parameters at one point: value, gradient, the
// parameters it depends on, and the range over which it could plausibly vary.
struct Derivation {
  double value = kNaN;
  std::vector<double> gradient;
  std::vector<std::size_t> inputs;
  double range = 1;
  double precision_absolute = 0, precision_relative = 0;
};

// Derived quantities are held to the precision of the extended model's parameter that states them.
Derivation with_precision_of(Derivation d, const ParamSpec& spec) {
  d.precision_absolute = spec.precision_absolute;
  d.precision_relative = spec.precision_relative;
  return d;
}

Derivation oxygen_saturation(ModelKind model, const Params& p) {
  Derivation d;
  d.gradient.assign(p.size(), 0.0);
  if (model == ModelKind::extended) {
    const ParamSpec& spec = model_spec(model).params[kOxygenSaturation];
    d.value = p[kOxygenSaturation];
    d.gradient[kOxygenSaturation] = 1;
    d.inputs = {kOxygenSaturation};
    d.range = spec.upper - spec.lower;
    return with_precision_of(d, spec);
  }
  const double oxy = p[kOxyhemoglobin], deoxy = p[kDeoxyhemoglobin], total = oxy + deoxy;
  d.inputs = {kOxyhemoglobin, kDeoxyhemoglobin};
  if (total > 0) {
    d.value = oxy / total;
    d.gradient[kOxyhemoglobin] = deoxy / (total * total);
    d.gradient[kDeoxyhemoglobin] = -oxy / (total * total);
  }
  return with_precision_of(d, model_spec(ModelKind::extended).params[kOxygenSaturation]);
}

Derivation blood_volume_fraction(ModelKind model, const Params& p) {
  Derivation d;
  d.gradient.assign(p.size(), 0.0);
  const auto params = model_spec(model).params;
  if (model == ModelKind::extended) {
    d.value = kReferenceBloodFraction * p[kTotalHemoglobin];
    d.gradient[kTotalHemoglobin] = kReferenceBloodFraction;
    d.inputs = {kTotalHemoglobin};
    d.range = kReferenceBloodFraction * (params[kTotalHemoglobin].upper - params[kTotalHemoglobin].lower);
  } else {
    d.value = kReferenceBloodFraction * (p[kOxyhemoglobin] + p[kDeoxyhemoglobin]);
    d.gradient[kOxyhemoglobin] = d.gradient[kDeoxyhemoglobin] = kReferenceBloodFraction;
    d.inputs = {kOxyhemoglobin, kDeoxyhemoglobin};
    d.range = kReferenceBloodFraction * (params[kOxyhemoglobin].upper - params[kOxyhemoglobin].lower);
  }
  const ParamSpec& blood = model_spec(ModelKind::extended).params[kTotalHemoglobin];
  d.precision_absolute = kReferenceBloodFraction * blood.precision_absolute;
  d.precision_relative = blood.precision_relative;
  return d;
}

struct Judged {
  std::vector<ParamDetermination> determination;
  SmallMatrix covariance;  // all parameters; NaN rows for those not fitted
};

// The most correlated other parameter of j among `candidates`, and the correlation's size.
std::pair<int, double> most_correlated(const SmallMatrix& c, std::size_t j,
                                       const std::vector<std::size_t>& candidates) {
  std::pair<int, double> best{-1, 0.0};
  for (const std::size_t l : candidates) {
    if (l == j) continue;
    const double rho = std::abs(c(static_cast<Eigen::Index>(j), static_cast<Eigen::Index>(l))) /
                       std::sqrt(c(static_cast<Eigen::Index>(j), static_cast<Eigen::Index>(j)) *
                                 c(static_cast<Eigen::Index>(l), static_cast<Eigen::Index>(l)));
    if (std::isfinite(rho) && rho > best.second) best = {static_cast<int>(l), rho};
  }
  return best;
}

DerivedQuantity derive(const Derivation& d, const Judged& judged) {
  DerivedQuantity q{d.value, kInfinity, Determination::determined};
  const auto status_of = [&](std::size_t i) { return judged.determination[i].status; };
  if (std::ranges::all_of(d.inputs, [&](std::size_t i) { return status_of(i) == Determination::held; })) {
    q.status = Determination::held;
    return q;
  }
  if (std::ranges::any_of(d.inputs, [&](std::size_t i) { return status_of(i) == Determination::at_bound; })) {
    q.status = Determination::at_bound;
    return q;
  }
  double variance = 0;
  for (const std::size_t a : d.inputs)
    for (const std::size_t b : d.inputs)
      if (status_of(a) != Determination::held && status_of(b) != Determination::held)
        variance += d.gradient[a] * d.gradient[b] *
                    judged.covariance(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b));
  const double se = std::sqrt(variance);
  q.standard_error = se;
  if (!std::isfinite(d.value) || !std::isfinite(se) || se > d.range) {
    q.status = Determination::unconstrained;
    return q;
  }
  if (se <= precision(d.precision_absolute, d.precision_relative, d.value)) return q;
  // Correlations among its own inputs are accounted for by the delta method; blame one with a
  // parameter outside them.
  std::vector<std::size_t> others;
  for (std::size_t l = 0; l < judged.determination.size(); ++l)
    if (std::ranges::find(d.inputs, l) == d.inputs.end()) others.push_back(l);
  q.status = Determination::imprecise;
  for (const std::size_t i : d.inputs)
    if (status_of(i) != Determination::held &&
        most_correlated(judged.covariance, i, others).second >= kCorrelationLimit)
      q.status = Determination::correlated;
  return q;
}

}  // namespace

// Columns are scaled to unit norm first so that one threshold tells the null space of J from
// parameters that merely have different units. A pseudo-inverse keeps parameters the data
// cannot see (a dermis hidden by melanin) from poisoning the others: their variance is
// infinite instead.
SmallMatrix parameter_covariance(const Eigen::MatrixXd& jacobian, const std::vector<std::size_t>& free, double cost) {
  const auto n = jacobian.rows(), k = static_cast<Eigen::Index>(free.size());
  SmallMatrix c = SmallMatrix::Constant(k, k, kNaN);
  if (k == 0) return c;
  const double sigma2 = 2 * cost / static_cast<double>(std::max<Eigen::Index>(1, n - k));
  const ScaledNormal s = scaled_normal(jacobian, free);
  std::vector<bool> in_null_space(s.invisible);
  const std::optional<SmallMatrix> plain = plain_inverse(s.normal);
  const SmallMatrix inverse = plain ? *plain : pseudo_inverse(s.normal, in_null_space);
  for (Eigen::Index a = 0; a < k; ++a)
    for (Eigen::Index b = 0; b < k; ++b) {
      const bool unseen = in_null_space[static_cast<std::size_t>(a)] || in_null_space[static_cast<std::size_t>(b)];
      c(a, b) = unseen ? (a == b ? kInfinity : kNaN) : sigma2 * inverse(a, b) / (s.scale(a) * s.scale(b));
    }
  return c;
}

FitUncertainty assess_uncertainty(ModelKind model, const Eigen::MatrixXd& jacobian, double cost, const Params& params,
                                  const std::vector<bool>& held, const std::vector<Pin>& pinned) {
  const auto specs = model_spec(model).params;
  const std::size_t n = params.size();
  Judged judged;
  judged.determination.resize(n);
  // The covariance is taken over every fitted parameter, those on a bound included: a
  // parameter pinned at a bound may be there only because the spectrum cannot place it, and
  // the others' errors must allow for it moving.
  std::vector<std::size_t> free;
  for (std::size_t i = 0; i < n; ++i) {
    if (held[i]) judged.determination[i].status = Determination::held;
    else free.push_back(i);
    if (!held[i] && on_bound(specs[i], params[i], pinned[i])) judged.determination[i].status = Determination::at_bound;
  }
  const SmallMatrix c_free = parameter_covariance(jacobian, free, cost);
  judged.covariance = SmallMatrix::Constant(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(n), kNaN);
  for (std::size_t a = 0; a < free.size(); ++a)
    for (std::size_t b = 0; b < free.size(); ++b)
      judged.covariance(static_cast<Eigen::Index>(free[a]), static_cast<Eigen::Index>(free[b])) =
          c_free(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b));

  FitUncertainty out;
  out.standard_error.assign(n, kInfinity);
  out.correlation.assign(n * n, kNaN);
  // Each parameter's inverse standard deviation taken once: 7 square roots and divisions a fit
  // rather than 49. A variance that is finite and positive correlates with itself exactly 1;
  // one infinite (unseen) or 0 with nothing.
  const auto covariance = [&](std::size_t a, std::size_t b) {
    return judged.covariance(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b));
  };
  std::array<double, kMaxParamCount> inverse_sd{};
  for (const std::size_t a : free) inverse_sd[a] = 1 / std::sqrt(covariance(a, a));
  for (const std::size_t a : free) {
    const double own = covariance(a, a);
    for (const std::size_t b : free)
      out.correlation[a * n + b] =
          a != b ? covariance(a, b) * inverse_sd[a] * inverse_sd[b] : (std::isfinite(own) && own > 0 ? 1.0 : kNaN);
  }
  for (const std::size_t j : free) {
    auto& d = judged.determination[j];
    if (d.status == Determination::at_bound) continue;
    const double se = std::sqrt(judged.covariance(static_cast<Eigen::Index>(j), static_cast<Eigen::Index>(j)));
    out.standard_error[j] = se;
    if (!std::isfinite(se) || se > specs[j].upper - specs[j].lower) {
      d.status = Determination::unconstrained;
      continue;
    }
    if (se <= precision(specs[j].precision_absolute, specs[j].precision_relative, params[j])) continue;
    const auto [other, rho] = most_correlated(judged.covariance, j, free);
    d.status = rho >= kCorrelationLimit ? Determination::correlated : Determination::imprecise;
    if (rho >= kCorrelationLimit) d.correlated_with = other;
  }
  out.determination = judged.determination;
  out.oxygen_saturation = derive(oxygen_saturation(model, params), judged);
  out.blood_volume_fraction = derive(blood_volume_fraction(model, params), judged);
  return out;
}

}  // namespace skinspec::detail
