// The model's kernels (kernels.hpp): one loop over the samples per evaluation, every step of
// eq. 1 for a vector of samples before the next, rather than one pass over the columns per
// operation as Eigen's expressions made. Included inside kernels.cpp's per-target namespace,
// where `hn` is Highway's namespace for the target, so it includes nothing.
//
// Each step is a template on Highway's descriptor D: the loops take whole vectors, then the
// samples left over one at a time through a one-lane descriptor, the same code either way.

template <class D>
using V = hn::Vec<D>;

// Runs Step::at(d, in, i) over the samples [0, in.n): whole vectors, then one lane at a time.
// The steps read their arguments through a local copy: the arguments' scalars and column
// pointers could otherwise be changed by any store to a column, as far as the compiler can
// tell, and would be loaded again after each one.
template <class Step, class Args>
HWY_INLINE void over_samples(const Args& arguments) {
  const Args in = arguments;
  const hn::ScalableTag<double> d;
  const std::size_t n = static_cast<std::size_t>(in.n), lanes = hn::Lanes(d);
  std::size_t i = 0;
  for (; i + lanes <= n; i += lanes) Step::at(d, in, i);
  const hn::CappedTag<double, 1> one_lane;
  for (; i < n; ++i) Step::at(one_lane, in, i);
}

template <class D>
struct Layer {
  V<D> k, a, b, e1, e, inverse_den, r, t;
};

template <class D>
HWY_INLINE void keep(D d, const Layer<D>& l, const LayerColumnsOut& out, std::size_t i) {
  hn::StoreU(l.k, d, out.k + i), hn::StoreU(l.b, d, out.b + i), hn::StoreU(l.e1, d, out.e1 + i);
  hn::StoreU(l.inverse_den, d, out.inverse_den + i), hn::StoreU(l.r, d, out.r + i), hn::StoreU(l.t, d, out.t + i);
}

template <class D>
HWY_INLINE Layer<D> kept_layer(D d, const LayerColumnsOut& in, std::size_t i) {
  Layer<D> l;
  l.k = hn::LoadU(d, in.k + i), l.b = hn::LoadU(d, in.b + i), l.e1 = hn::LoadU(d, in.e1 + i);
  l.inverse_den = hn::LoadU(d, in.inverse_den + i), l.r = hn::LoadU(d, in.r + i), l.t = hn::LoadU(d, in.t + i);
  l.a = hn::Set(d, 1.0) + l.k;
  l.e = l.e1 * l.e1;
  return l;
}

// Divisions and square roots take the longest of a sample's arithmetic and share one unit of
// the processor, so each layer below divides once: the quotients it needs are products of one
// reciprocal with the other factors of the denominator, 1/x = y (1/(x y)). Otherwise the
// formulas are kubelka_layer's and combined_reflectance's of model.hpp.

// The dermis over white, total = R + T^2 / (1 - R), with its 1 / S. In terms of S times
// Kubelka's quantities, which need no division: S b = sqrt(K (K + 2 S)), S den = (S + K)(1 - e)
// + S b (1 + e), and S den (1 - R) = K (1 - e) + S b (1 + e).
template <class D>
struct Dermis {
  Layer<D> layer;
  V<D> inverse_S, t_over_1_minus_r, total;
};

template <class D>
HWY_INLINE Dermis<D> dermis_over_white(D d, V<D> K, V<D> S, V<D> depth) {
  const V<D> one = hn::Set(d, 1.0), two = hn::Set(d, 2.0);
  Dermis<D> dermis;
  Layer<D>& l = dermis.layer;
  const V<D> Sb = hn::Sqrt(K * (K + two * S));
  l.e1 = hn::Exp(d, hn::Neg(depth * Sb));
  l.e = l.e1 * l.e1;
  const V<D> S_den = (S + K) * (one - l.e) + Sb * (one + l.e);
  const V<D> S_den_1_minus_r = K * (one - l.e) + Sb * (one + l.e);
  const V<D> reciprocal = one / (S * S_den * S_den_1_minus_r);
  dermis.inverse_S = S_den * S_den_1_minus_r * reciprocal;
  l.k = K * dermis.inverse_S;
  l.a = one + l.k;
  l.b = Sb * dermis.inverse_S;
  l.inverse_den = S * S * S_den_1_minus_r * reciprocal;  // S / (S den)
  l.r = (one - l.e) * l.inverse_den;
  l.t = two * l.b * l.e1 * l.inverse_den;
  dermis.t_over_1_minus_r = two * Sb * l.e1 * S * S_den * reciprocal;  // 2 S b e1 / (S den (1 - R))
  dermis.total = l.r + l.t * dermis.t_over_1_minus_r;
  return dermis;
}

