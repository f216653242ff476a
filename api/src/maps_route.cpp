#include "maps_route.hpp"

#include <fmt/format.h>

#include <charconv>
#include <cmath>
#include <cstring>

#include "fit_json.hpp"
#include "http_caching.hpp"
#include "json_io.hpp"
#include "skinspec/fit/model_spec.hpp"
#include "skinspec/maps/colour_map.hpp"
#include "skinspec/spectral/colour.hpp"
#include "text.hpp"

namespace skinspec::api::detail {

using nlohmann::json;

namespace {

ModelKind model_named(const std::string& name) {
  const auto model = parse_model_kind(name);
  if (!model)
    fail(ErrorKind::unprocessable, "unknown_model", "unknown model '" + name + "' (known: " + model_names() + ")");
  return *model;
}

maps::Region region_of(const std::vector<double>& v) {
  if (v.size() != 4 || v[2] < 1 || v[3] < 1)
    fail(ErrorKind::unprocessable, "invalid_value", "'white_roi' must be x, y, width and height in pixels");
  const auto at = [&](std::size_t i) { return static_cast<std::size_t>(v[i]); };
  return {at(0), at(1), at(2), at(3)};
}

std::vector<double> whole_numbers(const json& value) {
  std::vector<double> out;
  if (value.is_array())
    for (const auto& v : value)
      if (v.is_number_unsigned() && v.get<std::uint64_t>() < (1u << 30)) out.push_back(v.get<double>());
  if (!value.is_array() || out.size() != value.size())
    fail(ErrorKind::unprocessable, "wrong_type", "'white_roi' must be four whole numbers: x, y, width, height");
  return out;
}

template <typename T>
T parsed(const std::string& text, const char* name) {
  T value{};
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || text.empty())
    fail(ErrorKind::bad_request, "invalid_parameter", fmt::format("'{}' is not a number: {}", name, text));
  return value;
}

// A map's tag: its id and the moment it was stored, so a database made again never matches.
std::string map_etag(const store::Map& map) {
  return fmt::format("\"map-{}-{:x}\"", map.id, map.created_at.time_since_epoch().count());
}

// The mask band's numbers and their names.
json mask_reasons_json() {
  json out = json::array();
  for (const auto reason : maps::kMaskReasons) out.push_back(std::string(maps::to_string(reason)));
  return out;
}

std::string hex(const std::array<double, 3>& linear) {
  const auto c = srgb_8bit(linear);
  return fmt::format("#{:02x}{:02x}{:02x}", c[0], c[1], c[2]);
}

// The pictures' colour map as 8-bit sRGB, for a client that draws a map itself: the same
// colours as the PNGs, from maps/'s one definition.
const json& colour_map_json() {
  static const json table = [] {
    constexpr int kSteps = 256;
    json colours = json::array();
    for (int i = 0; i < kSteps; ++i) colours.push_back(hex(maps::map_linear_srgb(i / double(kSteps - 1))));
    return json{{"colours", colours},
                {"not_determined", hex(maps::lab_to_linear_srgb(maps::kNotDeterminedLab))},
                {"not_skin", hex(maps::lab_to_linear_srgb(maps::kMaskedLab))}};
  }();
  return table;
}

template <typename T>
T stored(store::Result<T> result) {
  if (!result) fail_store(result.error());
  return std::move(*result);
}

}  // namespace

MapAsk map_ask_of_json(const std::string& body) {
  const json object = parse_object(body);
  only_fields(object,
              {"path", "name", "model", "site", "session_id", "white_roi", "white", "dark", "white_reflectance"});
  MapAsk ask;
  ask.path = required_string(object, "path", 4096);
  ask.name = optional_string(object, "name", 100).value_or("");
  if (auto model = optional_string(object, "model", 64)) ask.model = model_named(*model);
  ask.site = optional_string(object, "site", 64).value_or(ask.site);
  ask.session_id = optional_id(object, "session_id");
  if (const auto it = object.find("white_roi"); it != object.end()) ask.white_roi = region_of(whole_numbers(*it));
  ask.white = optional_string(object, "white", 4096).value_or("");
  ask.dark = optional_string(object, "dark", 4096).value_or("");
  if (const auto it = object.find("white_reflectance"); it != object.end()) {
    if (!it->is_number()) fail(ErrorKind::unprocessable, "wrong_type", "'white_reflectance' must be a number");
    ask.white_reflectance = it->get<double>();
  }
  return ask;
}

