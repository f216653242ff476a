// skinspec: fit, model, optics and colour of skin reflectance spectra from the command line.

#include <iostream>

#include "common.hpp"
#include "skinspec/version.hpp"

int main(int argc, char** argv) {
  using namespace skinspec::cli;
  CLI::App app{"skinspec: skin reflectance spectra, the two-layer Kubelka-Munk model and its fit"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "skinspec " + std::string(skinspec::kVersion));
  add_fit_command(app);
  add_model_command(app);
  add_optics_command(app);
  add_color_command(app);
  add_tune_command(app);
  add_ports_command(app);
  add_measure_command(app);
  add_export_command(app);
  add_session_command(app);
  add_render_command(app);
  add_figures_command(app);
  // CLI11 reports a mistyped subcommand only as "a subcommand is required"; name it instead.
  if (argc > 1 && argv[1][0] != '-' && app.get_subcommands([&](CLI::App* sub) { return sub->get_name() == argv[1]; }).empty()) {
    std::cerr << "skinspec: unknown command '" << argv[1] << "'; commands: fit, model, optics, color, tune, ports, measure, export, session, render, figures\n";
    return kBadInput;
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int status = app.exit(e);
    return status == 0 ? kOk : kBadInput;
  } catch (const Failure& failure) {
    std::cout.flush();
    std::cerr << "skinspec: " << failure.message << '\n';
    return failure.status;
  }
  return kOk;
}