// The epidermis over the rest, X = R + kept T^2 total / q with q = 1 - R total, and 1 / q: with
// den q = (1 - e)(a - total) + b (1 + e). Its first part needs no total, and comes first in the
// loop so that the processor works on it while the dermis's divisions are under way.
template <class D>
struct Epidermis {
  Layer<D> layer;
  V<D> den, inverse_q, under_surface;
};

template <class D>
HWY_INLINE Epidermis<D> epidermis_layer(D d, V<D> K, V<D> S, V<D> inverse_S, V<D> depth) {
  const V<D> one = hn::Set(d, 1.0);
  Epidermis<D> epidermis;
  Layer<D>& l = epidermis.layer;
  l.k = K * inverse_S;
  l.a = one + l.k;
  l.b = hn::Sqrt(l.k * (l.k + hn::Set(d, 2.0)));
  l.e1 = hn::Exp(d, hn::Neg(depth * S * l.b));
  l.e = l.e1 * l.e1;
  epidermis.den = l.a * (one - l.e) + l.b * (one + l.e);
  return epidermis;
}

template <class D>
HWY_INLINE void over_the_dermis(D d, Epidermis<D>& epidermis, V<D> total, V<D> kept) {
  const V<D> one = hn::Set(d, 1.0);
  Layer<D>& l = epidermis.layer;
  const V<D> den_q = (one - l.e) * (l.a - total) + l.b * (one + l.e);
  const V<D> reciprocal = one / (epidermis.den * den_q);
  l.inverse_den = den_q * reciprocal;
  l.r = (one - l.e) * l.inverse_den;
  l.t = hn::Set(d, 2.0) * l.b * l.e1 * l.inverse_den;
  epidermis.inverse_q = epidermis.den * epidermis.den * reciprocal;
  epidermis.under_surface = l.r + kept * (l.t * l.t * total * epidermis.inverse_q);
}

// The dermis's K: its base plus the weighted absorbers.
template <class D>
HWY_INLINE V<D> dermis_K_at(D d, const double* base, const double* const absorbers[3], const double weights[3],
                            std::size_t i) {
  V<D> K = hn::LoadU(d, base + i);
  for (int j = 0; j < 3; ++j) K = hn::MulAdd(hn::Set(d, weights[j]), hn::LoadU(d, absorbers[j] + i), K);
  return K;
}

