#pragma once
// The fit's arithmetic over every sample (the model, its derivatives, the least squares' QR) as
// kernels over plain columns of doubles (private to fit/). They are written once with Google
// Highway's portable vectors (kernels.cpp) and compiled for each of Highway's targets the build
// attains (on x86-64: AVX-512, AVX2, SSE4 and a portable 128-bit emulation; on ARM: NEON); the
// best one the processor runs is chosen at run time, so the programs run on any processor and
// faster where wider vectors are found.

#include <cstdint>
#include <span>
#include <string>

namespace skinspec::detail {
// A Kubelka layer's columns, kept by the reflectance for the derivatives: k = K / S,
// b = sqrt(k (k + 2)), e1 = exp(-D S b), 1 / den with den = a (1 - e) + b (1 + e) (a = 1 + k,
// e = e1^2), its reflectance R = (1 - e) / den and transmittance T = 2 b e1 / den.
struct LayerColumnsOut {
  double *k, *b, *e1, *inverse_den, *r, *t;
};

// What the reflectance keeps for the derivatives besides the layers.
struct KeptColumns {
  LayerColumnsOut epidermis, dermis;
  double *dermis_K, *dermis_S, *dermis_inverse_S;
  double* dermis_t_over_1_minus_r;  // the dermis's T / (1 - R)
  double* inverse_q;                // 1 / (1 - the epidermis's R times total)
  double* total;                    // the dermis over white: R + T^2 / (1 - R)
  double* kept;                     // its share the instrument sees (1 without lateral diffusion)
  double* lateral_exp;              // exp(-mu_eff r) of that loss (unused without lateral diffusion)
  double* under_surface;            // X of R = (1 - rs) X + rs
  double* corneum_slope;            // dX / d(what the stratum corneum lies over); unused without one
};

// One evaluation of eq. 1 at n samples. The epidermis: K = base + melanin * melanin_K over the
// constant S. The dermis: K = base + the sum of the weighted absorbers, S = scale * shape.
struct ReflectanceArgs {
  int n;
  const double *epidermis_base_K, *melanin_K, *epidermis_S, *epidermis_inverse_S;
  double melanin;
  const double* dermis_base_K;
  const double* dermis_absorbers[3];
  double dermis_weights[3];
  const double* dermis_S_shape;
  double dermis_S_scale;
  double epidermis_mm, dermis_mm, lateral_radius_mm, surface_reflectance;
  // The stratum corneum's reflectance and squared transmittance over the epidermis; null: none.
  const double *corneum_r, *corneum_t2;
  KeptColumns kept;
  double* reflectance;
};

// The derivatives at the point of the last reflectance (whose kept columns they read): by the
// surface reflectance, by melanin, and by up to three parameters the dermis's K depends on and
// two its S depends on. Dermis parameter j's column is (1 - rs) dX/dK * factor_j * column_j
// (dX/dS likewise); a model with fewer points the others at scratch columns.
struct JacobianArgs {
  int n;
  const double *melanin_K, *epidermis_inverse_S;
  double epidermis_mm, dermis_mm, lateral_radius_mm, surface_reflectance;
  bool stratum_corneum;  // whether the reflectance had one (and kept its slope)
  KeptColumns kept;
  const double* by_dermis_K_columns[3];
  double by_dermis_K_factors[3];
  const double* by_dermis_S_columns[2];
  double by_dermis_S_factors[2];
  double *by_surface, *by_melanin;
  double* by_dermis_K[3];
  double* by_dermis_S[2];
};

// Weight 1 of blood at an oxygen saturation, packed in vessels of radius r (the extended model):
// spread = s Kh + (1 - s) Kdh, packed = spread (1 - exp(-x)) / x with x = radius_factor * spread
// (no packing where radius_factor is 0), and d packed / d s = exp(-x) (Kh - Kdh).
struct BloodPackingArgs {
  int n;
  const double *oxy_K, *deoxy_K;
  double saturation, radius_factor;
  double *packed_K, *by_saturation;
};

// The extended model's dermal scattering shape: amplitude * exp(-power * log_ratio), and that
// times log_ratio (for its derivative by the power).
struct PowerLawArgs {
  int n;
  const double* log_ratio;
  double power, amplitude;
  double *shape, *shape_by_log_ratio;
};

// Levenberg-Marquardt's columns to factorise (levenberg_marquardt.cpp, factorize): column j of
// `out` (out_rows rows, column-major) is scales[j] times column columns[j] of `jacobian` (rows
// rows), zero below row `rows`; squared_norms[j] is its squared norm and products[j] the
// unscaled column's product with `residuals`. At most 16 columns.
struct ScaledColumnsArgs {
  const double* jacobian;
  int rows;
  const int* columns;
  int count;
  const double *scales, *residuals;
  double* out;
  int out_rows;
  double *squared_norms, *products;
};

// The coarse search's weighted squared errors (solver.cpp, coarse_starts): for each pair of an
// epidermis level e and a dermis level d, the sum over the n samples, in their order, of
// w (model - measured)^2, with the model the layers combined as combined_reflectance does (model.hpp).
// The epidermis's R and T^2 and the dermis's total and kept share are columns of n samples per
// level, one level after another; `squared` is scratch of n; errors[e * dermis_levels + d].
struct CoarseErrorsArgs {
  int n, epidermis_levels, dermis_levels;
  const double *epidermis_r, *epidermis_t2, *dermis_total, *dermis_kept;
  // The stratum corneum's reflectance and squared transmittance; null: none.
  const double *corneum_r, *corneum_t2;
  double surface_reflectance;
  const double *measured, *weights;
  double *squared, *errors;
};

// The dot products of `count` columns of a column-major Jacobian (`rows` rows): those the
// covariance's normal matrix J^T J is made of, into `out` (count x count, column-major, both
// triangles).
struct NormalMatrixArgs {
  const double* jacobian;
  int rows;
  const int* columns;
  int count;
  double* out;
};

struct FitKernels {
  std::int64_t target;  // Highway's target (HWY_AVX2, ...) the kernels were compiled for
  void (*reflectance)(const ReflectanceArgs&);
  void (*jacobian)(const JacobianArgs&);
  void (*blood_packing)(const BloodPackingArgs&);
  void (*power_law)(const PowerLawArgs&);
  // small_qr.hpp's triangularize.
  void (*triangularize)(double* a, int rows, int cols, double* b);
  void (*scaled_columns)(const ScaledColumnsArgs&);
  void (*normal_matrix)(const NormalMatrixArgs&);
  void (*coarse_errors)(const CoarseErrorsArgs&);
  // The exp and expm1 the kernels use (Highway's), element by element, for the tests.
  void (*exp)(const double* x, int n, double* out);
  void (*expm1)(const double* x, int n, double* out);
};

// The kernels of every target this build compiled that the processor runs, best first.
std::span<const FitKernels* const> runnable_fit_kernels();

// The kernels in use: the best the processor runs, unless the environment variable
// SKINSPEC_FIT_KERNELS names another it runs (so that the tests check every target on one
// machine, and a processor slower with 512-bit vectors can be kept on AVX2).
const FitKernels& fit_kernels();

// A target's name as SKINSPEC_FIT_KERNELS takes it: Highway's, in lower case ("avx3" for
// AVX-512, "avx2", "sse4", "emu128", "neon").
std::string kernels_name(const FitKernels& kernels);

// Switches the kernels in use, for the tests, which run every target in one process; one of
// runnable_fit_kernels().
void use_fit_kernels(const FitKernels& kernels);

}  // namespace skinspec::detail
