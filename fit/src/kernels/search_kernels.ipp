// The coarse search's kernel (kernels.hpp, CoarseErrorsArgs), included after model_kernels.ipp
// in kernels.cpp's per-target namespace. The vectors hold samples, and each pair's sum is taken
// in sample order, so that a score differs between targets by rounding alone (fused
// multiply-adds where the target has them) and not by how its lanes were added up.

struct CoarsePair {
  int n;
  const double *epidermis_r, *epidermis_t2, *dermis_total, *dermis_kept, *corneum_r, *corneum_t2;
  double surface_reflectance;
  const double *measured, *weights;
  double* squared;
};

struct CoarseSquaredStep {
  template <class D>
  static HWY_INLINE void at(D d, const CoarsePair& in, std::size_t i) {
    const V<D> one = hn::Set(d, 1.0), rs = hn::Set(d, in.surface_reflectance);
    const V<D> er = hn::LoadU(d, in.epidermis_r + i), total = hn::LoadU(d, in.dermis_total + i);
    const V<D> through_dermis = hn::LoadU(d, in.epidermis_t2 + i) * total / (one - er * total);
    V<D> under = er + hn::LoadU(d, in.dermis_kept + i) * through_dermis;
    if (in.corneum_r != nullptr) {
      const V<D> cr = hn::LoadU(d, in.corneum_r + i);
      under = cr + hn::LoadU(d, in.corneum_t2 + i) * under / (one - cr * under);
    }
    const V<D> r = (one - rs) * under + rs - hn::LoadU(d, in.measured + i);
    hn::StoreU(hn::LoadU(d, in.weights + i) * r * r, d, in.squared + i);
  }
};

void coarse_errors(const CoarseErrorsArgs& in) {
  const std::size_t n = static_cast<std::size_t>(in.n);
  for (int e = 0; e < in.epidermis_levels; ++e)
    for (int level = 0; level < in.dermis_levels; ++level) {
      over_samples<CoarseSquaredStep>(CoarsePair{in.n, in.epidermis_r + e * n, in.epidermis_t2 + e * n,
                                                 in.dermis_total + level * n, in.dermis_kept + level * n, in.corneum_r,
                                                 in.corneum_t2, in.surface_reflectance, in.measured, in.weights,
                                                 in.squared});
      double sum = 0;
      for (std::size_t k = 0; k < n; ++k) sum += in.squared[k];
      in.errors[e * in.dermis_levels + level] = sum;
    }
}
