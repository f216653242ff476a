// skinspec export --db PATH|URI [--session ID] [--format csv|json|cgats]: stored spectra and fits.
// skinspec export --db PATH|URI --audit [--format csv|json]: the audit trail.

#include <iostream>
#include <sstream>

#include "common.hpp"
#include "skinspec/records/export.hpp"

namespace skinspec::cli {

namespace {

struct ExportArgs {
  std::string db;
  std::optional<store::Id> session;
  std::string format = "json";
  bool audit = false;
};

// Whatever the store reports (a missing, foreign, damaged, newer or older file, an unknown
// session, a read that fails) is about the file the user named: bad input, naming it.
Failure export_failure(const std::string& path, const store::StoreError& error) {
  const auto shown = store::display_target(path);
  const bool names_the_file = error.message.find(shown) != std::string::npos;
  return Failure{kBadInput, names_the_file ? error.message : shown + ": " + error.message};
}

// Only reads: a file that is not a current skinspec database is refused, never converted.
store::Store open_for_export(const std::string& path) {
  store::OpenOptions options;
  options.mode = store::OpenMode::read_only;
  auto opened = store::Store::open(path, options);
  if (!opened) throw export_failure(path, opened.error());
  return std::move(*opened);
}

// The whole export, held back until complete: a failure part way prints nothing on stdout.
std::string exported(const store::Store& db, const ExportArgs& args) {
  const auto format = args.format == "csv"     ? records::ExportFormat::csv
                      : args.format == "cgats" ? records::ExportFormat::cgats
                                               : records::ExportFormat::json;
  std::ostringstream out;
  store::Result<void> written;
  if (args.audit) {
    written = records::export_audit(db, format, out);
  } else if (args.session) {
    if (format == records::ExportFormat::csv) records::write_csv_header(out);
    written = records::export_session(db, *args.session, format, out);
  } else {
    written = records::export_all(db, format, out);
  }
  if (!written) throw export_failure(args.db, written.error());
  return std::move(out).str();
}

void run_export(const ExportArgs& args) {
  const auto db = open_for_export(args.db);
  // ArgyllCMS's tools read one table of a CGATS file: one session's spectra at a time.
  if (args.format == "cgats" && !args.session && !args.audit)
    throw Failure{kBadInput, "--format cgats writes one session's spectra: give --session ID"};
  const auto text = exported(db, args);
  std::cout << text;
  std::cout.flush();
  if (!std::cout) throw Failure{kFailure, "cannot write to standard output"};
}

}  // namespace

void add_export_command(CLI::App& app) {
  auto args = std::make_shared<ExportArgs>();
  auto* command = app.add_subcommand("export", "write the stored spectra and fits of one session or all");
  command->add_option("--db", args->db, "the skinspec database, a file or a postgresql:// URI (only read)")->required();
  auto* session = command->add_option("--session", args->session, "the session id (default: every session)");
  command
      ->add_flag("--audit", args->audit,
                 "write the audit trail instead: each change made through the service, oldest first, with who "
                 "asked, from where and when")
      ->excludes(session);
  command
      ->add_option("--format", args->format,
                   "csv (one row per wavelength), json (one line per session) or cgats (reflectance spectra, "
                   "ArgyllCMS .ti3)")
      ->check(CLI::IsMember({"csv", "json", "cgats"}))
      ->capture_default_str();
  command->callback([args] { run_export(*args); });
}

}  // namespace skinspec::cli
