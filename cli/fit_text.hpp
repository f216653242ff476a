#pragma once
// Fits as the command line prints them: the parameters of a fit as the service returns it
// (JSON) for the session commands, and what every table of fits says of its units and of
// "n.d.".

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "skinspec/spectral/skin_tone.hpp"

namespace skinspec::cli {

// The names of the fit's parameters in its model's order (the order of its JSON object when the
// model is not one this version knows).
std::vector<std::string> param_names(const nlohmann::json& fit);

// Why the spectrum did not determine the parameter ("at_bound", "correlated with melanin", ...);
// nullopt when it did.
std::optional<std::string> not_determined(const nlohmann::json& fit, const std::string& name);

// The unit of a parameter of `model` (ParamSpec::unit), "[fraction]"; empty for a model or a
// parameter this version does not know.
std::string param_unit(std::string_view model, std::string_view name);
// A unit as the tables print it: "[reflectance, as a fraction]" (kRmseUnit, kDeltaE00Unit of
// skinspec/fit/model_spec.hpp).
std::string unit_text(std::string_view unit);

// A table's units line: "units: melanin [x 1 % melanosomes in the epidermis]; ...; rmse
// [reflectance, as a fraction]; dE00 [CIEDE2000 ...]; ITA° [degrees]; M, E [...]", its columns
// named as the table names them.
std::string units_line(std::string_view model, const std::vector<std::string>& names, std::string_view rmse_column,
                       std::string_view delta_e00_column);

// The skin-tone columns of a table, "  ITA° class        M     E", and a fit's cells under them
// ("-" for what the fit does not have).
std::string skin_tone_header();
std::string skin_tone_cells(const std::optional<SkinTone>& tone);

// The line that ends a table showing fits: what "n.d." means, and where to read why
// (`reasons_in`: "--format json"; empty where the reasons are printed beside).
std::string not_determined_line(std::string_view reasons_in);

}  // namespace skinspec::cli
