#include "render_route.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fmt/format.h>
#include <fmt/ranges.h>

#include "json_io.hpp"
#include "skinspec/fit/model_spec.hpp"
#include "skinspec/records/fit_record.hpp"
#include "skinspec/render/figures.hpp"
#include "skinspec/render/png.hpp"
#include "skinspec/render/scenes.hpp"

namespace skinspec::api {

namespace detail {

namespace {

using nlohmann::json;

constexpr std::string_view kScalePrefix = "scale_";

struct RenderQuery {
  std::string illuminant = "D65";
  std::vector<render::ParamChange> changes;
  int width = 256, height = 256;
};

[[noreturn]] void bad_parameter(const std::string& name, const std::string& why) {
  fail(ErrorKind::bad_request, "invalid_parameter", "'" + name + "' " + why);
}

std::pair<int, int> size_value(const std::string& text) {
  const auto size = render::parse_image_size(text, kMaxRenderSide);
  if (!size) bad_parameter("size", fmt::format("must be WxH with each side 1 to {}, such as 256x256", kMaxRenderSide));
  return *size;
}

double number_value(const std::string& name, const std::string& text) {
  double v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc{} || end != text.data() + text.size() || !std::isfinite(v))
    bad_parameter(name, "must be a number");
  return v;
}

// NAME or scale_NAME, for a parameter of `model`; 400 for one it does not have, a bad value, or
// a parameter changed twice.
render::ParamChange param_change(ModelKind model, const std::string& key, const std::string& text,
                                 const std::vector<render::ParamChange>& earlier) {
  const bool scale = key.starts_with(kScalePrefix);
  const std::string name = scale ? key.substr(kScalePrefix.size()) : key;
  const auto index = param_index(model, name);
  if (!index) {
    std::vector<std::string_view> names;
    for (const ParamSpec& spec : model_spec(model).params) names.push_back(spec.name);
    fail(ErrorKind::bad_request, "unknown_parameter",
         fmt::format("unknown query parameter '{}': a fit of the {} model has the parameters {}", key, to_string(model),
                     fmt::join(names, ", ")));
  }
  if (std::ranges::any_of(earlier, [&](const render::ParamChange& c) { return c.index == *index; }))
    bad_parameter(key, fmt::format("changes {} a second time: give '{}' or 'scale_{}', not both", name, name, name));
  const auto kind = scale ? render::ParamChange::Kind::scale : render::ParamChange::Kind::value;
  const auto change = render::param_change(model, *index, kind, number_value(key, text));
  if (!change) bad_parameter(key, "is refused: " + change.error());
  return *change;
}

RenderQuery parse_query(ModelKind model, const std::map<std::string, std::string>& query) {
  RenderQuery q;
  for (const auto& [name, text] : query) {
    if (name == "size") std::tie(q.width, q.height) = size_value(text);
    else if (name == "illuminant") {
      if (text != "D65" && text != "A") bad_parameter("illuminant", "must be D65 or A");
      q.illuminant = text;
    } else q.changes.push_back(param_change(model, name, text, q.changes));
  }
  return q;
}

// Everything the image depends on, in a fixed order and format: the fit's id stands for its
// site (a stored fit never changes), the parameters rendered for the changes, so that a query
// that changes nothing shares the fit's own image.
std::string cache_key(store::Id fit_id, const RenderQuery& q, const Params& rendered) {
  return fmt::format("{}|{}|{}x{}|{:.17g}", fit_id, q.illuminant, q.width, q.height, fmt::join(rendered, "|"));
}

std::string render_png(const Fitter& fitter, const store::Fit& fit, ModelKind model, const Params& rendered,
                       const RenderQuery& q) {
  const SkinOptics& optics = fitter.optics(model);
  const auto site = optics.site(fit.site);
  if (!site) fail(ErrorKind::unprocessable, "unknown_site", "fit " + std::to_string(fit.id) + ": " + site.error());
  const render::Skin skin{*site, rendered, model};
  render::RenderSettings settings;
  settings.width = q.width;
  settings.height = q.height;
  settings.samples_per_side = 2;
  const auto scene = render::builtin_scene(render::SceneKind::hand, static_cast<double>(q.width) / q.height);
  const auto image = render::render_skin(optics, fitter.colorimetry(), skin, {},
                                         *fitter.colorimetry().illuminant(q.illuminant), scene, settings);
  if (!image) fail(ErrorKind::unprocessable, "render_failed", image.error());
  const auto png = render::encode_png(*image, 8);
  if (!png) fail(ErrorKind::internal, "render_failed", png.error());
  return {png->begin(), png->end()};
}

json query_parameter(const std::string& name, json schema, const std::string& description) {
  return {{"name", name}, {"in", "query"}, {"required", false}, {"schema", schema}, {"description", description}};
}

}  // namespace

Response render_fit_png(const Fitter& fitter, const store::Fit& fit, const std::map<std::string, std::string>& query,
                        RenderCache& cache) {
  const auto result = records::to_fit_result(fit);
  if (!result) fail(ErrorKind::unprocessable, "unknown_model", result.error());
  const RenderQuery q = parse_query(result->model, query);
  const auto rendered = render::changed_params(result->model, result->params, q.changes);
  if (!rendered)
    fail(ErrorKind::unprocessable, "render_failed", "fit " + std::to_string(fit.id) + ": " + rendered.error());
  const std::string key = cache_key(fit.id, q, *rendered);
  auto png = cache.find(key);
  const bool hit = png.has_value();
  if (!hit) {
    png = render_png(fitter, fit, result->model, *rendered, q);
    cache.put(key, *png);
  }
  Response r{200, "image/png", std::move(*png), {}};
  r.headers.emplace_back("X-Render-Cache", hit ? "hit" : "miss");
  return r;
}

json render_query_parameters() {
  json params =
      json::array({query_parameter("illuminant", {{"type", "string"}, {"enum", {"D65", "A"}}, {"default", "D65"}},
                                   "CIE illuminant"),
                   query_parameter("size", {{"type", "string"}, {"pattern", "^[0-9]+x[0-9]+$"}, {"default", "256x256"}},
                                   fmt::format("image size WxH, each side 1 to {}", kMaxRenderSide))});
  // Each parameter once, in the order the models list them, with the models that have it.
  std::vector<std::pair<const ParamSpec*, std::vector<std::string_view>>> seen;
  for (const ModelKind model : kModelKinds)
    for (const ParamSpec& spec : model_spec(model).params) {
      auto it = std::ranges::find(seen, spec.name, [](const auto& s) { return s.first->name; });
      if (it == seen.end()) it = seen.emplace(seen.end(), &spec, std::vector<std::string_view>{});
      it->second.push_back(to_string(model));
    }
  for (const auto& [spec, models] : seen) {
    const std::string of = fmt::format("a parameter of the {} model{}, in {}", fmt::join(models, " and "),
                                       models.size() > 1 ? "s" : "", spec->unit);
    params.push_back(query_parameter(
        std::string(spec->name), {{"type", "number"}, {"minimum", spec->domain_lower}, {"maximum", spec->domain_upper}},
        fmt::format("renders the fit with {} set to this value ({}); a 400 for a fit of another model", spec->name,
                    of)));
    if (spec->absorber)
      params.push_back(
          query_parameter(std::string(kScalePrefix) + std::string(spec->name),
                          {{"type", "number"}, {"minimum", 0}, {"maximum", render::kMaxPigmentScale}, {"default", 1}},
                          fmt::format("multiplies the fit's {} ({}), the product held to {}..{}; not with {} itself",
                                      spec->name, of, spec->domain_lower, spec->domain_upper, spec->name)));
  }
  return params;
}

}  // namespace detail

}  // namespace skinspec::api
