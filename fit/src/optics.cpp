#include "skinspec/fit/optics.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <numbers>

#include "skinspec/spectral/spectrum.hpp"
#include "skinspec/spectral/utf8.hpp"

namespace skinspec {

namespace {

// What weight 1.0 of each pigment means (docs/model.md, "Pigment weights").
constexpr double kReferenceMelanosomeFraction = 0.01;  // of the epidermis volume
constexpr double kHaemoglobinInBlood_g_per_L = 150;    // Prahl's convention
constexpr double kHaemoglobinMolarMass_g_per_mol = 64500;
constexpr double kReferenceBilirubin_g_per_L = 0.005;  // in the dermis (BioSpec default)
constexpr double kBilirubinMolarMass_g_per_mol = 584.66;
constexpr double kPerCmToPerMm = 0.1;

// Kubelka-Munk coefficients from transport ones for diffuse light (Gate 1974; Thennadil 2008).
double km_absorption(double mu_a_per_cm) { return 2 * mu_a_per_cm * kPerCmToPerMm; }
double km_scattering(double mu_s_reduced_per_cm) { return 0.75 * mu_s_reduced_per_cm * kPerCmToPerMm; }
// Decadic molar extinction (cm-1/M) at a molar concentration to mu_a (cm-1).
double decadic_to_mu_a(double epsilon, double molar) { return std::numbers::ln10 * epsilon * molar; }

std::uint64_t fnv1a(std::uint64_t hash, std::string_view bytes) {
  for (const unsigned char c : bytes) hash = (hash ^ c) * 0x100000001b3ULL;
  return hash;
}

struct Loaded {
  std::uint64_t hash = 0xcbf29ce484222325ULL;
  const DataReader& read;