template <bool kLateral, bool kCorneum>
struct ReflectanceStep {
  template <class D>
  static HWY_INLINE void at(D d, const ReflectanceArgs& in, std::size_t i) {
    const KeptColumns& out = in.kept;
    const V<D> one = hn::Set(d, 1.0);
    const V<D> epidermis_K = hn::MulAdd(hn::Set(d, in.melanin), hn::LoadU(d, in.melanin_K + i),
                                        hn::LoadU(d, in.epidermis_base_K + i));
    const V<D> dermis_K = dermis_K_at(d, in.dermis_base_K, in.dermis_absorbers, in.dermis_weights, i);
    const V<D> dermis_S = hn::Set(d, in.dermis_S_scale) * hn::LoadU(d, in.dermis_S_shape + i);
    Epidermis<D> e = epidermis_layer(d, epidermis_K, hn::LoadU(d, in.epidermis_S + i),
                                     hn::LoadU(d, in.epidermis_inverse_S + i), hn::Set(d, in.epidermis_mm));
    const Dermis<D> dermis = dermis_over_white(d, dermis_K, dermis_S, hn::Set(d, in.dermis_mm));
    V<D> kept = one;
    if constexpr (kLateral) {
      // lateral_loss of model.hpp: (1 + x) exp(-x) of x = r mu_eff, mu_eff = sqrt(3 mu_a (mu_a + mu_s')).
      const V<D> mu_a = hn::Set(d, 0.5) * dermis_K;
      const V<D> mu_s = hn::Set(d, 4.0 / 3.0) * dermis_S;
      const V<D> x = hn::Set(d, in.lateral_radius_mm) * hn::Sqrt(hn::Set(d, 3.0) * mu_a * (mu_a + mu_s));
      const V<D> lateral_exp = hn::Exp(d, hn::Neg(x));
      kept = one - (one + x) * lateral_exp;
      hn::StoreU(lateral_exp, d, out.lateral_exp + i);
    }
    over_the_dermis(d, e, dermis.total, kept);
    keep(d, e.layer, out.epidermis, i);
    keep(d, dermis.layer, out.dermis, i);
    hn::StoreU(dermis_K, d, out.dermis_K + i), hn::StoreU(dermis_S, d, out.dermis_S + i);
    hn::StoreU(dermis.inverse_S, d, out.dermis_inverse_S + i);
    hn::StoreU(dermis.t_over_1_minus_r, d, out.dermis_t_over_1_minus_r + i);
    hn::StoreU(e.inverse_q, d, out.inverse_q + i);
    V<D> under_surface = e.under_surface;
    if constexpr (kCorneum) {
      // under_stratum_corneum of model.hpp, Y = Rc + Tc^2 X / (1 - Rc X), with dY/dX = Tc^2 / (1 - Rc X)^2.
      const V<D> corneum_r = hn::LoadU(d, in.corneum_r + i);
      const V<D> inverse = one / (one - corneum_r * under_surface);
      const V<D> through = hn::LoadU(d, in.corneum_t2 + i) * inverse;
      hn::StoreU(through * inverse, d, out.corneum_slope + i);
      under_surface = corneum_r + through * under_surface;
    }
    hn::StoreU(dermis.total, d, out.total + i), hn::StoreU(kept, d, out.kept + i);
    hn::StoreU(under_surface, d, out.under_surface + i);
    const V<D> rs = hn::Set(d, in.surface_reflectance);
    hn::StoreU((one - rs) * under_surface + rs, d, in.reflectance + i);
  }
};

void reflectance(const ReflectanceArgs& in) {
  const bool lateral = in.lateral_radius_mm > 0, corneum = in.corneum_r != nullptr;
  if (lateral && corneum) over_samples<ReflectanceStep<true, true>>(in);
  else if (lateral) over_samples<ReflectanceStep<true, false>>(in);
  else if (corneum) over_samples<ReflectanceStep<false, true>>(in);
  else over_samples<ReflectanceStep<false, false>>(in);
}

// A layer's R and T as functions of k and c = D S b, each by one with the other fixed:
// den' = (1 - e) + (a / b)(1 + e) by k, 2 e (a - b) by c. With 1 / b and a / b (db/dk).
template <class D>
struct Slopes {
  V<D> r_k, t_k, r_c, t_c, inverse_b, a_over_b;
};

template <class D>
HWY_INLINE Slopes<D> slopes_of(D d, const Layer<D>& l, V<D> inverse_b) {
  const V<D> one = hn::Set(d, 1.0), two = hn::Set(d, 2.0);
  Slopes<D> s;
  s.inverse_b = inverse_b;
  s.a_over_b = l.a * s.inverse_b;
  const V<D> den_k = (one - l.e) + s.a_over_b * (one + l.e);
  const V<D> den_c = two * l.e * (l.a - l.b);
  s.r_k = hn::Neg(l.r) * den_k * l.inverse_den;
  s.t_k = (two * l.e1 * s.a_over_b - l.t * den_k) * l.inverse_den;
  s.r_c = (two * l.e - l.r * den_c) * l.inverse_den;
  s.t_c = hn::Neg(l.t) * (one + den_c * l.inverse_den);
  return s;
}

