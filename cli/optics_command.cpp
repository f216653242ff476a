// skinspec optics: the model's fixed constants for a site, as JSON.

#include <iostream>
#include <nlohmann/json.hpp>

#include "common.hpp"

namespace skinspec::cli {

void add_optics_command(CLI::App& app) {
  auto site_name = std::make_shared<std::string>("forearm");
  auto* optics = app.add_subcommand("optics", "print the layer and pigment K and S (per mm) and thicknesses");
  add_site_option(*optics, *site_name);
  optics->callback([site_name] {
    const auto site = fitter().optics().site(*site_name);
    if (!site) throw Failure{kBadInput, site.error()};
    const auto& o = fitter().optics().optics();
    const nlohmann::json out = {
        {"site", site->name},
        {"epidermis_thickness_mm", site->epidermis_mm},
        {"dermis_thickness_mm", site->dermis_mm},
        {"wavelength_nm", o.wavelength_nm},
        {"Ke", o.Ke},
        {"Se", o.Se},
        {"Kd", o.Kd},
        {"Sd", o.Sd},
        {"Km", o.Km},
        {"Kh", o.Kh},
        {"Kdh", o.Kdh},
        {"Kb", o.Kb},
        {"lateral_radius_mm", fitter().optics().constants().lateral_radius_mm},
        {"tables_digest", fitter().optics().tables_digest()},
    };
    std::cout << out.dump() << '\n';
  });
}

}  // namespace skinspec::cli
