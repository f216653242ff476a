#pragma once
// What every skinspec subcommand shares: exit statuses, input reading, the loaded model.

#include <CLI/CLI.hpp>
#include <optional>
#include <string>
#include <vector>

#include "skinspec/fit/fitter.hpp"
#include "skinspec/spectral/spectra_csv.hpp"
#include "skinspec/spectral/utf8.hpp"
#include "skinspec/store/types.hpp"

namespace skinspec::cli {

// kFailure: skinspec itself failed (no memory, standard output unwritable, a defect of ours);
// kInstrumentError is also a measurement job of skinspecd that failed or was cancelled;
// kUnreachable: skinspecd could not be reached (or went away mid-answer).
enum ExitStatus : int { kOk = 0, kFailure = 1, kBadInput = 2, kInstrumentError = 3, kUnreachable = 4 };

// A failure that ends the subcommand with a message on stderr and the given status.
struct Failure {
  int status;
  std::string message;
};

// What the store refused or failed at: bad input (exit 2) when the target or what was asked
// of it is wrong (store::is_bad_target), a failure of ours or the disk's otherwise.
Failure store_failure(const store::StoreError& error);

// Reads FILE, or standard input for "-".
std::string read_input(const std::string& path);
// "<stdin>" for "-", else the path itself: the name errors are reported under.
std::string input_name(const std::string& path);
std::vector<NamedSpectrum> read_spectra(const std::string& path, const SpectraLimits& limits = {});
// The same, with how its values were read (limits.scale).
SpectraFile read_spectra_file(const std::string& path, const SpectraLimits& limits);

// D65, A, or a spectra CSV file whose first column is the illuminant's relative power.
Spectrum illuminant_from(const std::string& name);

// Like CLI::Range, but NaN is refused as well.
CLI::Validator finite_range(double min, double max);
// Text that is sent on or printed as text (a subject, a label): it must be UTF-8.
CLI::Validator utf8_text();

// A message as it may reach the terminal: every line of it through printable().
std::string printable_message(std::string_view message);

// The model tables and colorimetry from the data directory (loaded once per process).
const Fitter& fitter();

// Registers --site, validated against the shipped sites.
CLI::Option* add_site_option(CLI::App& app, std::string& site);
// Registers --scale auto|fraction|percent: how a file writes reflectance (reflectance_scale.hpp);
// `more` ends its help.
CLI::Option* add_scale_option(CLI::App& app, ScaleRequest& scale, std::string_view more = {});

void add_fit_command(CLI::App& app);
void add_model_command(CLI::App& app);
void add_map_command(CLI::App& app);
void add_optics_command(CLI::App& app);
void add_colour_command(CLI::App& app);
void add_tune_command(CLI::App& app);
void add_ports_command(CLI::App& app);
void add_measure_command(CLI::App& app);
void add_export_command(CLI::App& app);
void add_migrate_db_command(CLI::App& app);
void add_backup_command(CLI::App& app);
void add_refit_command(CLI::App& app);
void add_import_command(CLI::App& app);
void add_session_command(CLI::App& app);
void add_render_command(CLI::App& app);
void add_figures_command(CLI::App& app);
void add_token_command(CLI::App& app);

}  // namespace skinspec::cli
