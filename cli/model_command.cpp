// skinspec model: the forward model's reflectance for given parameters, as CSV.

#include <cmath>
#include <fmt/format.h>
#include <iostream>

#include "common.hpp"
#include "model_options.hpp"

namespace skinspec::cli {

namespace {

struct ModelArgs {
  ModelKind model = kDefaultModel;
  std::string site = "forearm";
  ParamArgs params;
  bool no_lateral_diffusion = false;
  std::string grid = "380:780:1";
};

// "FIRST:LAST:STEP" inside the model's range.
std::vector<double> parse_grid(const std::string& text) {
  double first = 0, last = 0, step = 0;
  char c1 = 0, c2 = 0;
  std::istringstream in(text);
  if (!(in >> first >> c1 >> last >> c2 >> step) || c1 != ':' || c2 != ':' || !in.eof() || !(step > 0) ||
      !(last >= first) || first < SkinOptics::kFirstNm || last > SkinOptics::kLastNm)
    throw Failure{kBadInput, "--grid " + quote(text) + ": expected FIRST:LAST:STEP inside 380:780, step > 0"};
  return Spectrum::uniform_grid(first, last, step);
}

void run_model(const ModelArgs& args) {
  const auto grid = parse_grid(args.grid);
  const Params params = params_for(args.model, args.params);
  const SkinOptics& optics = fitter().optics(args.model);
  const auto site = optics.site(args.site);
  if (!site) throw Failure{kBadInput, site.error()};
  const SkinModel model(optics, *site, grid, !args.no_lateral_diffusion);
  const auto reflectance = model.reflectance(params);
  std::cout << "wavelength_nm,reflectance\n";
  for (std::size_t i = 0; i < grid.size(); ++i) std::cout << fmt::format("{},{:.10g}\n", grid[i], reflectance[i]);
}

}  // namespace

void add_model_command(CLI::App& app) {
  auto args = std::make_shared<ModelArgs>();
  auto* model =
      app.add_subcommand("model", "print the model's reflectance for given parameters (defaults: docs/model.md)");
  add_model_option(*model, args->model);
  add_site_option(*model, args->site);
  add_param_options(*model, args->params);
  model->add_flag("--no-lateral-diffusion", args->no_lateral_diffusion,
                  "leave out the correction for light lost outside the measured spot");
  model->add_option("--grid", args->grid, "wavelength grid FIRST:LAST:STEP in nm")->capture_default_str();
  model->callback([args] { run_model(*args); });
}

}  // namespace skinspec::cli