template <bool kLateral, bool kCorneum>
struct JacobianStep {
  template <class D>
  static HWY_INLINE void at(D d, const JacobianArgs& in, std::size_t i) {
    const KeptColumns& kc = in.kept;
    const V<D> one = hn::Set(d, 1.0), two = hn::Set(d, 2.0);
    const V<D> De = hn::Set(d, in.epidermis_mm), Dd = hn::Set(d, in.dermis_mm);
    const Layer<D> e = kept_layer(d, kc.epidermis, i), dermis = kept_layer(d, kc.dermis, i);
    const V<D> reciprocal = one / (e.b * dermis.b);  // one division for 1 / b of both layers
    const Slopes<D> es = slopes_of(d, e, dermis.b * reciprocal), ds = slopes_of(d, dermis, e.b * reciprocal);
    const V<D> total = hn::LoadU(d, kc.total + i), kept = hn::LoadU(d, kc.kept + i);
    const V<D> d_inverse_S = hn::LoadU(d, kc.dermis_inverse_S + i);
    const V<D> e_inverse_S = hn::LoadU(d, in.epidermis_inverse_S + i);
    // The epidermis's R and T by its K: k = K / S and c = D S b(k), so dk/dK = 1 / S and dc/dK = D a / b.
    const V<D> epidermis_r_K = es.r_k * e_inverse_S + es.r_c * De * es.a_over_b;
    const V<D> epidermis_t_K = es.t_k * e_inverse_S + es.t_c * De * es.a_over_b;
    // The dermis over white, total = R + T^2 / (1 - R), by the dermis's K as above and by its S:
    // dk/dS = -k / S, dc/dS = D k / b.
    const V<D> t_over_1_minus_r = hn::LoadU(d, kc.dermis_t_over_1_minus_r + i);
    const V<D> by_r = one + t_over_1_minus_r * t_over_1_minus_r, by_t = two * t_over_1_minus_r;
    const V<D> total_K = by_r * (ds.r_k * d_inverse_S + ds.r_c * Dd * ds.a_over_b) +
                         by_t * (ds.t_k * d_inverse_S + ds.t_c * Dd * ds.a_over_b);
    const V<D> total_S = dermis.k * (by_r * (ds.r_c * Dd * ds.inverse_b - ds.r_k * d_inverse_S) +
                                     by_t * (ds.t_c * Dd * ds.inverse_b - ds.t_k * d_inverse_S));
    // X = Re + kept through, through = Te^2 total / q, q = 1 - Re total: by Re through gains
    // Te^2 total^2 / q^2, by Te 2 Te total / q, by total Te^2 / q^2.
    const V<D> inverse_q = hn::LoadU(d, kc.inverse_q + i);
    const V<D> through = e.t * e.t * total * inverse_q;
    const V<D> through_by_total = (e.t * inverse_q) * (e.t * inverse_q);
    V<D> X_eK = epidermis_r_K + kept * (through_by_total * total * total * epidermis_r_K +
                                        two * e.t * total * inverse_q * epidermis_t_K);
    V<D> X_dK = total_K * (kept * through_by_total);
    V<D> X_dS = total_S * (kept * through_by_total);
    if constexpr (kLateral) {
      // kept = 1 - (1 + x) exp(-x), dkept/dx = x exp(-x), x = r mu_eff: by mu_a = K / 2 and
      // mu_s' = 4 S / 3 that is r^2 exp(-x) 3 (2 mu_a + mu_s') / 4 by K and r^2 exp(-x) 2 mu_a by S.
      const V<D> dermis_K = hn::LoadU(d, kc.dermis_K + i);
      const V<D> radius = hn::Set(d, in.lateral_radius_mm);
      const V<D> lost_by_x = radius * radius * hn::LoadU(d, kc.lateral_exp + i) * through;
      X_dK = X_dK + lost_by_x * hn::Set(d, 0.75) * (dermis_K + hn::Set(d, 4.0 / 3.0) * hn::LoadU(d, kc.dermis_S + i));
      X_dS = X_dS + lost_by_x * dermis_K;
    }
    if constexpr (kCorneum) {
      const V<D> slope = hn::LoadU(d, kc.corneum_slope + i);
      X_eK = X_eK * slope, X_dK = X_dK * slope, X_dS = X_dS * slope;
    }
    const V<D> one_minus_rs = hn::Set(d, 1.0 - in.surface_reflectance);
    X_dK = X_dK * one_minus_rs, X_dS = X_dS * one_minus_rs;
    hn::StoreU(one - hn::LoadU(d, kc.under_surface + i), d, in.by_surface + i);
    hn::StoreU(one_minus_rs * X_eK * hn::LoadU(d, in.melanin_K + i), d, in.by_melanin + i);
    for (int j = 0; j < 3; ++j)
      hn::StoreU(X_dK * hn::Set(d, in.by_dermis_K_factors[j]) * hn::LoadU(d, in.by_dermis_K_columns[j] + i), d,
                 in.by_dermis_K[j] + i);
    for (int j = 0; j < 2; ++j)
      hn::StoreU(X_dS * hn::Set(d, in.by_dermis_S_factors[j]) * hn::LoadU(d, in.by_dermis_S_columns[j] + i), d,
                 in.by_dermis_S[j] + i);
  }
};

