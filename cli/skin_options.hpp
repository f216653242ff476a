#pragma once
// What `render` and `figures` share: the skin to show (from a fit's JSON or from a model, a
// site and its parameters), the reflection parameters of eq. 2-5, and writing a PNG safely.

#include <string>

#include "common.hpp"
#include "model_options.hpp"
#include "skinspec/render/figures.hpp"

namespace skinspec::cli {

struct SkinArgs {
  std::string fit_file;
  ModelKind model = kDefaultModel;
  std::string site = "forearm";
  ParamArgs params;  // over the model's defaults, a typical forearm (docs/model.md)
};

// --fit FILE.json, or --model and --site with the model's parameters.
void add_skin_options(CLI::App& app, SkinArgs& args);
// --roughness, --index, --alpha, --beta.
void add_surface_options(CLI::App& app, render::SurfaceParams& surface);

// The skin of the first JSON line of --fit (as `skinspec fit` prints it; a line without
// "model" is the paper's), or the model, site and parameters given; errors name the file and
// line.
render::Skin skin_from(const SkinArgs& args);

// "WxH" within the renderer's limits.
std::pair<int, int> parse_size(const std::string& text);

// Writes bytes beside `path` and renames them into place, so that a failure never leaves a
// partial file under the final name.
void write_file_atomically(const std::string& path, const std::vector<unsigned char>& bytes);

}  // namespace skinspec::cli
