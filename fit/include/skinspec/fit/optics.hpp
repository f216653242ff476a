#pragma once
// The fixed optical constants of the two-layer skin model, built from the tables in data/:
// Kubelka-Munk absorption K and scattering S of each layer and pigment, per millimetre, and the
// layer thicknesses of each body site. docs/model.md derives every number.

#include <expected>
#include <span>
#include <string>
#include <string_view>
#include <vector>

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

struct Site {
  std::string name;
  double epidermis_mm = 0;
  double dermis_mm = 0;
};

// The constants chosen on measured skin (data/model/constants.csv, scripts/tune-model).
struct ModelConstants {
  double epidermis_scattering_scale = 1;
  double dermis_scattering_scale = 1;
  double epidermis_thickness_scale = 1;
  double dermis_thickness_scale = 1;
  double lateral_radius_mm = 0;  // radius beyond which remitted light is lost; 0 = no loss
};

class SkinOptics {
 public:
  // Loads optics/*.csv, model/sites.csv and model/constants.csv through `read`.
  static std::expected<SkinOptics, InputError> load(const DataReader& read);

  // The model grid: 380-780 nm every 1 nm.
  static constexpr double kFirstNm = 380, kLastNm = 780;

  const LayerOptics& optics() const { return optics_; }  // scattering scales applied
  const ModelConstants& constants() const { return constants_; }
  std::vector<std::string> site_names() const;
  // A site with the thickness scales applied; an error listing the known sites otherwise.
  std::expected<Site, std::string> site(std::string_view name) const;
  // A hex digest of every table byte that went into the model, for provenance.
  const std::string& tables_digest() const { return digest_; }

  // The same tables under other constants (used while tuning them).
  SkinOptics with_constants(const ModelConstants& constants) const;

 private:
  LayerOptics base_;    // as tabulated, before the scattering scales
  LayerOptics optics_;  // with them
  std::vector<Site> sites_;
  ModelConstants constants_;
  std::string digest_;
};

// Named constants of model/constants.csv, in the order the file lists them.
std::vector<std::pair<std::string_view, double ModelConstants::*>> model_constant_fields();

}  // namespace skinspec
