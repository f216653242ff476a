#pragma once
// What `render` and `figures` share: the skin to show (from a fit's JSON or from a site and
// five parameters), the reflection parameters of eq. 2-5, and writing a PNG safely.

#include <string>

#include "common.hpp"
#include "skinspec/render/figures.hpp"

namespace skinspec::cli {

struct SkinArgs {
  std::string fit_file;
  std::string site = "forearm";
  // A typical forearm (docs/model.md): Rs 0.04, melanin 5, oxy 6, deoxy 3, bilirubin 1.
  Params params{0.04, 5, 6, 3, 1};
};

// --fit FILE.json, or --site with --surface and the four pigment weights.
void add_skin_options(CLI::App& app, SkinArgs& args);
// --roughness, --index, --alpha, --beta.
void add_surface_options(CLI::App& app, render::SurfaceParams& surface);

// The skin of the first JSON line of --fit (as `skinspec fit` prints it), or the site and
// parameters given; errors name the file and line.
render::Skin skin_from(const SkinArgs& args);

// "WxH" within the renderer's limits.
std::pair<int, int> parse_size(const std::string& text);

// Writes bytes beside `path` and renames them into place, so that a failure never leaves a
// partial file under the final name.
void write_file_atomically(const std::string& path, const std::vector<unsigned char>& bytes);

}  // namespace skinspec::cli
