// The fit's kernels alone (fit/src/kernels/), called through the table in use, on 101 samples
// (the PR-650's grid) of plausible columns: the reflectance with and without the lateral loss,
// its Jacobian, the blood packing, the scattering's power law and a 101 x 7 QR. With
// SKINSPEC_FIT_KERNELS naming a Highway target, that target's kernels are timed.

#include <benchmark/benchmark.h>

#include <deque>
#include <random>
#include <string>
#include <vector>

#include "kernels/kernels.hpp"  // fit/src

namespace skinspec {
namespace {

using namespace detail;

constexpr int kSamples = 101;

// Columns of kSamples values in (0.1, 1), each kept where it was made.
class Columns {
 public:
  double* next() {
    std::uniform_real_distribution<double> value(0.1, 1.0);
    auto& column = columns_.emplace_back(kSamples);
    for (double& x : column) x = value(random_);
    return column.data();
  }
  LayerColumnsOut layer() { return {next(), next(), next(), next(), next(), next()}; }

 private:
  std::mt19937 random_{1};
  std::deque<std::vector<double>> columns_;
};

// An evaluation of the model's reflectance and what its Jacobian needs, on made-up columns.
struct Evaluation {
  Columns columns;
  ReflectanceArgs reflectance{};
  JacobianArgs jacobian{};

  explicit Evaluation(double lateral_radius_mm) {
    ReflectanceArgs& r = reflectance;
    r.n = kSamples;
    r.epidermis_base_K = columns.next(), r.melanin_K = columns.next();
    double* epidermis_S = columns.next();
    double* inverse_S = columns.next();
    for (int i = 0; i < kSamples; ++i) inverse_S[i] = 1 / epidermis_S[i];
    r.epidermis_S = epidermis_S, r.epidermis_inverse_S = inverse_S;
    r.melanin = 3;
    r.dermis_base_K = columns.next();
    for (auto& absorber : r.dermis_absorbers) absorber = columns.next();
    r.dermis_weights[0] = 0.01, r.dermis_weights[1] = 0.02, r.dermis_weights[2] = 0;
    r.dermis_S_shape = columns.next(), r.dermis_S_scale = 20;
    r.epidermis_mm = 0.06, r.dermis_mm = 1.5, r.lateral_radius_mm = lateral_radius_mm, r.surface_reflectance = 0.04;
    KeptColumns& k = r.kept;
    k.epidermis = columns.layer(), k.dermis = columns.layer();
    for (double** column : {&k.dermis_K, &k.dermis_S, &k.dermis_inverse_S, &k.dermis_t_over_1_minus_r, &k.inverse_q,
                            &k.total, &k.kept, &k.lateral_exp, &k.under_surface, &k.corneum_slope})
      *column = columns.next();
    r.reflectance = columns.next();

    JacobianArgs& j = jacobian;
    j.n = kSamples;
    j.melanin_K = r.melanin_K, j.epidermis_inverse_S = r.epidermis_inverse_S;
    j.epidermis_mm = r.epidermis_mm, j.dermis_mm = r.dermis_mm, j.lateral_radius_mm = lateral_radius_mm;
    j.surface_reflectance = r.surface_reflectance, j.kept = r.kept;
    for (int c = 0; c < 3; ++c)
      j.by_dermis_K_columns[c] = r.dermis_absorbers[c], j.by_dermis_K_factors[c] = 1, j.by_dermis_K[c] = columns.next();
    for (int c = 0; c < 2; ++c)
      j.by_dermis_S_columns[c] = r.dermis_S_shape, j.by_dermis_S_factors[c] = 1, j.by_dermis_S[c] = columns.next();
    j.by_surface = columns.next(), j.by_melanin = columns.next();
    fit_kernels().reflectance(reflectance);  // the kept columns the Jacobian reads
  }
};

// Times `call` (one kernel call, returning a value it wrote), labelled with the target in use.
template <class Call>
void time_kernel(benchmark::State& state, Call call) {
  for (auto _ : state) benchmark::DoNotOptimize(call());
  state.SetLabel(kernels_name(fit_kernels()));
}

double lateral_radius_mm(const benchmark::State& state) { return state.range(0) == 1 ? 0.5 : 0.0; }

void Reflectance(benchmark::State& state) {
  Evaluation e(lateral_radius_mm(state));
  time_kernel(state, [&] { return fit_kernels().reflectance(e.reflectance), e.reflectance.reflectance[0]; });
}
BENCHMARK(Reflectance)->ArgName("lateral")->Arg(0)->Arg(1);

void Jacobian(benchmark::State& state) {
  Evaluation e(lateral_radius_mm(state));
  time_kernel(state, [&] { return fit_kernels().jacobian(e.jacobian), e.jacobian.by_melanin[0]; });
}
BENCHMARK(Jacobian)->ArgName("lateral")->Arg(0)->Arg(1);

void BloodPacking(benchmark::State& state) {
  Columns columns;
  const BloodPackingArgs args{kSamples, columns.next(), columns.next(), 0.7, 0.3, columns.next(), columns.next()};
  time_kernel(state, [&] { return fit_kernels().blood_packing(args), args.packed_K[0]; });
}
BENCHMARK(BloodPacking);

void PowerLaw(benchmark::State& state) {
  Columns columns;
  const PowerLawArgs args{kSamples, columns.next(), 1.3, 20, columns.next(), columns.next()};
  time_kernel(state, [&] { return fit_kernels().power_law(args), args.shape[0]; });
}
BENCHMARK(PowerLaw);

void Triangularize(benchmark::State& state) {
  constexpr int kColumns = 7;
  const auto rows = static_cast<int>(state.range(0));
  Columns columns;
  const double* right_side = columns.next();
  std::vector<double> a, b(right_side, right_side + rows);
  for (int c = 0; c < kColumns; ++c) {
    const double* column = columns.next();
    a.insert(a.end(), column, column + rows);
  }
  time_kernel(state, [&] {
    std::vector<double> work_a = a, work_b = b;
    fit_kernels().triangularize(work_a.data(), rows, kColumns, work_b.data());
    return work_b[0];
  });
}
// A spectrum's samples, and the 14 rows of a Levenberg-Marquardt step's damped system (R over
// the damping's diagonal).
BENCHMARK(Triangularize)->ArgName("rows")->Arg(kSamples)->Arg(14);

}  // namespace
}  // namespace skinspec

BENCHMARK_MAIN();
