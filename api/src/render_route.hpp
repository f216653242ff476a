#pragma once
// GET /api/v1/fits/{id}/render.png: a stored fit's skin on the procedural hand, rendered by
// render/ with the query's illuminant, changes of the fit's own parameters and size, cached by
// the parameters rendered.

#include <map>
#include <string>

#include <nlohmann/json.hpp>

#include "skinspec/api/render_cache.hpp"
#include "skinspec/api/router.hpp"
#include "skinspec/fit/fitter.hpp"
#include "skinspec/store/types.hpp"

namespace skinspec::api::detail {

// Query: illuminant (D65 or A), size (WxH, each side 1 to kMaxRenderSide, default 256x256),
// and for the parameters of the fit's model (ParamSpec): NAME=VALUE sets one within its domain,
// scale_NAME=FACTOR (0 to 100) multiplies an absorber's amount, the product held to its domain.
// A parameter the fit's model does not have is a 400 unknown_parameter; a bad value, a scale of
// what is not an amount, or both forms of one parameter a 400 invalid_parameter.
Response render_fit_png(const Fitter& fitter, const store::Fit& fit, const std::map<std::string, std::string>& query,
                        RenderCache& cache);

// The query parameters above as OpenAPI parameter objects: those of every model, each saying
// which models have it.
nlohmann::json render_query_parameters();

inline constexpr int kMaxRenderSide = 1024;

}  // namespace skinspec::api::detail
