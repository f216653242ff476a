#include "spectrum_model.hpp"

#include <atomic>

namespace skinspec::detail {

using Eigen::ArrayXd;

void LayerColumns::resize(Eigen::Index n) {
  for (ArrayXd* column : {&inverse_S, &k, &a, &b, &e1, &e, &inverse_den, &r, &t}) column->resize(n);
}

void LayerSlopes::resize(Eigen::Index n) {
  for (ArrayXd* column : {&r_k, &t_k, &r_c, &t_c, &inverse_b, &a_over_b}) column->resize(n);
}

void Workspace::resize(Eigen::Index n) {
  if (total.size() == n) return;
  packing_model = power_law_model = 0;
  epidermis.resize(n);
  dermis.resize(n);
  epidermis_slopes.resize(n);
  dermis_slopes.resize(n);
  for (ArrayXd* column : {&epidermis_K, &dermis_K, &dermis_S, &packed_blood_K, &packing_slope, &scattering_power_law,
                          &total, &kept, &lateral_exp, &under_surface, &scratch1, &scratch2, &scratch3, &scratch4,
                          &scratch5, &scratch6, &scratch7, &scratch8})
    column->resize(n);
}

namespace {

// kubelka_layer of model.hpp at every sample, with l.inverse_S set to 1 / S beforehand (a
// multiplication is cheaper than a division, and the derivatives need 1 / S again).
void kubelka_layer(const ArrayXd& K, const ArrayXd& S, double D, LayerColumns& l) {
  l.k = K * l.inverse_S;
  l.a = 1.0 + l.k;
  l.b = (l.k * (l.k + 2.0)).sqrt();
  l.e1 = (-(D * S * l.b)).exp();
  l.e = l.e1.square();
  l.inverse_den = (l.a * (1.0 - l.e) + l.b * (1.0 + l.e)).inverse();
  l.r = (1.0 - l.e) * l.inverse_den;
  l.t = 2.0 * l.b * l.e1 * l.inverse_den;
}

// LayerSlopes of a layer: den' = (1 - e) + (a / b)(1 + e) by k, 2 e (a - b) by c.
void slopes_of(const LayerColumns& l, LayerSlopes& s) {
  s.inverse_b = l.b.inverse();
  s.a_over_b = l.a * s.inverse_b;
  s.r_k = -l.r * ((1.0 - l.e) + s.a_over_b * (1.0 + l.e)) * l.inverse_den;
  s.t_k = (2.0 * l.e1 * s.a_over_b - l.t * ((1.0 - l.e) + s.a_over_b * (1.0 + l.e))) * l.inverse_den;
  s.r_c = (2.0 * l.e - l.r * (2.0 * l.e * (l.a - l.b))) * l.inverse_den;
  s.t_c = -l.t * (1.0 + 2.0 * l.e * (l.a - l.b) * l.inverse_den);
}

std::uint64_t next_id() {
  static std::atomic<std::uint64_t> last{0};
  return ++last;
}

}  // namespace

SpectrumModel::SpectrumModel(const SkinModel& model) : model_(model), id_(next_id()), geometry_(model.geometry()) {
  const auto n = static_cast<Eigen::Index>(model.size());
  for (ArrayXd* column : {&Ke_, &Se_, &Kd_, &Sd_, &Km_, &Kh_, &Kdh_, &Kb_, &log_scattering_ratio_}) column->resize(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const OpticsAt& o = model.optics_at(static_cast<std::size_t>(i));
    Ke_(i) = o.Ke, Se_(i) = o.Se, Kd_(i) = o.Kd, Sd_(i) = o.Sd, Km_(i) = o.Km, Kh_(i) = o.Kh, Kdh_(i) = o.Kdh;
    Kb_(i) = o.Kb, log_scattering_ratio_(i) = o.log_scattering_ratio;
  }
  inverse_Se_ = Se_.inverse();
}

// What the parameters act on: the epidermis's absorption, the dermis's absorption and
// scattering (epidermis_layer, paper_dermis and extended_dermis of model.hpp).
void SpectrumModel::absorption_and_scattering(const double* p, Workspace& w) const {
  w.epidermis_K = Ke_ + p[kMelanin] * Km_;
  if (model_.kind() == ModelKind::paper) {
    w.dermis_K = Kd_ + p[kOxyhemoglobin] * Kh_ + p[kDeoxyhemoglobin] * Kdh_ + p[kBilirubin] * Kb_;
    w.dermis_S = Sd_;
    return;
  }
  const double saturation = p[kOxygenSaturation];
  if (w.packing_model != id_ || w.packing_saturation != saturation) packed_blood(saturation, w);
  w.dermis_K = Kd_ + p[kTotalHemoglobin] * w.packed_blood_K + p[kBilirubin] * Kb_;
  const double exponent = p[kDermisScatteringPower];
  if (w.power_law_model != id_ || w.power_law_exponent != exponent) {
    w.scattering_power_law = kScatteringPerTransport * (-exponent * log_scattering_ratio_).exp();
    w.power_law_model = id_;
    w.power_law_exponent = exponent;
  }
  w.dermis_S = p[kDermisScattering] * w.scattering_power_law;
}

// Weight 1 of blood at an oxygen saturation, packed in vessels (extended_dermis of model.hpp).
void SpectrumModel::packed_blood(double saturation, Workspace& w) const {
  ArrayXd& spread_K = w.scratch1;  // weight 1 of blood, spread evenly
  spread_K = saturation * Kh_ + (1.0 - saturation) * Kdh_;
  if (geometry_.vessel_radius_mm > 0) {
    // vessel_packaging: packed = spread (1 - exp(-x)) / x, x = 2 mu_a r; d packed / d spread = exp(-x).
    ArrayXd& x = w.scratch2;
    ArrayXd& expm1_minus_x = w.scratch3;
    x = (geometry_.vessel_radius_mm / kReferenceBloodFraction) * spread_K;
    expm1_minus_x = (-x).expm1();
    w.packed_blood_K = spread_K * (-expm1_minus_x / x);
    w.packing_slope = 1.0 + expm1_minus_x;
  } else {
    w.packed_blood_K = spread_K;
    w.packing_slope.setOnes();
  }
  w.packing_model = id_;
  w.packing_saturation = saturation;
}

void SpectrumModel::reflectance(const double* p, Workspace& w, double* reflectance) const {
  w.resize(size());
  absorption_and_scattering(p, w);
  w.epidermis.inverse_S = inverse_Se_;
  kubelka_layer(w.epidermis_K, Se_, geometry_.site.epidermis_mm, w.epidermis);
  w.dermis.inverse_S = w.dermis_S.inverse();
  kubelka_layer(w.dermis_K, w.dermis_S, geometry_.site.dermis_mm, w.dermis);
  w.total = w.dermis.r + w.dermis.t.square() / (1.0 - w.dermis.r);
  const double radius = geometry_.lateral_radius_mm;
  if (radius > 0) {
    // lateral_loss: (1 + x) exp(-x) of x = r mu_eff, mu_eff = sqrt(3 mu_a (mu_a + mu_s')).
    ArrayXd& x = w.scratch1;
    x = radius * (3.0 * (0.5 * w.dermis_K) * (0.5 * w.dermis_K + (4.0 / 3.0) * w.dermis_S)).sqrt();
    w.lateral_exp = (-x).exp();
    w.kept = 1.0 - (1.0 + x) * w.lateral_exp;
  } else {
    w.kept.setOnes();
  }
  const LayerColumns& e = w.epidermis;
  w.under_surface = e.r + w.kept * (e.t.square() * w.total / (1.0 - e.r * w.total));
  const double rs = p[kSurfaceReflectance];
  Eigen::Map<ArrayXd>(reflectance, size()) = (1.0 - rs) * w.under_surface + rs;
}

void SpectrumModel::jacobian(const double* p, Workspace& w, double* jacobian) const {
  const LayerColumns& e = w.epidermis;
  const LayerColumns& d = w.dermis;
  const LayerSlopes& es = w.epidermis_slopes;
  const LayerSlopes& ds = w.dermis_slopes;
  slopes_of(e, w.epidermis_slopes);
  slopes_of(d, w.dermis_slopes);
  const double De = geometry_.site.epidermis_mm, Dd = geometry_.site.dermis_mm;
  const ArrayXd& S = w.dermis_S;

  // The epidermis's R and T by its K: k = K / S and c = D S b(k), so dk/dK = 1 / S and
  // dc/dK = D a / b.
  ArrayXd& epidermis_r_K = w.scratch1;
  ArrayXd& epidermis_t_K = w.scratch2;
  epidermis_r_K = es.r_k * inverse_Se_ + es.r_c * De * es.a_over_b;
  epidermis_t_K = es.t_k * inverse_Se_ + es.t_c * De * es.a_over_b;
  // The dermis over white, total = R + T^2 / (1 - R), by the dermis's K as above and by its S:
  // dk/dS = -k / S, dc/dS = D k / b.
  ArrayXd& t_over_1_minus_r = w.scratch3;
  ArrayXd& total_K = w.scratch4;
  ArrayXd& total_S = w.scratch5;
  t_over_1_minus_r = d.t / (1.0 - d.r);
  total_K = (1.0 + t_over_1_minus_r.square()) * (ds.r_k * d.inverse_S + ds.r_c * Dd * ds.a_over_b) +
            2.0 * t_over_1_minus_r * (ds.t_k * d.inverse_S + ds.t_c * Dd * ds.a_over_b);
  total_S = d.k * ((1.0 + t_over_1_minus_r.square()) * (ds.r_c * Dd * ds.inverse_b - ds.r_k * d.inverse_S) +
                   2.0 * t_over_1_minus_r * (ds.t_c * Dd * ds.inverse_b - ds.t_k * d.inverse_S));
  // X = Re + kept through, through = Te^2 total / q, q = 1 - Re total: by Re through gains
  // Te^2 total^2 / q^2, by Te 2 Te total / q, by total Te^2 / q^2.
  ArrayXd& inverse_q = w.scratch6;
  ArrayXd& through = w.scratch7;
  ArrayXd& through_by_total = w.scratch8;
  inverse_q = (1.0 - e.r * w.total).inverse();
  through = e.t.square() * w.total * inverse_q;
  through_by_total = (e.t * inverse_q).square();
  ArrayXd& X_eK = w.scratch3;  // t_over_1_minus_r is done with
  X_eK = epidermis_r_K + w.kept * (through_by_total * w.total.square() * epidermis_r_K +
                                   2.0 * e.t * w.total * inverse_q * epidermis_t_K);
  ArrayXd& X_dK = total_K;
  ArrayXd& X_dS = total_S;
  X_dK *= w.kept * through_by_total;
  X_dS *= w.kept * through_by_total;
  const double radius = geometry_.lateral_radius_mm;
  if (radius > 0) {
    // kept = 1 - (1 + x) exp(-x), dkept/dx = x exp(-x), x = r mu_eff: by mu_a = K / 2 and
    // mu_s' = 4 S / 3 that is r^2 exp(-x) 3 (2 mu_a + mu_s') / 4 by K and r^2 exp(-x) 2 mu_a by S.
    X_dK += radius * radius * w.lateral_exp * 0.75 * (w.dermis_K + (4.0 / 3.0) * S) * through;
    X_dS += radius * radius * w.lateral_exp * w.dermis_K * through;
  }

  const double rs = p[kSurfaceReflectance];
  Eigen::Map<Eigen::ArrayXXd> J(jacobian, size(), param_count());
  J.col(kSurfaceReflectance) = 1.0 - w.under_surface;
  J.col(kMelanin) = (1.0 - rs) * X_eK * Km_;
  X_dK *= 1.0 - rs;
  X_dS *= 1.0 - rs;
  if (model_.kind() == ModelKind::paper) {
    J.col(kOxyhemoglobin) = X_dK * Kh_;
    J.col(kDeoxyhemoglobin) = X_dK * Kdh_;
    J.col(kBilirubin) = X_dK * Kb_;
    return;
  }
  J.col(kTotalHemoglobin) = X_dK * w.packed_blood_K;
  J.col(kOxygenSaturation) = X_dK * p[kTotalHemoglobin] * w.packing_slope * (Kh_ - Kdh_);
  J.col(kBilirubin) = X_dK * Kb_;
  J.col(kDermisScattering) = X_dS * w.scattering_power_law;
  J.col(kDermisScatteringPower) = -X_dS * S * log_scattering_ratio_;
}

}  // namespace skinspec::detail
