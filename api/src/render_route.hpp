#pragma once
// GET /api/v1/fits/{id}/render.png: a stored fit's skin on the procedural hand, rendered by
// render/ with the query's illuminant, pigment scales and size, cached by those parameters.

#include <map>
#include <string>

#include "skinspec/api/render_cache.hpp"
#include "skinspec/api/router.hpp"
#include "skinspec/fit/fitter.hpp"
#include "skinspec/store/types.hpp"

namespace skinspec::api::detail {

// Query: illuminant (D65 or A), scale_melanin, scale_oxyhemoglobin, scale_deoxyhemoglobin,
// scale_bilirubin (0 to 100, default 1), size (WxH, each side 1 to kMaxRenderSide, default
// 256x256). Anything else, or a bad value, is a 400.
Response render_fit_png(const Fitter& fitter, const store::Fit& fit, const std::map<std::string, std::string>& query,
                        RenderCache& cache);

inline constexpr int kMaxRenderSide = 1024;

}  // namespace skinspec::api::detail