MapAsk map_ask_of_upload(std::string body, const std::map<std::string, std::string>& query) {
  MapAsk ask;
  for (const auto& [name, text] : query) {
    if (name == "name") {
      ask.name = text;
    } else if (name == "model") {
      ask.model = model_named(text);
    } else if (name == "site") {
      ask.site = text;
    } else if (name == "session_id") {
      ask.session_id = parsed<store::Id>(text, "session_id");
      if (*ask.session_id < 1) fail(ErrorKind::bad_request, "invalid_parameter", "'session_id' must be positive");
    } else if (name == "white_reflectance") {
      ask.white_reflectance = parsed<double>(text, "white_reflectance");
    } else if (name == "white_roi") {
      std::vector<double> v;
      for (std::size_t at = 0; at <= text.size();) {
        const auto comma = std::min(text.find(',', at), text.size());
        v.push_back(static_cast<double>(parsed<std::uint32_t>(text.substr(at, comma - at), "white_roi")));
        at = comma + 1;
      }
      ask.white_roi = region_of(v);
    } else {
      fail(ErrorKind::bad_request, "unknown_parameter", "unknown query parameter '" + name + "'");
    }
  }
  if (body.empty()) fail(ErrorKind::unprocessable, "empty_file", "the body holds no cube");
  ask.upload = std::move(body);
  return ask;
}

json map_json(const store::Map& map) {
  json summary = json::parse(map.summary, nullptr, false);
  const auto model = parse_model_kind(summary.value("model", ""));
  const std::string base = fmt::format("/api/v1/maps/{}", map.id);
  json pictures = json::object();
  for (const auto& parameter : map.pictures) pictures[parameter] = fmt::format("{}/{}.png", base, parameter);
  return {{"id", map.id},
          {"job_id", map.job_id},
          {"session_id", map.session_id ? json(*map.session_id) : json(nullptr)},
          {"name", map.name},
          {"created_at", format_time(map.created_at)},
          {"summary", summary},
          {"bands", model ? map_bands_json(*model) : json::array()},
          {"interleave", "bil"},
          {"data_type", "float32"},
          {"byte_order", "little-endian"},
          {"data_bytes", map.data_bytes},
          {"mask_reasons", mask_reasons_json()},
          {"colour_map", colour_map_json()},
          {"links", {{"cube", base + "/cube"}, {"header", base + "/cube.hdr"}, {"pictures", pictures}}}};
}

json map_list_json(const store::Store& store, const std::map<std::string, std::string>& query) {
  std::optional<store::Id> session;
  int limit = 100;
  for (const auto& [name, text] : query) {
    if (name == "session_id") session = parsed<store::Id>(text, "session_id");
    else if (name == "limit") limit = parsed<int>(text, "limit");
    else fail(ErrorKind::bad_request, "unknown_parameter", "unknown query parameter '" + name + "'");
  }
  if (limit < 1 || limit > 1000) fail(ErrorKind::bad_request, "invalid_parameter", "'limit' must be 1 to 1000");
  json maps = json::array();
  for (const auto& map : stored(store.maps(session, limit))) maps.push_back(map_json(map));
  return {{"maps", maps}};
}

Response map_picture_response(const Request& request, const store::Store& store, store::Id id,
                              const std::string& parameter) {
  const auto map = stored(store.map(id));
  if (std::ranges::find(map.pictures, parameter) == map.pictures.end())
    fail(ErrorKind::not_found, "not_found", fmt::format("map {} has no picture of '{}'", id, parameter));
  return identified_response(request, map_etag(map) + parameter, kImmutable, "image/png",
                             [&] { return stored(store.map_picture(id, parameter)); });
}

Response map_header_response(const Request& request, const store::Store& store, store::Id id) {
  const auto map = stored(store.map(id));
  return identified_response(request, map_etag(map) + "hdr", kImmutable, "text/plain; charset=utf-8",
                             [&] { return map.header; });
}

Response map_cube_response(const Request& request, const store::Store& store, store::Id id) {
  const auto map = stored(store.map(id));
  return identified_response(request, map_etag(map), kImmutable, "application/octet-stream", [&] {
    std::string data;
    data.reserve(static_cast<std::size_t>(map.data_bytes));
    const auto read = store.read_map_data(id, [&](std::string_view piece) {
      data.append(piece);
      return true;
    });
    if (!read) fail_store(read.error());
    return data;
  });
}

