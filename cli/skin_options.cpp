#include "skin_options.hpp"

#include <filesystem>
#include <fmt/format.h>
#include <fstream>
#include <nlohmann/json.hpp>

namespace skinspec::cli {

namespace {

// The first non-blank line and its 1-based number.
std::pair<std::string, std::size_t> first_line(const std::string& bytes) {
  std::size_t number = 0, start = 0;
  while (start < bytes.size()) {
    ++number;
    const std::size_t end = std::min(bytes.find('\n', start), bytes.size());
    const std::string line = bytes.substr(start, end - start);
    if (line.find_first_not_of(" \t\r") != std::string::npos) return {line, number};
    start = end + 1;
  }
  return {"", 0};
}

render::Skin skin_from_fit_json(const std::string& path) {
  const std::string name = input_name(path);
  const auto [line, number] = first_line(read_input(path));
  if (number == 0) throw Failure{kBadInput, name + ": empty; expected a line of `skinspec fit` JSON"};
  const auto fail = [&](const std::string& why) {
    return Failure{kBadInput, fmt::format("{}:{}: {}", name, number, why)};
  };
  const auto document = nlohmann::json::parse(line, nullptr, false);
  if (document.is_discarded() || !document.is_object()) throw fail("not a JSON object as `skinspec fit` prints");
  if (!document.contains("site") || !document["site"].is_string()) throw fail("no \"site\" text");
  if (!document.contains("params") || !document["params"].is_object()) throw fail("no \"params\" object");
  render::Skin skin;
  skin.model = ModelKind::paper;
  if (document.contains("model")) {
    const auto model =
        document["model"].is_string() ? parse_model_kind(document["model"].get<std::string>()) : std::nullopt;
    if (!model) throw fail("\"model\" must be one of " + model_names());
    skin.model = *model;
  }
  const auto site = fitter().optics(skin.model).site(document["site"].get<std::string>());
  if (!site) throw fail(site.error());
  skin.site = *site;
  for (const ParamSpec& spec : model_spec(skin.model).params) {
    const std::string key(spec.name);
    const auto& value = document["params"].contains(key) ? document["params"][key] : nlohmann::json();
    if (!value.is_number()) throw fail("params." + key + " is missing or not a number");
    skin.params.push_back(value.get<double>());
  }
  return skin;
}

}  // namespace

void add_skin_options(CLI::App& app, SkinArgs& args) {
  auto* fit =
      app.add_option("--fit", args.fit_file, "a fit's JSON, as printed by `skinspec fit` (its first line is used)");
  std::vector<CLI::Option*> direct{add_model_option(app, args.model), add_site_option(app, args.site)};
  for (auto* option : add_param_options(app, args.params)) direct.push_back(option);
  for (auto* option : direct) fit->excludes(option);
}

void add_surface_options(CLI::App& app, render::SurfaceParams& s) {
  app.add_option("--roughness", s.roughness, "gamma of eq. 3: facet angle (radians) where D halves")
      ->check(finite_range(1e-3, 1.5707963))
      ->capture_default_str();
  app.add_option("--index", s.index, "refractive index n of eq. 4")
      ->check(finite_range(1.0001, 5))
      ->capture_default_str();
  app.add_option("--alpha", s.alpha, "weight of the body term of eq. 2")
      ->check(finite_range(0, 100))
      ->capture_default_str();
  app.add_option("--beta", s.beta, "weight of the specular term of eq. 2")
      ->check(finite_range(0, 100))
      ->capture_default_str();
}

render::Skin skin_from(const SkinArgs& args) {
  if (!args.fit_file.empty()) return skin_from_fit_json(args.fit_file);
  const auto site = fitter().optics(args.model).site(args.site);
  if (!site) throw Failure{kBadInput, site.error()};
  return {*site, params_for(args.model, args.params), args.model};
}

std::pair<int, int> parse_size(const std::string& text) {
  const auto size = render::parse_image_size(text);
  if (!size)
    throw Failure{kBadInput, fmt::format("--size {}: expected WxH with each side 1..{}, such as 512x512", quote(text),
                                         render::kMaxImageSide)};
  return *size;
}

void write_file_atomically(const std::string& path, const std::vector<unsigned char>& bytes) {
  const std::string temporary = path + ".partial";
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    if (!out.flush()) {
      std::error_code ignored;
      std::filesystem::remove(temporary, ignored);
      throw Failure{kBadInput, path + ": cannot write the file"};
    }
  }
  std::error_code ec;
  std::filesystem::rename(temporary, path, ec);
  if (ec) throw Failure{kBadInput, path + ": cannot write the file: " + ec.message()};
}

}  // namespace skinspec::cli