  std::expected<Table, InputError> table(std::string_view path, std::initializer_list<std::string_view> columns) {
    auto bytes = read(path);
    if (!bytes) return std::unexpected(InputError{std::string(path), 0, 0, bytes.error()});
    hash = fnv1a(fnv1a(hash, path), *bytes);
    return parse_table(*bytes, path, {columns.begin(), columns.size()});
  }
};

// Column `name` of a spectral table, interpolated onto grid; an error when the table does
// not span the grid (holding an end value would invent data).
std::expected<std::vector<double>, InputError> on_grid(const Table& t, std::string_view name,
                                                       std::span<const double> grid) {
  const auto w = t.column("wavelength_nm");
  if (w.empty() || w.front() > grid.front() || w.back() < grid.back())
    return std::unexpected(InputError{
        t.source(), 0, 0, fmt::format("must span {}-{} nm (wavelength_nm column)", grid.front(), grid.back())});
  const auto values = t.column(name);
  std::vector<double> out(grid.size());
  for (std::size_t i = 0; i < grid.size(); ++i) out[i] = interpolate(w, values, grid[i]);
  return out;
}

std::vector<double> transform(const std::vector<double>& in, auto f) {
  std::vector<double> out(in.size());
  std::ranges::transform(in, out.begin(), f);
  return out;
}

std::expected<LayerOptics, InputError> layer_optics(Loaded& loaded) {
  const auto grid = Spectrum::uniform_grid(SkinOptics::kFirstNm, SkinOptics::kLastNm, 1);
  auto hb = loaded.table("optics/hemoglobin_prahl.csv", {"wavelength_nm", "eps_hbo2", "eps_hb"});
  auto bil = loaded.table("optics/bilirubin_photochemcad.csv", {"wavelength_nm", "eps_bilirubin"});
  auto mel = loaded.table("optics/melanosome_jacques2013.csv", {"wavelength_nm", "mua"});
  auto base = loaded.table("optics/skin_baseline_jacques1998.csv", {"wavelength_nm", "mua"});
  auto scat = loaded.table("optics/scattering_salomatina.csv", {"wavelength_nm", "musp_epidermis", "musp_dermis"});
  for (auto* t : {&hb, &bil, &mel, &base, &scat})
    if (!*t) return std::unexpected(t->error());

  auto eps_hbo2 = on_grid(*hb, "eps_hbo2", grid);
  auto eps_hb = on_grid(*hb, "eps_hb", grid);
  auto eps_bil = on_grid(*bil, "eps_bilirubin", grid);
  auto mua_mel = on_grid(*mel, "mua", grid);
  auto mua_base = on_grid(*base, "mua", grid);
  auto musp_e = on_grid(*scat, "musp_epidermis", grid);
  auto musp_d = on_grid(*scat, "musp_dermis", grid);
  for (auto* c : {&eps_hbo2, &eps_hb, &eps_bil, &mua_mel, &mua_base, &musp_e, &musp_d})
    if (!*c) return std::unexpected(c->error());
  for (auto* c : {&musp_e, &musp_d})
    if (std::ranges::any_of(**c, [](double v) { return !(v > 0); }))
      return std::unexpected(InputError{scat->source(), 0, 0, "scattering must be positive"});

  constexpr double blood_haemoglobin_molar = kHaemoglobinInBlood_g_per_L / kHaemoglobinMolarMass_g_per_mol;
  constexpr double bilirubin_molar = kReferenceBilirubin_g_per_L / kBilirubinMolarMass_g_per_mol;
  const auto haemoglobin = [&](double eps) {
    return km_absorption(kReferenceBloodFraction * decadic_to_mu_a(eps, blood_haemoglobin_molar));
  };
  LayerOptics o;
  o.wavelength_nm = grid;
  o.Ke = transform(*mua_base, km_absorption);
  o.Kd = o.Ke;
  o.Se = transform(*musp_e, km_scattering);
  o.Sd = transform(*musp_d, km_scattering);
  o.Km = transform(*mua_mel, [](double mu) { return km_absorption(kReferenceMelanosomeFraction * mu); });
  o.Kh = transform(*eps_hbo2, haemoglobin);
  o.Kdh = transform(*eps_hb, haemoglobin);
  o.Kb = transform(*eps_bil, [](double eps) { return km_absorption(decadic_to_mu_a(eps, bilirubin_molar)); });
  return o;
}

std::expected<std::vector<Site>, InputError> load_sites(Loaded& loaded, ModelKind model) {
  const ModelSpec& spec = model_spec(model);
  const bool corneum = !spec.stratum_corneum_column.empty();
  auto t = corneum ? loaded.table(spec.sites_file, {spec.epidermis_column, "dermis_mm", spec.stratum_corneum_column})
                   : loaded.table(spec.sites_file, {spec.epidermis_column, "dermis_mm"});
  if (!t) return std::unexpected(t.error());
  std::vector<Site> sites;
  for (std::size_t i = 0; i < t->rows(); ++i) {
    Site s{t->keys()[i], t->column(spec.epidermis_column)[i], t->column("dermis_mm")[i],
           corneum ? t->column(spec.stratum_corneum_column)[i] : 0.0};
    if (!(s.epidermis_mm > 0) || !(s.dermis_mm > 0) || !(s.stratum_corneum_mm >= 0))
      return std::unexpected(InputError{t->source(), 0, 0, "site " + quote(s.name) + " needs positive thicknesses"});
    sites.push_back(std::move(s));
  }
  return sites;
}

std::expected<ModelConstants, InputError> load_constants(Loaded& loaded, ModelKind model) {
  auto t = loaded.table(model_spec(model).constants_file, {"value"});
  if (!t) return std::unexpected(t.error());
  return parse_constants(*t, model);
}

LayerOptics with_constants_applied(LayerOptics o, const ModelConstants& c) {
  for (double& s : o.Se) s *= c.epidermis_scattering_scale;
  for (double& s : o.Sd) s *= c.dermis_scattering_scale;
  for (std::size_t i = 0; i < o.wavelength_nm.size(); ++i) {
    const double factor = baseline_absorption_factor(c, o.wavelength_nm[i]);
    o.Ke[i] *= factor;
    o.Kd[i] *= factor;
    if (c.melanin_exponent != 3) o.Km[i] *= std::pow(o.wavelength_nm[i] / kMelaninPivotNm, 3 - c.melanin_exponent);
  }
  return o;
}

// Legendre polynomial P_n(x) by Bonnet's recursion.
double legendre(std::size_t n, double x) {
  double previous = 1, current = x;
  if (n == 0) return previous;
  for (std::size_t k = 1; k < n; ++k) {
    const double next = ((2.0 * static_cast<double>(k) + 1) * x * current - static_cast<double>(k) * previous) /
                        (static_cast<double>(k) + 1);
    previous = current;
    current = next;
  }
  return current;
}

// The constants' names and values as applied, hashed.
std::string constants_digest_of(ModelKind model, const ModelConstants& constants) {
  std::uint64_t hash = 0xcbf29ce484222325ULL;
  const auto specs = model_spec(model).constants;
  const auto values = constant_values(model, constants);
  for (std::size_t i = 0; i < specs.size() && i < values.size(); ++i)
    hash = fnv1a(hash, fmt::format("{}={:.17g};", specs[i].name, values[i]));
  return fmt::format("{:016x}", hash);
}

}  // namespace

std::expected<ModelConstants, InputError> parse_constants(const Table& t, ModelKind model) {
  if (!t.has_column("value")) return std::unexpected(InputError{t.source(), 0, 0, "no 'value' column"});
  std::vector<double> values;
  for (const ConstantSpec& spec : model_spec(model).constants) {
    const auto it = std::ranges::find(t.keys(), spec.name);
    if (it == t.keys().end())
      return std::unexpected(InputError{t.source(), 0, 0, fmt::format("missing constant '{}'", spec.name)});
    const double value = t.column("value")[static_cast<std::size_t>(it - t.keys().begin())];
    if (spec.scale == ConstantScale::logarithmic && value < 0)
      return std::unexpected(InputError{t.source(), 0, 0, fmt::format("constant '{}' is negative", spec.name)});
    values.push_back(value);
  }
  return constants_from_values(model, values);
}

double* constant_field(ModelConstants& c, std::string_view name) {
  const std::pair<std::string_view, double*> named[] = {{"epidermis_scattering_scale", &c.epidermis_scattering_scale},
                                                        {"dermis_scattering_scale", &c.dermis_scattering_scale},
                                                        {"epidermis_thickness_scale", &c.epidermis_thickness_scale},
                                                        {"dermis_thickness_scale", &c.dermis_thickness_scale},
                                                        {"lateral_radius_mm", &c.lateral_radius_mm},
                                                        {"vessel_radius_um", &c.vessel_radius_um},
                                                        {"melanin_exponent", &c.melanin_exponent}};
  for (const auto& [field_name, field] : named)
    if (field_name == name) return field;
  constexpr std::string_view kBaseline = "baseline_absorption_";
  if (name.starts_with(kBaseline)) {
    const std::string_view digits = name.substr(kBaseline.size());
    if (digits.size() == 1 && digits[0] >= '0' && static_cast<std::size_t>(digits[0] - '0') < kMaxBaselineTerms)
      return &c.baseline_absorption[static_cast<std::size_t>(digits[0] - '0')];
  }
  return nullptr;
}

ModelConstants textbook_constants(ModelKind model) {
  std::vector<double> values;
  for (const ConstantSpec& spec : model_spec(model).constants) values.push_back(spec.textbook);
  return constants_from_values(model, values);
}

std::vector<double> constant_values(ModelKind model, const ModelConstants& constants) {
  ModelConstants copy = constants;
  std::vector<double> values;
  for (const ConstantSpec& spec : model_spec(model).constants) values.push_back(*constant_field(copy, spec.name));
  return values;
}

ModelConstants constants_from_values(ModelKind model, std::span<const double> values) {
  ModelConstants constants;
  const auto specs = model_spec(model).constants;
  for (std::size_t i = 0; i < specs.size() && i < values.size(); ++i)
    *constant_field(constants, specs[i].name) = values[i];
  return constants;
}

double baseline_absorption_factor(const ModelConstants& constants, double wavelength_nm) {
  const double x = (wavelength_nm - 580.0) / 200.0;
  double exponent = 0;
  for (std::size_t n = 0; n < kMaxBaselineTerms; ++n)
    if (constants.baseline_absorption[n] != 0) exponent += constants.baseline_absorption[n] * legendre(n, x);
  return std::exp(exponent);
}

LayerOptics LayerOptics::resampled(std::span<const double> grid_nm) const {
  LayerOptics out;
  out.wavelength_nm.assign(grid_nm.begin(), grid_nm.end());
  const auto resample = [&](const std::vector<double>& values) {
    std::vector<double> r(grid_nm.size());
    for (std::size_t i = 0; i < grid_nm.size(); ++i) r[i] = interpolate(wavelength_nm, values, grid_nm[i]);
    return r;
  };
  for (auto member : {&LayerOptics::Ke, &LayerOptics::Se, &LayerOptics::Kd, &LayerOptics::Sd, &LayerOptics::Km,
                      &LayerOptics::Kh, &LayerOptics::Kdh, &LayerOptics::Kb})
    out.*member = resample(this->*member);
  return out;
}

std::expected<SkinOptics, InputError> SkinOptics::load(const DataReader& read, ModelKind model) {
  Loaded loaded{.read = read};
  auto base = layer_optics(loaded);
  if (!base) return std::unexpected(base.error());
  auto sites = load_sites(loaded, model);
  if (!sites) return std::unexpected(sites.error());
  auto constants = load_constants(loaded, model);
  if (!constants) return std::unexpected(constants.error());
  SkinOptics optics;
  optics.model_ = model;
  optics.base_ = std::move(*base);
  optics.sites_ = std::move(*sites);
  optics.digest_ = fmt::format("{:016x}", loaded.hash);
  return optics.with_constants(*constants);
}

SkinOptics SkinOptics::with_constants(const ModelConstants& constants) const {
  SkinOptics copy = *this;
  copy.constants_ = constants;
  copy.optics_ = with_constants_applied(base_, constants);
  copy.constants_digest_ = constants_digest_of(copy.model_, constants);
  return copy;
}

std::vector<std::string> SkinOptics::site_names() const {
  std::vector<std::string> names;
  for (const auto& s : sites_) names.push_back(s.name);
  return names;
}

std::expected<Site, std::string> SkinOptics::site(std::string_view name) const {
  const auto it = std::ranges::find(sites_, name, &Site::name);
  if (it == sites_.end())
    return std::unexpected(fmt::format("unknown site {}; known sites: {}", quote(name), fmt::join(site_names(), ", ")));
  // One scale for the whole epidermis, its stratum corneum included.
  return Site{it->name, it->epidermis_mm * constants_.epidermis_thickness_scale,
              it->dermis_mm * constants_.dermis_thickness_scale,
              it->stratum_corneum_mm * constants_.epidermis_thickness_scale};
}

}  // namespace skinspec