namespace {

// `count` float32 values (little-endian) of a map's part from value `first`.
std::vector<float> floats(const store::Store& store, store::Id id, store::MapPart part, std::size_t first,
                          std::size_t count) {
  const std::string raw = stored(store.read_map_bytes(id, part, static_cast<std::int64_t>(first * sizeof(float)),
                                                      static_cast<std::int64_t>(count * sizeof(float))));
  if (raw.size() != count * sizeof(float))
    fail(ErrorKind::internal, "", fmt::format("map {} is shorter than its summary", id));
  std::vector<float> out(count);
  std::memcpy(out.data(), raw.data(), raw.size());  // the store's bytes are this machine's floats (little-endian)
  return out;
}

json number_or_null(float v) { return std::isnan(v) ? json(nullptr) : json(static_cast<double>(v)); }

}  // namespace

json map_pixel_json(const store::Store& store, const Fitter& fitter, store::Id id,
                    const std::map<std::string, std::string>& query) {
  const auto map = stored(store.map(id));
  const json summary = json::parse(map.summary, nullptr, false);
  const auto model = parse_model_kind(summary.value("model", ""));
  const auto lines = summary.value("lines", std::size_t{0}), samples = summary.value("samples", std::size_t{0});
  const auto wavelengths = summary.value("wavelength_nm", std::vector<double>{});
  if (!model || map.reflectance_bytes == 0 || wavelengths.empty())
    fail(ErrorKind::not_found, "not_found", fmt::format("map {} keeps no spectra of its pixels", id));
  std::optional<std::size_t> x, y;
  for (const auto& [name, text] : query) {
    if (name == "x") x = parsed<std::size_t>(text, "x");
    else if (name == "y") y = parsed<std::size_t>(text, "y");
    else fail(ErrorKind::bad_request, "unknown_parameter", "unknown query parameter '" + name + "'");
  }
  if (!x || !y) fail(ErrorKind::bad_request, "missing_parameter", "give the pixel as x and y");
  if (*x >= samples || *y >= lines)
    fail(ErrorKind::unprocessable, "out_of_range", fmt::format("the map has {} × {} pixels", samples, lines));

  const auto bands = maps::map_bands(*model);
  // Band-interleaved by line: the pixel's line whole, band b of it at b × samples + x.
  const auto line = floats(store, id, store::MapPart::answers, *y * bands.size() * samples, bands.size() * samples);
  std::vector<float> answers;
  for (std::size_t b = 0; b < bands.size(); ++b) answers.push_back(line[b * samples + *x]);
  const auto measured =
      floats(store, id, store::MapPart::reflectance, (*y * samples + *x) * wavelengths.size(), wavelengths.size());
  json values = json::object();
  for (std::size_t b = 0; b + 1 < bands.size(); ++b) values[bands[b].name] = number_or_null(answers[b]);
  const auto reason = static_cast<std::size_t>(answers.back());
  const bool skin = reason == static_cast<std::size_t>(maps::MaskReason::skin);
  json out = {
      {"x", *x},
      {"y", *y},
      {"mask", reason < maps::kMaskReasons.size() ? std::string(maps::to_string(maps::kMaskReasons[reason])) : "?"},
      {"values", values},
      {"wavelength_nm", wavelengths},
      {"fit", nullptr}};
  json& measured_json = out["measured"] = json::array();
  for (const float v : measured) measured_json.push_back(number_or_null(v));
  if (!skin) return out;
  std::vector<double> reflectance(measured.begin(), measured.end());
  auto spectrum = Spectrum::create(wavelengths, reflectance);
  if (!spectrum) return out;
  FitOptions options;
  options.model = *model;
  options.site = summary.value("site", "forearm");
  if (auto fit = fitter.fit(*spectrum, options)) out["fit"] = fit_to_json(fmt::format("pixel ({}, {})", *x, *y), *fit);
  return out;
}

json map_upload_parameters() {
  const auto q = [](const char* name, json schema, const char* description) {
    return json{{"name", name}, {"in", "query"}, {"required", false}, {"schema", schema}, {"description", description}};
  };
  return json::array({
      q("name", {{"type", "string"}, {"maxLength", 100}}, "the map's name (default: upload)"),
      q("model", {{"type", "string"}}, "the skin model (default: the service's default model)"),
      q("site", {{"type", "string"}, {"default", "forearm"}}, "the body site"),
      q("session_id", {{"type", "integer"}, {"minimum", 1}}, "the session the map belongs to"),
      q("white_roi", {{"type", "string"}}, "a radiance cube: the white panel's region x,y,w,h in pixels"),
      q("white_reflectance", {{"type", "number"}, {"default", 0.99}}, "the white panel's calibrated reflectance"),
  });
}

}  // namespace skinspec::api::detail
