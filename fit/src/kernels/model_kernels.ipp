// The model's kernels (kernels.hpp): one loop over the samples per evaluation, every step of
// eq. 1 for a sample before the next, rather than one pass over the columns per operation as
// Eigen's expressions made; each loop's body is straight-line code the compiler vectorises for
// the file's instruction set. Included inside each kernel file's anonymous namespace, after
// fast_exp.ipp, so it includes nothing.

// Each iteration reads and writes its own sample only, whichever columns alias: the loops carry
// no dependence, which the compiler cannot see through so many pointers.
#if defined(__GNUC__) && !defined(__clang__)
#define SKINSPEC_INDEPENDENT_ITERATIONS _Pragma("GCC ivdep")
#else
#define SKINSPEC_INDEPENDENT_ITERATIONS
#endif

struct Layer {
  double k, a, b, e1, e, inverse_den, r, t;
};

inline void keep(const Layer& l, const LayerColumnsOut& out, int i) {
  out.k[i] = l.k, out.b[i] = l.b, out.e1[i] = l.e1, out.inverse_den[i] = l.inverse_den, out.r[i] = l.r;
  out.t[i] = l.t;
}

inline Layer kept_layer(const LayerColumnsOut& in, int i) {
  Layer l;
  l.k = in.k[i], l.b = in.b[i], l.e1 = in.e1[i], l.inverse_den = in.inverse_den[i], l.r = in.r[i], l.t = in.t[i];
  l.a = 1.0 + l.k;
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
struct Dermis {
  Layer layer;
  double inverse_S, t_over_1_minus_r, total;
};

inline Dermis dermis_over_white(double K, double S, double D) {
  Dermis d;
  Layer& l = d.layer;
  const double Sb = __builtin_sqrt(K * (K + 2.0 * S));
  l.e1 = fast_exp_of_negative(-(D * Sb));
  l.e = l.e1 * l.e1;
  const double S_den = (S + K) * (1.0 - l.e) + Sb * (1.0 + l.e);
  const double S_den_1_minus_r = K * (1.0 - l.e) + Sb * (1.0 + l.e);
  const double reciprocal = 1.0 / (S * S_den * S_den_1_minus_r);
  d.inverse_S = S_den * S_den_1_minus_r * reciprocal;
  l.k = K * d.inverse_S;
  l.a = 1.0 + l.k;
  l.b = Sb * d.inverse_S;
  l.inverse_den = S * S * S_den_1_minus_r * reciprocal;  // S / (S den)
  l.r = (1.0 - l.e) * l.inverse_den;
  l.t = 2.0 * l.b * l.e1 * l.inverse_den;
  d.t_over_1_minus_r = 2.0 * Sb * l.e1 * S * S_den * reciprocal;  // 2 S b e1 / (S den (1 - R))
  d.total = l.r + l.t * d.t_over_1_minus_r;
  return d;
}

// The epidermis over the rest, X = R + kept T^2 total / q with q = 1 - R total, and 1 / q: with
// den q = (1 - e)(a - total) + b (1 + e). Its first part needs no total, and comes first in the
// loop so that the processor works on it while the dermis's divisions are under way.
struct Epidermis {
  Layer layer;
  double den, inverse_q, under_surface;
};

inline Epidermis epidermis_layer(double K, double S, double inverse_S, double D) {
  Epidermis ep;
  Layer& l = ep.layer;
  l.k = K * inverse_S;
  l.a = 1.0 + l.k;
  l.b = __builtin_sqrt(l.k * (l.k + 2.0));
  l.e1 = fast_exp_of_negative(-(D * S * l.b));
  l.e = l.e1 * l.e1;
  ep.den = l.a * (1.0 - l.e) + l.b * (1.0 + l.e);
  return ep;
}

inline void over_the_dermis(Epidermis& ep, double total, double kept) {
  Layer& l = ep.layer;
  const double den_q = (1.0 - l.e) * (l.a - total) + l.b * (1.0 + l.e);
  const double reciprocal = 1.0 / (ep.den * den_q);
  l.inverse_den = den_q * reciprocal;
  l.r = (1.0 - l.e) * l.inverse_den;
  l.t = 2.0 * l.b * l.e1 * l.inverse_den;
  ep.inverse_q = ep.den * ep.den * reciprocal;
  ep.under_surface = l.r + kept * (l.t * l.t * total * ep.inverse_q);
}

template <bool kLateral, bool kCorneum>
void reflectance_of(const ReflectanceArgs& in) {
  const KeptColumns& out = in.kept;
  const double radius = in.lateral_radius_mm, rs = in.surface_reflectance;
  SKINSPEC_INDEPENDENT_ITERATIONS
  for (int i = 0; i < in.n; ++i) {
    const double epidermis_K = in.epidermis_base_K[i] + in.melanin * in.melanin_K[i];
    const double dermis_K = in.dermis_base_K[i] + in.dermis_weights[0] * in.dermis_absorbers[0][i] +
                            in.dermis_weights[1] * in.dermis_absorbers[1][i] +
                            in.dermis_weights[2] * in.dermis_absorbers[2][i];
    const double dermis_S = in.dermis_S_scale * in.dermis_S_shape[i];
    Epidermis e = epidermis_layer(epidermis_K, in.epidermis_S[i], in.epidermis_inverse_S[i], in.epidermis_mm);
    const Dermis d = dermis_over_white(dermis_K, dermis_S, in.dermis_mm);
    double kept = 1.0;
    if constexpr (kLateral) {
      // lateral_loss of model.hpp: (1 + x) exp(-x) of x = r mu_eff, mu_eff = sqrt(3 mu_a (mu_a + mu_s')).
      const double x = radius * __builtin_sqrt(3.0 * (0.5 * dermis_K) * (0.5 * dermis_K + (4.0 / 3.0) * dermis_S));
      const double lateral_exp = fast_exp_of_negative(-x);
      kept = 1.0 - (1.0 + x) * lateral_exp;
      out.lateral_exp[i] = lateral_exp;
    }
    over_the_dermis(e, d.total, kept);
    keep(e.layer, out.epidermis, i);
    keep(d.layer, out.dermis, i);
    out.dermis_K[i] = dermis_K, out.dermis_S[i] = dermis_S, out.dermis_inverse_S[i] = d.inverse_S;
    out.dermis_t_over_1_minus_r[i] = d.t_over_1_minus_r, out.inverse_q[i] = e.inverse_q;
    double under_surface = e.under_surface;
    if constexpr (kCorneum) {
      // under_stratum_corneum of model.hpp, Y = Rc + Tc^2 X / (1 - Rc X), with dY/dX = Tc^2 / (1 - Rc X)^2.
      const double inverse = 1.0 / (1.0 - in.corneum_r[i] * under_surface);
      const double through = in.corneum_t2[i] * inverse;
      out.corneum_slope[i] = through * inverse;
      under_surface = in.corneum_r[i] + through * under_surface;
    }
    out.total[i] = d.total, out.kept[i] = kept, out.under_surface[i] = under_surface;
    in.reflectance[i] = (1.0 - rs) * under_surface + rs;
  }
}

void reflectance(const ReflectanceArgs& in) {
  const bool lateral = in.lateral_radius_mm > 0, corneum = in.corneum_r != nullptr;
  if (lateral && corneum) reflectance_of<true, true>(in);
  else if (lateral) reflectance_of<true, false>(in);
  else if (corneum) reflectance_of<false, true>(in);
  else reflectance_of<false, false>(in);
}

// A layer's R and T as functions of k and c = D S b, each by one with the other fixed:
// den' = (1 - e) + (a / b)(1 + e) by k, 2 e (a - b) by c. With 1 / b and a / b (db/dk).
struct Slopes {
  double r_k, t_k, r_c, t_c, inverse_b, a_over_b;
};

inline Slopes slopes_of(const Layer& l, double inverse_b) {
  Slopes s;
  s.inverse_b = inverse_b;
  s.a_over_b = l.a * s.inverse_b;
  const double den_k = (1.0 - l.e) + s.a_over_b * (1.0 + l.e);
  const double den_c = 2.0 * l.e * (l.a - l.b);
  s.r_k = -l.r * den_k * l.inverse_den;
  s.t_k = (2.0 * l.e1 * s.a_over_b - l.t * den_k) * l.inverse_den;
  s.r_c = (2.0 * l.e - l.r * den_c) * l.inverse_den;
  s.t_c = -l.t * (1.0 + den_c * l.inverse_den);
  return s;
}

template <bool kLateral, bool kCorneum>
void jacobian_of(const JacobianArgs& in) {
  const KeptColumns& kc = in.kept;
  const double De = in.epidermis_mm, Dd = in.dermis_mm, radius = in.lateral_radius_mm;
  const double one_minus_rs = 1.0 - in.surface_reflectance;
  SKINSPEC_INDEPENDENT_ITERATIONS
  for (int i = 0; i < in.n; ++i) {
    const Layer e = kept_layer(kc.epidermis, i), d = kept_layer(kc.dermis, i);
    const double reciprocal = 1.0 / (e.b * d.b);  // one division for 1 / b of both layers
    const Slopes es = slopes_of(e, d.b * reciprocal), ds = slopes_of(d, e.b * reciprocal);
    const double total = kc.total[i], kept = kc.kept[i], d_inverse_S = kc.dermis_inverse_S[i];
    // The epidermis's R and T by its K: k = K / S and c = D S b(k), so dk/dK = 1 / S and dc/dK = D a / b.
    const double epidermis_r_K = es.r_k * in.epidermis_inverse_S[i] + es.r_c * De * es.a_over_b;
    const double epidermis_t_K = es.t_k * in.epidermis_inverse_S[i] + es.t_c * De * es.a_over_b;
    // The dermis over white, total = R + T^2 / (1 - R), by the dermis's K as above and by its S:
    // dk/dS = -k / S, dc/dS = D k / b.
    const double t_over_1_minus_r = kc.dermis_t_over_1_minus_r[i];
    const double by_r = 1.0 + t_over_1_minus_r * t_over_1_minus_r, by_t = 2.0 * t_over_1_minus_r;
    const double total_K = by_r * (ds.r_k * d_inverse_S + ds.r_c * Dd * ds.a_over_b) +
                           by_t * (ds.t_k * d_inverse_S + ds.t_c * Dd * ds.a_over_b);
    const double total_S = d.k * (by_r * (ds.r_c * Dd * ds.inverse_b - ds.r_k * d_inverse_S) +
                                  by_t * (ds.t_c * Dd * ds.inverse_b - ds.t_k * d_inverse_S));
    // X = Re + kept through, through = Te^2 total / q, q = 1 - Re total: by Re through gains
    // Te^2 total^2 / q^2, by Te 2 Te total / q, by total Te^2 / q^2.
    const double inverse_q = kc.inverse_q[i];
    const double through = e.t * e.t * total * inverse_q;
    const double through_by_total = (e.t * inverse_q) * (e.t * inverse_q);
    double X_eK = epidermis_r_K + kept * (through_by_total * total * total * epidermis_r_K +
                                          2.0 * e.t * total * inverse_q * epidermis_t_K);
    double X_dK = total_K * (kept * through_by_total);
    double X_dS = total_S * (kept * through_by_total);
    if constexpr (kLateral) {
      // kept = 1 - (1 + x) exp(-x), dkept/dx = x exp(-x), x = r mu_eff: by mu_a = K / 2 and
      // mu_s' = 4 S / 3 that is r^2 exp(-x) 3 (2 mu_a + mu_s') / 4 by K and r^2 exp(-x) 2 mu_a by S.
      const double dermis_K = kc.dermis_K[i];
      const double lost_by_x = radius * radius * kc.lateral_exp[i] * through;
      X_dK += lost_by_x * 0.75 * (dermis_K + (4.0 / 3.0) * kc.dermis_S[i]);
      X_dS += lost_by_x * dermis_K;
    }
    if constexpr (kCorneum) {
      const double slope = kc.corneum_slope[i];
      X_eK *= slope;
      X_dK *= slope;
      X_dS *= slope;
    }
    X_dK *= one_minus_rs;
    X_dS *= one_minus_rs;
    in.by_surface[i] = 1.0 - kc.under_surface[i];
    in.by_melanin[i] = one_minus_rs * X_eK * in.melanin_K[i];
    for (int j = 0; j < 3; ++j) in.by_dermis_K[j][i] = X_dK * in.by_dermis_K_factors[j] * in.by_dermis_K_columns[j][i];
    for (int j = 0; j < 2; ++j) in.by_dermis_S[j][i] = X_dS * in.by_dermis_S_factors[j] * in.by_dermis_S_columns[j][i];
  }
}

void jacobian(const JacobianArgs& in) {
  const bool lateral = in.lateral_radius_mm > 0;
  if (lateral && in.stratum_corneum) jacobian_of<true, true>(in);
  else if (lateral) jacobian_of<true, false>(in);
  else if (in.stratum_corneum) jacobian_of<false, true>(in);
  else jacobian_of<false, false>(in);
}

void blood_packing(const BloodPackingArgs& in) {
  const double s = in.saturation, c = in.radius_factor;
  SKINSPEC_INDEPENDENT_ITERATIONS
  for (int i = 0; i < in.n; ++i) {
    const double spread = s * in.oxy_K[i] + (1.0 - s) * in.deoxy_K[i];
    // Where c is 0 there is no packing: packed = spread, d packed / d spread = 1.
    const double x = c * spread;
    const double expm1_minus_x = fast_expm1(-x);
    const bool packs = c > 0;
    in.packed_K[i] = packs ? spread * (-expm1_minus_x / x) : spread;
    in.by_saturation[i] = (packs ? 1.0 + expm1_minus_x : 1.0) * (in.oxy_K[i] - in.deoxy_K[i]);
  }
}

void power_law(const PowerLawArgs& in) {
  SKINSPEC_INDEPENDENT_ITERATIONS
  for (int i = 0; i < in.n; ++i) {
    const double shape = in.amplitude * fast_exp(-in.power * in.log_ratio[i]);
    in.shape[i] = shape;
    in.shape_by_log_ratio[i] = shape * in.log_ratio[i];
  }
}

void exp_of(const double* x, int n, double* out) {
  for (int i = 0; i < n; ++i) out[i] = fast_exp(x[i]);
}

void exp_of_negative_of(const double* x, int n, double* out) {
  for (int i = 0; i < n; ++i) out[i] = fast_exp_of_negative(x[i]);
}

void expm1_of(const double* x, int n, double* out) {
  for (int i = 0; i < n; ++i) out[i] = fast_expm1(x[i]);
}
