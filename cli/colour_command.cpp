// skinspec colour FILE (alias color): XYZ, Lab and sRGB of each spectrum under an illuminant.

#include <iostream>
#include <nlohmann/json.hpp>

#include "common.hpp"

namespace skinspec::cli {

void add_colour_command(CLI::App& app) {
  auto file = std::make_shared<std::string>();
  auto illuminant_name = std::make_shared<std::string>("D65");
  auto* colour = app.add_subcommand("colour", "print CIE XYZ, CIELAB and sRGB of reflectance spectra");
  colour->alias("color");
  colour->add_option("FILE", *file, "CSV of reflectance spectra as for `fit`; - reads stdin")->required();
  colour->add_option("--illuminant", *illuminant_name, "D65, A, or a CSV file wavelength_nm,power covering 380-780 nm")
      ->capture_default_str();
  colour->callback([file, illuminant_name] {
    const Spectrum illuminant = illuminant_from(*illuminant_name);
    const auto& c = fitter().colorimetry();
    const Xyz white = c.white(illuminant);
    for (const auto& [name, spectrum] : read_spectra(*file)) {
      const Xyz xyz = c.xyz(spectrum, illuminant);
      const Lab lab = xyz_to_lab(xyz, white);
      const auto linear = xyz_to_linear_srgb(xyz);
      const nlohmann::json out = {
          {"name", name},
          {"illuminant", *illuminant_name},
          {"XYZ", {xyz.x, xyz.y, xyz.z}},
          {"Lab", {lab.l, lab.a, lab.b}},
          {"sRGB", {srgb_encode(linear[0]), srgb_encode(linear[1]), srgb_encode(linear[2])}},
          {"sRGB8", srgb_8bit(linear)},
      };
      // Names are UTF-8 (the parser refuses anything else); an illuminant's path may not be.
      std::cout << out.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) << '\n';
    }
  });
}

}  // namespace skinspec::cli
