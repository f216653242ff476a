// skinspec render: a fitted (or described) skin on the procedural hand, a sphere or a mesh
// file, under an illuminant, with pigments scaled, written as PNG.

#include <iostream>

#include "skin_options.hpp"
#include "skinspec/render/png.hpp"
#include "skinspec/render/scenes.hpp"

namespace skinspec::cli {

namespace {

struct RenderArgs {
  SkinArgs skin;
  std::string illuminant = "D65";
  render::PigmentScales scales;
  std::string mesh_file;
  std::string scene = "hand";
  std::string size = "512x512";
  render::SurfaceParams surface;
  int bits = 8;
  int samples = 2;
  std::string output;
};

render::Scene scene_from(const RenderArgs& args, double aspect) {
  if (args.mesh_file.empty())
    return render::builtin_scene(args.scene == "sphere" ? render::SceneKind::sphere : render::SceneKind::hand, aspect);
  auto mesh = render::parse_mesh(read_input(args.mesh_file), input_name(args.mesh_file));
  if (!mesh) throw Failure{kBadInput, mesh.error().what()};
  return render::framed_scene(std::move(*mesh), aspect);
}

void run_render(const RenderArgs& args) {
  const auto [width, height] = parse_size(args.size);
  const render::Skin skin = skin_from(args.skin);
  const Spectrum illuminant = illuminant_from(args.illuminant);
  const render::Scene scene = scene_from(args, static_cast<double>(width) / height);
  render::RenderSettings settings;
  settings.width = width;
  settings.height = height;
  settings.surface = args.surface;
  settings.samples_per_side = args.samples;
  const auto& f = fitter();
  const auto image =
      render::render_skin(f.optics(skin.model), f.colorimetry(), skin, args.scales, illuminant, scene, settings);
  if (!image) throw Failure{kBadInput, image.error()};
  const auto png = render::encode_png(*image, args.bits);
  if (!png) throw Failure{kFailure, png.error()};
  write_file_atomically(args.output, *png);
}

void add_scale_options(CLI::App& app, render::PigmentScales& s) {
  const std::pair<const char*, double*> scales[] = {{"--scale-melanin", &s.melanin},
                                                    {"--scale-oxyhemoglobin", &s.oxyhemoglobin},
                                                    {"--scale-deoxyhemoglobin", &s.deoxyhemoglobin},
                                                    {"--scale-bilirubin", &s.bilirubin}};
  for (const auto& [name, value] : scales)
    app.add_option(name, *value, "multiply this pigment's weight")
        ->check(finite_range(0, render::kMaxPigmentScale))
        ->capture_default_str();
}

}  // namespace

void add_render_command(CLI::App& app) {
  auto args = std::make_shared<RenderArgs>();
  auto* cmd = app.add_subcommand("render", "render skin with the Torrance-Sparrow model as a PNG image");
  add_skin_options(*cmd, args->skin);
  cmd->add_option("--illuminant", args->illuminant, "D65, A, or a CSV file wavelength_nm,power covering 380-780 nm")
      ->capture_default_str();
  add_scale_options(*cmd, args->scales);
  auto* mesh = cmd->add_option("--mesh", args->mesh_file,
                               "a triangle mesh to render instead: .obj or .ply (ASCII or binary little-endian)");
  cmd->add_option("--scene", args->scene, "built-in scene")
      ->check(CLI::IsMember({"hand", "sphere"}))
      ->excludes(mesh)
      ->capture_default_str();
  cmd->add_option("--size", args->size, "image size WxH")->capture_default_str();
  add_surface_options(*cmd, args->surface);
  cmd->add_option("--bits", args->bits, "bits per PNG channel")->check(CLI::IsMember({8, 16}))->capture_default_str();
  cmd->add_option("--samples", args->samples, "rays per pixel along each side (anti-aliasing)")
      ->check(CLI::Range(1, render::kMaxSamplesPerSide))
      ->capture_default_str();
  cmd->add_option("-o,--output", args->output, "the PNG file to write")->required();
  cmd->callback([args] { run_render(*args); });
}

}  // namespace skinspec::cli
