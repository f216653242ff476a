#include "skinspec/simulator/scenes.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "skinspec/drivers/pr650_protocol.hpp"
#include "skinspec/spectral/spectra_csv.hpp"

namespace skinspec::simulator {

namespace pp = drivers::pr650;

namespace {

constexpr std::string_view kCmfFile = "colour/cie1931_2deg_cmf.csv";
constexpr std::string_view kIlluminantFile = "colour/cie_illuminants.csv";

std::vector<double> sampled(std::span<const double> xs, std::span<const double> ys, std::span<const double> grid) {
  std::vector<double> out;
  for (const double nm : grid) out.push_back(interpolate(xs, ys, nm));
  return out;
}

struct Tristimulus {
  double x = 0, y = 0, z = 0;
};

// The meter sums at its own step.
Tristimulus tristimulus(std::span<const double> radiance, const Observer& observer) {
  Tristimulus t;
  for (std::size_t i = 0; i < radiance.size() && i < observer.ybar.size(); ++i) {
    t.x += radiance[i] * observer.xbar[i];
    t.y += radiance[i] * observer.ybar[i];
    t.z += radiance[i] * observer.zbar[i];
  }
  const double k = kKm * observer.step_nm();
  return {t.x * k, t.y * k, t.z * k};
}

// CIE 1960 u, v of tristimulus values; zeros for black.
std::pair<double, double> uv1960(const Tristimulus& t) {
  const double d = t.x + 15 * t.y + 3 * t.z;
  if (d <= 0) return {0, 0};
  return {4 * t.x / d, 6 * t.y / d};
}

// Planck's law for a blackbody at `kelvin` on the grid (relative units suffice for uv).
std::vector<double> blackbody(double kelvin, std::span<const double> grid) {
  constexpr double c2 = 1.4388e-2;  // m K
  std::vector<double> out;
  for (const double nm : grid) {
    const double m = nm * 1e-9;
    out.push_back(1.0 / (std::pow(m, 5) * std::expm1(c2 / (m * kelvin))) * 1e-30);
  }
  return out;
}

std::expected<std::vector<NamedSpectrum>, std::string> read_spectra(std::string_view csv, std::string_view source,
                                                                    const SpectraLimits& limits) {
  auto spectra = parse_spectra_csv(csv, source, limits);
  if (!spectra) return std::unexpected(spectra.error().what());
  return std::move(*spectra);
}

std::expected<Spectrum, std::string> table_column(const Table& table, std::string_view column) {
  const auto nm = table.column("wavelength_nm");
  const auto values = table.column(column);
  auto spectrum = Spectrum::create({nm.begin(), nm.end()}, {values.begin(), values.end()});
  if (!spectrum) return std::unexpected(fmt::format("{}: column '{}': {}", table.source(), column, spectrum.error()));
  return std::move(*spectrum);
}

}  // namespace

const std::vector<double>& native_grid() {
  static const std::vector<double> grid = [] {
    std::vector<double> g;
    for (int i = 0; i < pp::kSpectralPoints; ++i) g.push_back(pp::kFirstNm + pp::kStepNm * i);
    return g;
  }();
  return grid;
}

std::vector<double> wavelengths(const drivers::Grid& grid) {
  std::vector<double> out;
  for (int i = 0; i < grid.points; ++i) out.push_back(grid.first_nm + grid.step_nm * i);
  return out;
}

std::expected<Observer, std::string> Observer::from_table(const Table& cmf, std::span<const double> grid) {
  for (const std::string_view column : {"wavelength_nm", "xbar", "ybar", "zbar"})
    if (!cmf.has_column(column)) return std::unexpected(fmt::format("{}: missing column '{}'", cmf.source(), column));
  const auto nm = cmf.column("wavelength_nm");
  if (grid.empty() || nm.empty() || nm.front() > grid.front())
    return std::unexpected(
        fmt::format("{}: the observer does not start by {} nm", cmf.source(), grid.empty() ? 0.0 : grid.front()));
  // Beyond its last row (830 nm) the observer sees nothing: zeros, not the last row held.
  const auto seen = [&](std::string_view column) {
    std::vector<double> values = sampled(nm, cmf.column(column), grid);
    for (std::size_t i = 0; i < grid.size(); ++i)
      if (grid[i] > nm.back()) values[i] = 0;
    return values;
  };
  return Observer{seen("xbar"), seen("ybar"), seen("zbar"), {grid.begin(), grid.end()}};
}

Photometry photometry(std::span<const double> radiance, const Observer& observer) {
  const Tristimulus t = tristimulus(radiance, observer);
  Photometry p;
  p.X = t.x;
  p.Y = t.y;
  p.Z = t.z;
  const double sum = t.x + t.y + t.z;
  if (sum <= 0) return p;
  p.x = t.x / sum;
  p.y = t.y / sum;
  const auto [u, v] = uv1960(t);
  p.u = u;
  p.v = 1.5 * v;
  // McCamy's cubic in the slope from the epicentre (0.3320, 0.1858); good for 2000-12500 K.
  const double n = (p.x - 0.3320) / (0.1858 - p.y);
  p.cct = std::clamp(((449 * n + 3525) * n + 6823.3) * n + 5520.33, 1000.0, 100000.0);
  const auto [ub, vb] = uv1960(tristimulus(blackbody(p.cct, observer.nm), observer));
  p.duv = std::copysign(std::hypot(u - ub, v - vb), v - vb);
  return p;
}

std::vector<double> colour_report_values(const Photometry& p, int report, bool si_units) {
  const double unit = si_units ? 1.0 : 1.0 / kCandelaPerFootlambert;
  switch (report) {
    case 1:
      return {p.Y * unit, p.x, p.y};
    case 2:
      return {p.X * unit, p.Y * unit, p.Z * unit};
    case 3:
      return {p.Y * unit, p.u, p.v};
    case 4:
      return {p.Y * unit, p.cct, p.duv};
    default:
      return {p.Y * unit, p.x, p.y, p.u, p.v};
  }
}

std::expected<Spectrum, std::string> ColourData::illuminant(std::string_view name) const {
  if (name == "D65") return d65;
  if (name == "A") return a;
  return std::unexpected(fmt::format("unknown illuminant '{}' (known: D65, A, or a spectra CSV file)", name));
}

std::expected<ColourData, std::string> ColourData::load(const DataReader& read, std::span<const double> grid) {
  const auto load_table = [&](std::string_view file,
                              std::span<const std::string_view> columns) -> std::expected<Table, std::string> {
    auto bytes = read(file);
    if (!bytes) return std::unexpected(bytes.error());
    auto table = parse_table(*bytes, file, columns);
    if (!table) return std::unexpected(table.error().what());
    return std::move(*table);
  };
  static constexpr std::string_view kCmfColumns[] = {"wavelength_nm", "xbar", "ybar", "zbar"};
  static constexpr std::string_view kIlluminantColumns[] = {"wavelength_nm", "D65", "A"};
  auto cmf = load_table(kCmfFile, kCmfColumns);
  if (!cmf) return std::unexpected(cmf.error());
  auto illuminants = load_table(kIlluminantFile, kIlluminantColumns);
  if (!illuminants) return std::unexpected(illuminants.error());
  auto observer = Observer::from_table(*cmf, grid);
  if (!observer) return std::unexpected(observer.error());
  auto d65 = table_column(*illuminants, "D65");
  if (!d65) return std::unexpected(d65.error());
  auto a = table_column(*illuminants, "A");
  if (!a) return std::unexpected(a.error());
  return ColourData{std::move(*observer), std::move(*d65), std::move(*a)};
}

std::expected<Scene, std::string> scene_from_radiance(std::string name, const Spectrum& radiance,
                                                      std::span<const double> grid) {
  const Spectrum on_grid = radiance.resampled(grid);
  if (std::ranges::any_of(on_grid.values(), [](double v) { return v < 0; }))
    return std::unexpected(fmt::format("radiance '{}' has negative values", name));
  const auto values = on_grid.values();
  Scene scene;
  scene.name = std::move(name);
  scene.radiance.assign(values.begin(), values.end());
  return scene;
}

Scene scene_under_lamp(std::string name, const Spectrum& reflectance, const Lamp& lamp, const Observer& observer) {
  const Spectrum power = lamp.power.resampled(observer.nm);
  const Spectrum r = reflectance.resampled(observer.nm);
  const double white = tristimulus(power.values(), observer).y;
  const double k = white > 0 ? lamp.white_luminance / white : 0;
  Scene scene;
  scene.name = std::move(name);
  for (std::size_t i = 0; i < observer.nm.size(); ++i)
    scene.radiance.push_back(std::max(0.0, r.values()[i]) * power.values()[i] * k);
  return scene;
}

std::expected<std::vector<Scene>, std::string> radiance_scenes(std::string_view csv, std::string_view source,
                                                               std::span<const double> grid) {
  SpectraLimits limits;
  limits.max_value = std::numeric_limits<double>::max();
  auto spectra = read_spectra(csv, source, limits);
  if (!spectra) return std::unexpected(spectra.error());
  std::vector<Scene> scenes;
  for (const auto& [name, spectrum] : *spectra) {
    auto scene = scene_from_radiance(name, spectrum, grid);
    if (!scene) return std::unexpected(fmt::format("{}: {}", source, scene.error()));
    scenes.push_back(std::move(*scene));
  }
  return scenes;
}

std::expected<std::vector<Scene>, std::string> reflectance_scenes(std::string_view csv, std::string_view source,
                                                                  const Lamp& lamp, const Observer& observer) {
  auto spectra = read_spectra(csv, source, SpectraLimits{});
  if (!spectra) return std::unexpected(spectra.error());
  std::vector<Scene> scenes;
  for (const auto& [name, spectrum] : *spectra)
    scenes.push_back(scene_under_lamp(fmt::format("{} under {}", name, lamp.name), spectrum, lamp, observer));
  return scenes;
}

std::expected<Spectrum, std::string> illuminant_from_csv(std::string_view csv, std::string_view source) {
  SpectraLimits limits;
  limits.max_value = std::numeric_limits<double>::max();
  auto spectra = read_spectra(csv, source, limits);
  if (!spectra) return std::unexpected(spectra.error());
  return std::move(spectra->front().spectrum);
}

}  // namespace skinspec::simulator
