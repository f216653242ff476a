#include "spectrum_model.hpp"

#include <algorithm>
#include <atomic>

namespace skinspec::detail {

using Eigen::ArrayXd;

void LayerColumns::resize(Eigen::Index n) {
  for (ArrayXd* column : {&k, &b, &e1, &inverse_den, &r, &t}) column->resize(n);
}

void Workspace::resize(Eigen::Index n) {
  if (total.size() == n) return;
  packing_model = power_law_model = 0;
  epidermis.resize(n);
  dermis.resize(n);
  for (ArrayXd* column : {&dermis_K, &dermis_S, &dermis_inverse_S, &dermis_t_over_1_minus_r, &inverse_q, &total, &kept,
                          &lateral_exp, &under_surface, &corneum_slope, &unused_derivative1, &unused_derivative2,
                          &packed_blood_K, &packed_blood_by_saturation, &scattering_power_law, &power_law_by_log_ratio})
    column->resize(n);
}

namespace {

std::uint64_t next_id() {
  static std::atomic<std::uint64_t> last{0};
  return ++last;
}

LayerColumnsOut pointers_to(LayerColumns& l) {
  return {l.k.data(), l.b.data(), l.e1.data(), l.inverse_den.data(), l.r.data(), l.t.data()};
}

KeptColumns pointers_to(Workspace& w) {
  KeptColumns kept;
  kept.epidermis = pointers_to(w.epidermis), kept.dermis = pointers_to(w.dermis);
  kept.dermis_K = w.dermis_K.data(), kept.dermis_S = w.dermis_S.data();
  kept.dermis_inverse_S = w.dermis_inverse_S.data(), kept.dermis_t_over_1_minus_r = w.dermis_t_over_1_minus_r.data();
  kept.inverse_q = w.inverse_q.data(), kept.total = w.total.data(), kept.kept = w.kept.data();
  kept.lateral_exp = w.lateral_exp.data(), kept.under_surface = w.under_surface.data();
  kept.corneum_slope = w.corneum_slope.data();
  return kept;
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
  if (geometry_.site.stratum_corneum_mm > 0) {
    corneum_r_.resize(n), corneum_t2_.resize(n);
    for (Eigen::Index i = 0; i < n; ++i) {
      const OpticsAt& o = model.optics_at(static_cast<std::size_t>(i));
      corneum_r_(i) = o.corneum_r, corneum_t2_(i) = o.corneum_t2;
    }
  }
}

// Blood packed in vessels at an oxygen saturation (extended_dermis of model.hpp) and the
// scattering's power law at an exponent, each computed again only where its parameter changed.
void SpectrumModel::update_single_parameter_columns(const double* p, Workspace& w) const {
  const int n = static_cast<int>(size());
  const double saturation = p[kOxygenSaturation];
  if (w.packing_model != id_ || w.packing_saturation != saturation) {
    // vessel_packaging of model.hpp: x = 2 mu_a r, mu_a = spread K / the reference blood fraction.
    const double radius_factor = std::max(geometry_.vessel_radius_mm, 0.0) / kReferenceBloodFraction;
    fit_kernels().blood_packing({n, Kh_.data(), Kdh_.data(), saturation, radius_factor, w.packed_blood_K.data(),
                                 w.packed_blood_by_saturation.data()});
    w.packing_model = id_;
    w.packing_saturation = saturation;
  }
  const double exponent = p[kDermisScatteringPower];
  if (w.power_law_model != id_ || w.power_law_exponent != exponent) {
    fit_kernels().power_law({n, log_scattering_ratio_.data(), exponent, kScatteringPerTransport,
                             w.scattering_power_law.data(), w.power_law_by_log_ratio.data()});
    w.power_law_model = id_;
    w.power_law_exponent = exponent;
  }
}

// What the parameters act on (epidermis_layer, paper_dermis and extended_dermis of model.hpp):
// the epidermis's absorption by melanin; the dermis's by the paper's three absorbers, or by
// blood and bilirubin with scattering by a power law in the extended model.
ReflectanceArgs SpectrumModel::reflectance_args(const double* p, Workspace& w, double* reflectance) const {
  ReflectanceArgs args{};
  args.n = static_cast<int>(size());
  args.epidermis_base_K = Ke_.data(), args.melanin_K = Km_.data();
  args.epidermis_S = Se_.data(), args.epidermis_inverse_S = inverse_Se_.data();
  args.melanin = p[kMelanin];
  args.dermis_base_K = Kd_.data();
  if (model_.kind() == ModelKind::paper) {
    args.dermis_absorbers[0] = Kh_.data(), args.dermis_weights[0] = p[kOxyhemoglobin];
    args.dermis_absorbers[1] = Kdh_.data(), args.dermis_weights[1] = p[kDeoxyhemoglobin];
    args.dermis_absorbers[2] = Kb_.data(), args.dermis_weights[2] = p[kBilirubin];
    args.dermis_S_shape = Sd_.data(), args.dermis_S_scale = 1.0;
  } else {
    args.dermis_absorbers[0] = w.packed_blood_K.data(), args.dermis_weights[0] = p[kTotalHemoglobin];
    args.dermis_absorbers[1] = Kb_.data(), args.dermis_weights[1] = p[kBilirubin];
    args.dermis_absorbers[2] = Kb_.data(), args.dermis_weights[2] = 0.0;  // only two absorbers
    args.dermis_S_shape = w.scattering_power_law.data(), args.dermis_S_scale = p[kDermisScattering];
  }
  args.epidermis_mm = geometry_.site.epidermis_mm, args.dermis_mm = geometry_.site.dermis_mm;
  args.lateral_radius_mm = geometry_.lateral_radius_mm;
  args.surface_reflectance = p[kSurfaceReflectance];
  const bool corneum = corneum_r_.size() > 0;
  args.corneum_r = corneum ? corneum_r_.data() : nullptr, args.corneum_t2 = corneum ? corneum_t2_.data() : nullptr;
  args.kept = pointers_to(w);
  args.reflectance = reflectance;
  return args;
}

void SpectrumModel::reflectance(const double* p, Workspace& w, double* reflectance) const {
  w.resize(size());
  if (model_.kind() == ModelKind::extended) update_single_parameter_columns(p, w);
  fit_kernels().reflectance(reflectance_args(p, w, reflectance));
}

// Where each parameter's derivative goes (column-major, size() rows) and what it is made of:
// d/dK of the dermis times d K / d parameter, or d/dS times d S / d parameter.
JacobianArgs SpectrumModel::jacobian_args(const double* p, Workspace& w, double* jacobian) const {
  const auto column = [&](int k) { return jacobian + static_cast<std::ptrdiff_t>(k) * size(); };
  JacobianArgs args{};
  args.n = static_cast<int>(size());
  args.melanin_K = Km_.data(), args.epidermis_inverse_S = inverse_Se_.data();
  args.epidermis_mm = geometry_.site.epidermis_mm, args.dermis_mm = geometry_.site.dermis_mm;
  args.lateral_radius_mm = geometry_.lateral_radius_mm;
  args.surface_reflectance = p[kSurfaceReflectance];
  args.stratum_corneum = corneum_r_.size() > 0;
  args.kept = pointers_to(w);
  args.by_surface = column(kSurfaceReflectance), args.by_melanin = column(kMelanin);
  if (model_.kind() == ModelKind::paper) {
    const double* by_K[] = {Kh_.data(), Kdh_.data(), Kb_.data()};
    const int params[] = {kOxyhemoglobin, kDeoxyhemoglobin, kBilirubin};
    for (int j = 0; j < 3; ++j) {
      args.by_dermis_K_columns[j] = by_K[j], args.by_dermis_K_factors[j] = 1.0, args.by_dermis_K[j] = column(params[j]);
    }
    // The paper's dermis scatters by its constant S: no parameter acts on it.
    args.by_dermis_S_columns[0] = args.by_dermis_S_columns[1] = Sd_.data();
    args.by_dermis_S_factors[0] = args.by_dermis_S_factors[1] = 0.0;
    args.by_dermis_S[0] = w.unused_derivative1.data(), args.by_dermis_S[1] = w.unused_derivative2.data();
    return args;
  }
  // K = Kd + total blood * packed + bilirubin * Kb; S = amplitude * kScatteringPerTransport
  // * exp(-power ln(lambda / pivot)).
  args.by_dermis_K_columns[0] = w.packed_blood_K.data(), args.by_dermis_K_factors[0] = 1.0;
  args.by_dermis_K[0] = column(kTotalHemoglobin);
  args.by_dermis_K_columns[1] = w.packed_blood_by_saturation.data(), args.by_dermis_K_factors[1] = p[kTotalHemoglobin];
  args.by_dermis_K[1] = column(kOxygenSaturation);
  args.by_dermis_K_columns[2] = Kb_.data(), args.by_dermis_K_factors[2] = 1.0, args.by_dermis_K[2] = column(kBilirubin);
  args.by_dermis_S_columns[0] = w.scattering_power_law.data(), args.by_dermis_S_factors[0] = 1.0;
  args.by_dermis_S[0] = column(kDermisScattering);
  args.by_dermis_S_columns[1] = w.power_law_by_log_ratio.data(), args.by_dermis_S_factors[1] = -p[kDermisScattering];
  args.by_dermis_S[1] = column(kDermisScatteringPower);
  return args;
}

void SpectrumModel::jacobian(const double* p, Workspace& w, double* jacobian) const {
  fit_kernels().jacobian(jacobian_args(p, w, jacobian));
}

}  // namespace skinspec::detail
