#include "render_route.hpp"

#include <charconv>
#include <cmath>
#include <fmt/format.h>

#include "json_io.hpp"
#include "skinspec/records/fit_record.hpp"
#include "skinspec/render/figures.hpp"
#include "skinspec/render/png.hpp"
#include "skinspec/render/scenes.hpp"

namespace skinspec::api {

namespace detail {

namespace {

struct RenderQuery {
  std::string illuminant = "D65";
  render::PigmentScales scales;
  int width = 256, height = 256;
};

[[noreturn]] void bad_parameter(const std::string& name, const std::string& why) {
  fail(ErrorKind::bad_request, "invalid_parameter", "'" + name + "' " + why);
}

double scale_value(const std::string& name, const std::string& text) {
  double v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc{} || end != text.data() + text.size() || !std::isfinite(v) || v < 0 ||
      v > render::kMaxPigmentScale)
    bad_parameter(name, fmt::format("must be a number from 0 to {}", render::kMaxPigmentScale));
  return v;
}

std::pair<int, int> size_value(const std::string& text) {
  const auto size = render::parse_image_size(text, kMaxRenderSide);
  if (!size) bad_parameter("size", fmt::format("must be WxH with each side 1 to {}, such as 256x256", kMaxRenderSide));
  return *size;
}

RenderQuery parse_query(const std::map<std::string, std::string>& query) {
  RenderQuery q;
  const std::pair<const char*, double*> scales[] = {{"scale_melanin", &q.scales.melanin},
                                                    {"scale_oxyhemoglobin", &q.scales.oxyhemoglobin},
                                                    {"scale_deoxyhemoglobin", &q.scales.deoxyhemoglobin},
                                                    {"scale_bilirubin", &q.scales.bilirubin}};
  for (const auto& [name, text] : query) {
    const auto* scale = std::ranges::find(scales, name, [](const auto& s) { return std::string_view(s.first); });
    if (scale != std::end(scales)) *scale->second = scale_value(name, text);
    else if (name == "size") std::tie(q.width, q.height) = size_value(text);
    else if (name == "illuminant") {
      if (text != "D65" && text != "A") bad_parameter("illuminant", "must be D65 or A");
      q.illuminant = text;
    } else fail(ErrorKind::bad_request, "unknown_parameter", "unknown query parameter '" + name + "'");
  }
  return q;
}

// Everything the image depends on, in a fixed order and format; the fit's id stands for its
// site and parameters because a stored fit never changes.
std::string cache_key(store::Id fit_id, const RenderQuery& q) {
  return fmt::format("{}|{}|{}x{}|{:.17g}|{:.17g}|{:.17g}|{:.17g}", fit_id, q.illuminant, q.width, q.height,
                     q.scales.melanin, q.scales.oxyhemoglobin, q.scales.deoxyhemoglobin, q.scales.bilirubin);
}

std::string render_png(const Fitter& fitter, const store::Fit& fit, const RenderQuery& q) {
  const auto result = records::to_fit_result(fit);
  if (!result) fail(ErrorKind::unprocessable, "unknown_model", result.error());
  const SkinOptics& optics = fitter.optics(result->model);
  const auto site = optics.site(fit.site);
  if (!site) fail(ErrorKind::unprocessable, "unknown_site", "fit " + std::to_string(fit.id) + ": " + site.error());
  const render::Skin skin{*site, result->params, result->model};
  render::RenderSettings settings;
  settings.width = q.width;
  settings.height = q.height;
  settings.samples_per_side = 2;
  const auto scene = render::builtin_scene(render::SceneKind::hand, static_cast<double>(q.width) / q.height);
  const auto image = render::render_skin(optics, fitter.colorimetry(), skin, q.scales,
                                         *fitter.colorimetry().illuminant(q.illuminant), scene, settings);
  if (!image) fail(ErrorKind::unprocessable, "render_failed", image.error());
  const auto png = render::encode_png(*image, 8);
  if (!png) fail(ErrorKind::internal, "render_failed", png.error());
  return {png->begin(), png->end()};
}

}  // namespace

Response render_fit_png(const Fitter& fitter, const store::Fit& fit, const std::map<std::string, std::string>& query,
                        RenderCache& cache) {
  const RenderQuery q = parse_query(query);
  const std::string key = cache_key(fit.id, q);
  auto png = cache.find(key);
  const bool hit = png.has_value();
  if (!hit) {
    png = render_png(fitter, fit, q);
    cache.put(key, *png);
  }
  Response r{200, "image/png", std::move(*png), {}};
  r.headers.emplace_back("X-Render-Cache", hit ? "hit" : "miss");
  return r;
}

}  // namespace detail

}  // namespace skinspec::api
