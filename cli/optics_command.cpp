// skinspec optics: the model's fixed constants for a site, as JSON.

#include <iostream>
#include <nlohmann/json.hpp>

#include "common.hpp"
#include "model_options.hpp"

namespace skinspec::cli {

void add_optics_command(CLI::App& app) {
  auto site_name = std::make_shared<std::string>("forearm");
  auto model = std::make_shared<ModelKind>(kDefaultModel);
  auto* optics =
      app.add_subcommand("optics",
                         "print the layer and pigment K and S (per mm) and thicknesses; the extended model's dermis "
                         "scattering is a fitted parameter, and Sd here is the tabulated one it replaces");
  add_model_option(*optics, *model);
  add_site_option(*optics, *site_name);
  optics->callback([site_name, model] {
    const SkinOptics& skin = fitter().optics(*model);
    const auto site = skin.site(*site_name);
    if (!site) throw Failure{kBadInput, site.error()};
    const auto& o = skin.optics();
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
        {"model", to_string(*model)},
        {"lateral_radius_mm", skin.constants().lateral_radius_mm},
        {"tables_digest", skin.tables_digest()},
    };
    std::cout << out.dump() << '\n';
  });
}

}  // namespace skinspec::cli
