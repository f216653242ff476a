#pragma once
// The fixed optical constants of the two-layer skin model, built from the tables in data/:
// Kubelka-Munk absorption K and scattering S of each layer and pigment, per millimetre, the
// layer thicknesses of each body site, and one model's tuned constants. docs/model.md derives
// every number.

#include <array>
#include <expected>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "skinspec/fit/model_spec.hpp"
#include "skinspec/spectral/table.hpp"

namespace skinspec {

// K and S per mm at each wavelength of a grid. Pigment rows (Km, Kh, Kdh, Kb) are the absorption
// of weight 1.0 of that pigment: the reference concentrations of docs/model.md.
struct LayerOptics {
  std::vector<double> wavelength_nm;
  std::vector<double> Ke, Se;           // epidermis baseline absorption, epidermis scattering
  std::vector<double> Kd, Sd;           // dermis baseline absorption, dermis scattering
  std::vector<double> Km, Kh, Kdh, Kb;  // melanin, oxy-, deoxy-haemoglobin, bilirubin

  // The same constants linearly interpolated onto another grid inside this one's range.
  LayerOptics resampled(std::span<const double> grid_nm) const;
};

// Weight 1.0 of blood means whole blood filling this share of the dermis (Jacques 1998's
// average dermal blood fraction): docs/model.md, "Pigment weights".
inline constexpr double kReferenceBloodFraction = 0.002;

// A body site's layers. epidermis_mm is the layer that holds melanin: the whole epidermis for
// the paper model, the living epidermis for the extended model, whose stratum corneum (no
// melanin, no blood) lies over it as a layer of its own; 0 is none.
struct Site {
  std::string name;
  double epidermis_mm = 0;
  double dermis_mm = 0;
  double stratum_corneum_mm = 0;
};

// The constants chosen on measured skin (data/model/constants*.csv, scripts/tune-model). Each
// model uses those its ConstantSpec table names; the others keep their neutral values.
struct ModelConstants {
  double epidermis_scattering_scale = 1;
  double dermis_scattering_scale = 1;
  double epidermis_thickness_scale = 1;
  double dermis_thickness_scale = 1;
  double lateral_radius_mm = 0;  // radius beyond which remitted light is lost; 0 = no loss
  double vessel_radius_um = 0;   // radius of the vessels blood is packed in; 0 = spread evenly
  double melanin_exponent = 3;   // m of the melanosome's mu_a ~ lambda^-m; the table's is 3
  // Coefficients of the baseline-absorption correction, Legendre degree 0, 1, ...
  std::array<double, kMaxBaselineTerms> baseline_absorption{};
};

// The field named as in a ConstantSpec ("lateral_radius_mm", "baseline_absorption_2"); null for
// a name ModelConstants does not have.
double* constant_field(ModelConstants& constants, std::string_view name);
// The untuned starting point of a model's constants: each ConstantSpec's textbook value.
ModelConstants textbook_constants(ModelKind model);
// A model's constants as the values of its ConstantSpec table, in order, and back.
std::vector<double> constant_values(ModelKind model, const ModelConstants& constants);
ModelConstants constants_from_values(ModelKind model, std::span<const double> values);

// A model's constants from a keyed table with a `value` column (the format of
// data/model/constants*.csv); an error naming the table for a missing or negative one.
std::expected<ModelConstants, InputError> parse_constants(const Table& table, ModelKind model);

// The melanin absorption's wavelength exponent, relative to the m = 3 of the table, pivoted where
// the table is normalised (500 nm).
inline constexpr double kMelaninPivotNm = 500;

// exp of the baseline-absorption correction at one wavelength: the factor on Ke and Kd.
double baseline_absorption_factor(const ModelConstants& constants, double wavelength_nm);

class SkinOptics {
 public:
  // Loads optics/*.csv and the model's sites and constants files through `read`.
  static std::expected<SkinOptics, InputError> load(const DataReader& read, ModelKind model);

  // The model grid: 380-780 nm every 1 nm. The tables behind it reach no further in
  // agreement (bilirubin stops at 700 nm, haemoglobin is tabulated here to 782 nm), and the
  // spectra the constants are tuned on stop at 781 nm: docs/model.md, "Wavelength range".
  static constexpr double kFirstNm = 380, kLastNm = 780;

  ModelKind model() const { return model_; }
  // With the tuned constants applied: scattering scales, the melanin exponent and the baseline
  // correction.
  const LayerOptics& optics() const { return optics_; }
  const ModelConstants& constants() const { return constants_; }
  std::vector<std::string> site_names() const;
  // A site with the thickness scales applied; an error listing the known sites otherwise.
  std::expected<Site, std::string> site(std::string_view name) const;
  // A hex digest of every table byte that went into the model, its constants included, for
  // provenance.
  const std::string& tables_digest() const { return digest_; }
  // A hex digest of the tuned constants alone (their names and values as applied): two fits
  // with the same constants digest used the same constants whatever else changed. Every fit
  // stored names it, so it is taken once, when the constants are applied.
  const std::string& constants_digest() const { return constants_digest_; }

  // The same tables under other constants (used while tuning them).
  SkinOptics with_constants(const ModelConstants& constants) const;

 private:
  ModelKind model_ = ModelKind::paper;
  LayerOptics base_;    // as tabulated, before the tuned constants
  LayerOptics optics_;  // with them
  std::vector<Site> sites_;
  ModelConstants constants_;
  std::string digest_;
  std::string constants_digest_;
};

}  // namespace skinspec
