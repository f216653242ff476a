#include "skinspec/spectral/colour.hpp"

#include <cmath>
#include <fmt/format.h>
#include <numbers>
#include <string>

#include "resample.hpp"
#include "skinspec/spectral/utf8.hpp"

namespace skinspec {

namespace {

// The CIE 1931 observer's tabulated range; tristimulus sums run over it at 1 nm.
constexpr int kObserverFirstNm = 360;
constexpr int kObserverLastNm = 830;

std::unexpected<InputError> table_error(const Table& table, std::string message) {
  return std::unexpected(InputError{table.source(), 0, 0, std::move(message)});
}

// One column of a wavelength table as a spectrum. The table must reach across the whole
// observer range: holding an end value of an observer or illuminant table would silently
// change every colour computed from it.
std::expected<Spectrum, InputError> column_spectrum(const Table& table, std::string_view column) {
  for (const std::string_view name : {std::string_view("wavelength_nm"), column})
    if (!table.has_column(name)) return table_error(table, fmt::format("missing column '{}'", name));
  const auto wavelengths = table.column("wavelength_nm");
  const auto values = table.column(column);
  auto spectrum = Spectrum::create({wavelengths.begin(), wavelengths.end()}, {values.begin(), values.end()});
  if (!spectrum) return table_error(table, fmt::format("column '{}': {}", column, spectrum.error()));
  if (!spectrum->covers(kObserverFirstNm, kObserverLastNm))
    return table_error(
        table, fmt::format("column '{}' covers {}-{} nm, not the observer's {}-{} nm", column, spectrum->first_nm(),
                           spectrum->last_nm(), kObserverFirstNm, kObserverLastNm));
  return std::move(*spectrum);
}

// The observer's 1 nm grid. Stepped as integers so that it lands exactly on the tables' samples.
const std::vector<double>& observer_grid() {
  static const std::vector<double> grid = [] {
    std::vector<double> g;
    for (int nm = kObserverFirstNm; nm <= kObserverLastNm; ++nm) g.push_back(nm);
    return g;
  }();
  return grid;
}

// CIE 1976 lightness function, linear near black where the cube root is too steep.
double lab_f(double t) {
  constexpr double delta = 6.0 / 29.0;
  if (t > delta * delta * delta) return std::cbrt(t);
  return t / (3 * delta * delta) + 4.0 / 29.0;
}

double degrees(double radians) { return radians * 180.0 / std::numbers::pi; }
double radians(double degrees) { return degrees * std::numbers::pi / 180.0; }

double pow7(double x) {
  const double x2 = x * x;
  return x2 * x2 * x2 * x;
}

// sqrt(C^7 / (C^7 + 25^7)), the chroma weight shared by G and R_C.
double chroma_weight(double chroma) {
  const double c7 = pow7(chroma);
  return std::sqrt(c7 / (c7 + pow7(25.0)));
}

// Hue angle in [0, 360). Sharma et al. set it to 0 for a neutral colour, where atan2 would
// otherwise depend on the sign of a zero.
double hue_degrees(double a, double b) {
  if (a == 0 && b == 0) return 0;
  const double h = degrees(std::atan2(b, a));
  return h < 0 ? h + 360 : h;
}

// Hue difference h2 - h1 taken the short way round; 0 when either colour is neutral.
double hue_difference(double h1, double h2, double chroma_product) {
  if (chroma_product == 0) return 0;
  const double d = h2 - h1;
  if (d > 180) return d - 360;
  if (d < -180) return d + 360;
  return d;
}

// Mean hue on the short arc; when either colour is neutral its hue carries no information
// and the sum is used, as the paper prescribes.
double mean_hue(double h1, double h2, double chroma_product) {
  if (chroma_product == 0) return h1 + h2;
  if (std::abs(h1 - h2) <= 180) return (h1 + h2) / 2;
  if (h1 + h2 < 360) return (h1 + h2 + 360) / 2;
  return (h1 + h2 - 360) / 2;
}

double clip_unit(double v) {
  if (!(v > 0)) return 0;  // also maps NaN to 0
  return v < 1 ? v : 1;
}

}  // namespace

std::expected<Colorimetry, InputError> Colorimetry::from_tables(const Table& cmf, const Table& illuminants) {
  auto xbar = column_spectrum(cmf, "xbar");
  if (!xbar) return std::unexpected(xbar.error());
  auto ybar = column_spectrum(cmf, "ybar");
  if (!ybar) return std::unexpected(ybar.error());
  auto zbar = column_spectrum(cmf, "zbar");
  if (!zbar) return std::unexpected(zbar.error());
  auto d65 = column_spectrum(illuminants, "D65");
  if (!d65) return std::unexpected(d65.error());
  auto a = column_spectrum(illuminants, "A");
  if (!a) return std::unexpected(a.error());
  return Colorimetry(std::move(*xbar), std::move(*ybar), std::move(*zbar), std::move(*d65), std::move(*a));
}

std::expected<Spectrum, std::string> Colorimetry::illuminant(std::string_view name) const {
  if (name == "D65") return d65_;
  if (name == "A") return a_;
  return std::unexpected(fmt::format("unknown illuminant {} (known: D65, A)", quote(name)));
}

// Sums of R(λ)S(λ)x̄(λ) etc. at 1 nm, divided by the sum of S(λ)ȳ(λ) so that the perfect
// reflecting diffuser has Y = 1.
ColourWeighting Colorimetry::weighting(const Spectrum& illuminant) const {
  const auto& grid = observer_grid();
  const Spectrum power_on_grid = illuminant.resampled(grid), xbar_on_grid = xbar_.resampled(grid),
                 ybar_on_grid = ybar_.resampled(grid), zbar_on_grid = zbar_.resampled(grid);
  const auto power = power_on_grid.values(), xbar = xbar_on_grid.values(), ybar = ybar_on_grid.values(),
             zbar = zbar_on_grid.values();
  ColourWeighting w;
  double white_y = 0;
  for (std::size_t i = 0; i < grid.size(); ++i) white_y += power[i] * ybar[i];
  for (std::size_t i = 0; i < grid.size(); ++i) {
    w.x.push_back(power[i] * xbar[i] / white_y);
    w.y.push_back(power[i] * ybar[i] / white_y);
    w.z.push_back(power[i] * zbar[i] / white_y);
    w.white.x += w.x.back();
    w.white.y += w.y.back();
    w.white.z += w.z.back();
  }
  return w;
}

SampledWeighting Colorimetry::on_samples(std::span<const double> wavelength_nm, const ColourWeighting& w) {
  SampledWeighting on;
  on.x.assign(wavelength_nm.size(), 0.0);
  on.y.assign(wavelength_nm.size(), 0.0);
  on.z.assign(wavelength_nm.size(), 0.0);
  on.white = w.white;
  const auto gather = [&](std::size_t sample, std::size_t i, double share) {
    on.x[sample] += share * w.x[i];
    on.y[sample] += share * w.y[i];
    on.z[sample] += share * w.z[i];
  };
  detail::place_onto(wavelength_nm, observer_grid(), [&](std::size_t i, std::size_t lower, double t, bool past_end) {
    if (past_end) return gather(lower, i, 1.0);
    gather(lower, i, 1 - t);
    gather(lower + 1, i, t);
  });
  return on;
}

Xyz Colorimetry::xyz(std::span<const double> values, const SampledWeighting& w) {
  Xyz sum;
  for (std::size_t k = 0; k < values.size(); ++k) {
    sum.x += values[k] * w.x[k];
    sum.y += values[k] * w.y[k];
    sum.z += values[k] * w.z[k];
  }
  return sum;
}

Lab Colorimetry::lab(std::span<const double> values, const SampledWeighting& w) {
  return xyz_to_lab(xyz(values, w), w.white);
}

std::array<Lab, 2> Colorimetry::labs(std::span<const double> first, std::span<const double> second,
                                     const SampledWeighting& w) {
  Xyz a, b;
  for (std::size_t k = 0; k < first.size(); ++k) {
    a.x += first[k] * w.x[k];
    a.y += first[k] * w.y[k];
    a.z += first[k] * w.z[k];
    b.x += second[k] * w.x[k];
    b.y += second[k] * w.y[k];
    b.z += second[k] * w.z[k];
  }
  return {xyz_to_lab(a, w.white), xyz_to_lab(b, w.white)};
}

Xyz Colorimetry::xyz(const Spectrum& reflectance, const ColourWeighting& w) {
  Xyz sum;
  detail::resample_onto(reflectance.wavelengths(), reflectance.values(), observer_grid(),
                        [&](std::size_t i, double value) {
                          sum.x += value * w.x[i];
                          sum.y += value * w.y[i];
                          sum.z += value * w.z[i];
                        });
  return sum;
}

Lab Colorimetry::lab(const Spectrum& reflectance, const ColourWeighting& w) {
  return xyz_to_lab(xyz(reflectance, w), w.white);
}

Xyz Colorimetry::xyz(const Spectrum& reflectance, const Spectrum& illuminant) const {
  return xyz(reflectance, weighting(illuminant));
}

Xyz Colorimetry::white(const Spectrum& illuminant) const { return weighting(illuminant).white; }

Lab Colorimetry::lab(const Spectrum& reflectance, const Spectrum& illuminant) const {
  return xyz_to_lab(xyz(reflectance, illuminant), white(illuminant));
}

Lab xyz_to_lab(const Xyz& xyz, const Xyz& white) {
  const double fx = lab_f(xyz.x / white.x);
  const double fy = lab_f(xyz.y / white.y);
  const double fz = lab_f(xyz.z / white.z);
  return {116 * fy - 16, 500 * (fx - fy), 200 * (fy - fz)};
}

double delta_e2000(const Lab& reference, const Lab& sample) {
  // Sharma, Wu & Dalal (2005), equations (2)-(22), with kL = kC = kH = 1.
  const double mean_chroma = (std::hypot(reference.a, reference.b) + std::hypot(sample.a, sample.b)) / 2;
  const double g = 0.5 * (1 - chroma_weight(mean_chroma));
  const double a1 = (1 + g) * reference.a;
  const double a2 = (1 + g) * sample.a;
  const double c1 = std::hypot(a1, reference.b);
  const double c2 = std::hypot(a2, sample.b);
  const double h1 = hue_degrees(a1, reference.b);
  const double h2 = hue_degrees(a2, sample.b);

  const double chroma_product = c1 * c2;
  const double delta_l = sample.l - reference.l;
  const double delta_c = c2 - c1;
  const double delta_h = 2 * std::sqrt(chroma_product) * std::sin(radians(hue_difference(h1, h2, chroma_product)) / 2);

  const double l_bar = (reference.l + sample.l) / 2;
  const double c_bar = (c1 + c2) / 2;
  const double h_bar = mean_hue(h1, h2, chroma_product);

  const double t = 1 - 0.17 * std::cos(radians(h_bar - 30)) + 0.24 * std::cos(radians(2 * h_bar)) +
                   0.32 * std::cos(radians(3 * h_bar + 6)) - 0.20 * std::cos(radians(4 * h_bar - 63));
  const double delta_theta = 30 * std::exp(-std::pow((h_bar - 275) / 25, 2));
  const double r_c = 2 * chroma_weight(c_bar);
  const double l50 = (l_bar - 50) * (l_bar - 50);
  const double s_l = 1 + 0.015 * l50 / std::sqrt(20 + l50);
  const double s_c = 1 + 0.045 * c_bar;
  const double s_h = 1 + 0.015 * c_bar * t;
  const double r_t = -std::sin(radians(2 * delta_theta)) * r_c;

  const double dl = delta_l / s_l;
  const double dc = delta_c / s_c;
  const double dh = delta_h / s_h;
  return std::sqrt(dl * dl + dc * dc + dh * dh + r_t * dc * dh);
}

std::array<double, 3> xyz_to_linear_srgb(const Xyz& xyz) {
  return {3.2406 * xyz.x - 1.5372 * xyz.y - 0.4986 * xyz.z, -0.9689 * xyz.x + 1.8758 * xyz.y + 0.0415 * xyz.z,
          0.0557 * xyz.x - 0.2040 * xyz.y + 1.0570 * xyz.z};
}

double srgb_encode(double linear) {
  const double v = clip_unit(linear);
  if (v <= 0.0031308) return 12.92 * v;
  return 1.055 * std::pow(v, 1 / 2.4) - 0.055;
}

double srgb_decode(double encoded) {
  const double v = clip_unit(encoded);
  if (v <= 0.04045) return v / 12.92;
  return std::pow((v + 0.055) / 1.055, 2.4);
}

std::array<int, 3> srgb_8bit(const std::array<double, 3>& linear) {
  std::array<int, 3> codes{};
  for (std::size_t i = 0; i < codes.size(); ++i) codes[i] = static_cast<int>(std::lround(255 * srgb_encode(linear[i])));
  return codes;
}

}  // namespace skinspec
