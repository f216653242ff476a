#include "fit_json.hpp"

#include <cmath>

namespace skinspec {

namespace {
nlohmann::json finite_or_null(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }
}  // namespace

nlohmann::json params_to_json(const Params& params) {
  nlohmann::json out = nlohmann::json::object();
  for (std::size_t i = 0; i < params.size(); ++i) out[std::string(kParamNames[i])] = finite_or_null(params[i]);
  return out;
}

nlohmann::json fit_to_json(std::string_view name, const FitResult& fit) {
  return {
      {"name", name},
      {"site", fit.site},
      {"params", params_to_json(fit.params)},
      {"stderr", params_to_json(fit.standard_error)},
      {"rmse", fit.rmse},
      {"max_abs_error", fit.max_abs_error},
      {"delta_e00_d65", fit.delta_e00_d65},
      {"iterations", fit.iterations},
      {"converged", fit.converged},
      {"wavelength_nm", fit.wavelength_nm},
      {"measured", fit.measured},
      {"fitted", fit.fitted},
  };
}

}  // namespace skinspec
