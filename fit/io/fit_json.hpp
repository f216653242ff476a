#pragma once
// The JSON form of fit results, shared by the command line and the service so that both
// print exactly the same fields.

#include <nlohmann/json.hpp>
#include <string_view>

#include "skinspec/fit/fitter.hpp"

namespace skinspec {

// Fields of `skinspec fit`: name, site, params, stderr, rmse, max_abs_error, delta_e00_d65,
// iterations, converged, wavelength_nm, measured, fitted. An unbounded standard error (a
// parameter the spectrum cannot determine) is null.
nlohmann::json fit_to_json(std::string_view name, const FitResult& fit);

nlohmann::json params_to_json(const Params& params);

}  // namespace skinspec