void jacobian(const JacobianArgs& in) {
  const bool lateral = in.lateral_radius_mm > 0;
  if (lateral && in.stratum_corneum) over_samples<JacobianStep<true, true>>(in);
  else if (lateral) over_samples<JacobianStep<true, false>>(in);
  else if (in.stratum_corneum) over_samples<JacobianStep<false, true>>(in);
  else over_samples<JacobianStep<false, false>>(in);
}

struct BloodPackingStep {
  template <class D>
  static HWY_INLINE void at(D d, const BloodPackingArgs& in, std::size_t i) {
    const V<D> oxy = hn::LoadU(d, in.oxy_K + i), deoxy = hn::LoadU(d, in.deoxy_K + i);
    const V<D> s = hn::Set(d, in.saturation);
    const V<D> spread = s * oxy + (hn::Set(d, 1.0) - s) * deoxy;
    if (in.radius_factor > 0) {
      const V<D> x = hn::Set(d, in.radius_factor) * spread;
      const V<D> expm1_minus_x = hn::Expm1(d, hn::Neg(x));
      hn::StoreU(spread * (hn::Neg(expm1_minus_x) / x), d, in.packed_K + i);
      hn::StoreU((hn::Set(d, 1.0) + expm1_minus_x) * (oxy - deoxy), d, in.by_saturation + i);
    } else {
      // No packing: packed = spread, d packed / d spread = 1.
      hn::StoreU(spread, d, in.packed_K + i);
      hn::StoreU(oxy - deoxy, d, in.by_saturation + i);
    }
  }
};

void blood_packing(const BloodPackingArgs& in) { over_samples<BloodPackingStep>(in); }

struct PowerLawStep {
  template <class D>
  static HWY_INLINE void at(D d, const PowerLawArgs& in, std::size_t i) {
    const V<D> log_ratio = hn::LoadU(d, in.log_ratio + i);
    const V<D> shape = hn::Set(d, in.amplitude) * hn::Exp(d, hn::Neg(hn::Set(d, in.power) * log_ratio));
    hn::StoreU(shape, d, in.shape + i);
    hn::StoreU(shape * log_ratio, d, in.shape_by_log_ratio + i);
  }
};

void power_law(const PowerLawArgs& in) { over_samples<PowerLawStep>(in); }

// Element by element, for the tests.
struct ExpArgs {
  const double* x;
  int n;
  double* out;
};

struct ExpStep {
  template <class D>
  static HWY_INLINE void at(D d, const ExpArgs& in, std::size_t i) {
    hn::StoreU(hn::Exp(d, hn::LoadU(d, in.x + i)), d, in.out + i);
  }
};

struct Expm1Step {
  template <class D>
  static HWY_INLINE void at(D d, const ExpArgs& in, std::size_t i) {
    hn::StoreU(hn::Expm1(d, hn::LoadU(d, in.x + i)), d, in.out + i);
  }
};

void exp_of(const double* x, int n, double* out) { over_samples<ExpStep>(ExpArgs{x, n, out}); }
void expm1_of(const double* x, int n, double* out) { over_samples<Expm1Step>(ExpArgs{x, n, out}); }
