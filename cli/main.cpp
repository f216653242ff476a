// skinspec: fit, model, optics and colour of skin reflectance spectra from the command line.

#include <exception>
#include <iostream>
#include <sstream>

#include "common.hpp"
#include "skinspec/version.hpp"

namespace {

using namespace skinspec::cli;

// Everything written to stderr goes through here: whatever input a message quotes, it reaches
// the terminal as printable text.
void report(std::string_view message) {
  std::cout.flush();
  std::cerr << printable_message(message);
  if (!message.ends_with('\n')) std::cerr << '\n';
}

int run(int argc, char** argv) {
  CLI::App app{"skinspec: skin reflectance spectra, the two-layer Kubelka-Munk model and its fit"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "skinspec " + std::string(skinspec::kVersion));
  add_fit_command(app);
  add_model_command(app);
  add_optics_command(app);
  add_colour_command(app);
  add_tune_command(app);
  add_ports_command(app);
  add_measure_command(app);
  add_export_command(app);
  add_migrate_db_command(app);
  add_backup_command(app);
  add_refit_command(app);
  add_import_command(app);
  add_session_command(app);
  add_render_command(app);
  add_figures_command(app);
  add_map_command(app);
  add_token_command(app);
  // CLI11 reports a mistyped subcommand only as "a subcommand is required"; name it instead.
  if (argc > 1 && argv[1][0] != '-' &&
      app.get_subcommands([&](CLI::App* sub) { return sub->check_name(argv[1]); }).empty()) {
    std::string commands;
    for (const auto* sub : app.get_subcommands({})) commands += (commands.empty() ? "" : ", ") + sub->get_name();
    report("skinspec: unknown command " + skinspec::quote(argv[1]) + "; commands: " + commands);
    return kBadInput;
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // CLI11 quotes the arguments it refuses as they were given.
    std::ostringstream message;
    const int status = app.exit(e, std::cout, message);
    if (!message.view().empty()) report(message.view());
    return status == 0 ? kOk : kBadInput;
  } catch (const Failure& failure) {
    report("skinspec: " + failure.message);
    return failure.status;
  }
  return kOk;
}

}  // namespace

// Nothing may end the program by an uncaught exception (std::terminate, exit 134): what
// escapes a command is reported, as skinspec's own failure.
int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    report(std::string("skinspec: internal error: ") + e.what());
  } catch (...) {
    report("skinspec: internal error of an unknown kind");
  }
  return kFailure;
}
