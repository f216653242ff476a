// SkinModel::reflectance_and_gradient: the derivatives taken through what the parameters act
// on rather than through every parameter. The layers see only the epidermis's absorption, the
// dermis's absorption and the dermis's scattering, so the layered equations carry at most three
// derivatives, not one per parameter, and the chain rule to the parameters is a few products:
// a fraction of the work of differentiating by parameter, with the same derivatives to
// rounding (tests/fit/model_test.cpp checks them against automatic differentiation).

#include <ceres/jet.h>

#include "skinspec/fit/model.hpp"

namespace skinspec {

namespace {

// Derivatives with respect to the epidermis's absorption, the dermis's absorption and the
// dermis's scattering, in that order. Each layer carries only its own: the epidermis one, the
// dermis two, and they meet in three where the layers combine.
using LayerJet = ceres::Jet<double, 3>;
enum LayerInput { kEpidermisK, kDermisK, kDermisS };
using EpidermisJet = ceres::Jet<double, 1>;
using DermisJet = ceres::Jet<double, 2>;

LayerJet from_epidermis(const EpidermisJet& x) {
  LayerJet out(x.a);
  out.v[kEpidermisK] = x.v[0];
  return out;
}

LayerJet from_dermis(const DermisJet& x) {
  LayerJet out(x.a);
  out.v[kDermisK] = x.v[0];
  out.v[kDermisS] = x.v[1];
  return out;
}

// The reflectance under the surface, R = (1 - rs) X + rs, and X's three derivatives.
[[gnu::flatten]] LayerJet under_surface(const Geometry& g, const OpticsAt& o, double epidermis_K, double dermis_K,
                                        double dermis_S) {
  const auto epidermis = kubelka_layer(EpidermisJet(epidermis_K, 0), o.Se, g.site.epidermis_mm);
  const auto dermis = dermis_remittance(DermisJet(dermis_K, 0), DermisJet(dermis_S, 1), g);
  return combined_reflectance(o, LayerJet(0.0), {from_epidermis(epidermis.r), from_epidermis(epidermis.t)},
                              {from_dermis(dermis.total), from_dermis(dermis.kept)});
}

double paper(const SkinModel& model, std::size_t i, const double* p, double* gradient) {
  const OpticsAt& o = model.optics_at(i);
  const double epidermis_K = o.Ke + p[kMelanin] * o.Km;
  const double dermis_K = o.Kd + p[kOxyhemoglobin] * o.Kh + p[kDeoxyhemoglobin] * o.Kdh + p[kBilirubin] * o.Kb;
  const LayerJet x = under_surface(model.geometry(), o, epidermis_K, dermis_K, o.Sd);
  const double rs = p[kSurfaceReflectance];
  if (gradient != nullptr) {
    const double dk = (1 - rs) * x.v[kDermisK];
    gradient[kSurfaceReflectance] = 1 - x.a;
    gradient[kMelanin] = (1 - rs) * x.v[kEpidermisK] * o.Km;
    gradient[kOxyhemoglobin] = dk * o.Kh;
    gradient[kDeoxyhemoglobin] = dk * o.Kdh;
    gradient[kBilirubin] = dk * o.Kb;
  }
  return (1 - rs) * x.a + rs;
}

double extended(const SkinModel& model, std::size_t i, const double* p, double* gradient) {
  const OpticsAt& o = model.optics_at(i);
  const Geometry& g = model.geometry();
  const double saturation = p[kOxygenSaturation];
  // Packed blood's absorption as a function of the unpacked one, with its slope.
  const ceres::Jet<double, 1> blood_K(saturation * o.Kh + (1 - saturation) * o.Kdh, 0);
  const auto packed_K = blood_K * vessel_packaging(blood_K / (2.0 * kReferenceBloodFraction), g.vessel_radius_mm);
  const double epidermis_K = o.Ke + p[kMelanin] * o.Km;
  const double dermis_K = o.Kd + p[kTotalHemoglobin] * packed_K.a + p[kBilirubin] * o.Kb;
  const double power_law = kScatteringPerTransport * std::exp(-p[kDermisScatteringPower] * o.log_scattering_ratio);
  const double dermis_S = p[kDermisScattering] * power_law;
  const LayerJet x = under_surface(g, o, epidermis_K, dermis_K, dermis_S);
  const double rs = p[kSurfaceReflectance];
  if (gradient != nullptr) {
    const double dk = (1 - rs) * x.v[kDermisK], ds = (1 - rs) * x.v[kDermisS];
    gradient[kSurfaceReflectance] = 1 - x.a;
    gradient[kMelanin] = (1 - rs) * x.v[kEpidermisK] * o.Km;
    gradient[kTotalHemoglobin] = dk * packed_K.a;
    gradient[kOxygenSaturation] = dk * p[kTotalHemoglobin] * packed_K.v[0] * (o.Kh - o.Kdh);
    gradient[kBilirubin] = dk * o.Kb;
    gradient[kDermisScattering] = ds * power_law;
    gradient[kDermisScatteringPower] = -ds * dermis_S * o.log_scattering_ratio;
  }
  return (1 - rs) * x.a + rs;
}

}  // namespace

double SkinModel::reflectance_and_gradient(std::size_t i, const double* p, double* gradient) const {
  return kind_ == ModelKind::paper ? paper(*this, i, p, gradient) : extended(*this, i, p, gradient);
}

}  // namespace skinspec
