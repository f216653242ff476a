// skinspec figures: the seed paper's figures 4-6 recreated as labelled contact sheets.

#include <filesystem>
#include <iostream>

#include "skin_options.hpp"
#include "skinspec/render/png.hpp"
#include "skinspec/render/scenes.hpp"

namespace skinspec::cli {

namespace {

struct FiguresArgs {
  SkinArgs skin;
  std::string out_dir;
  std::string size = "256x256";
  render::SurfaceParams surface;
  int bits = 8;
};

void run_figures(const FiguresArgs& args) {
  const auto [width, height] = parse_size(args.size);
  const render::Skin skin = skin_from(args.skin);
  std::error_code ec;
  std::filesystem::create_directories(args.out_dir, ec);
  if (ec || !std::filesystem::is_directory(args.out_dir))
    throw Failure{kBadInput, args.out_dir + ": cannot create the directory" + (ec ? ": " + ec.message() : "")};
  render::RenderSettings cell;
  cell.width = width;
  cell.height = height;
  cell.surface = args.surface;
  cell.samples_per_side = 2;
  const auto& f = fitter();
  const auto scene = render::builtin_scene(render::SceneKind::hand, static_cast<double>(width) / height);
  const auto figures = render::paper_figures(f.optics(skin.model), f.colorimetry(), skin, scene, cell);
  if (!figures) throw Failure{kBadInput, figures.error()};
  for (const auto& figure : *figures) {
    const auto png = render::encode_png(figure.image, args.bits);
    if (!png) throw Failure{kFailure, png.error()};
    const auto path = (std::filesystem::path(args.out_dir) / figure.file_name).string();
    write_file_atomically(path, *png);
    std::cout << path << '\n';
  }
}

}  // namespace

void add_figures_command(CLI::App& app) {
  auto args = std::make_shared<FiguresArgs>();
  auto* cmd = app.add_subcommand(
      "figures", "recreate the paper's figures 4-6 (illuminants, melanin x haemoglobin, bilirubin) as PNGs");
  cmd->add_option("--out", args->out_dir,
                  "directory for figure4_illuminants.png, figure5_melanin_haemoglobin.png, figure6_bilirubin.png")
      ->required();
  add_skin_options(*cmd, args->skin);
  cmd->add_option("--size", args->size, "size of each image of a sheet, WxH")->capture_default_str();
  add_surface_options(*cmd, args->surface);
  cmd->add_option("--bits", args->bits, "bits per PNG channel")->check(CLI::IsMember({8, 16}))->capture_default_str();
  cmd->callback([args] { run_figures(*args); });
}

}  // namespace skinspec::cli
