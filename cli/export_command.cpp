// skinspec export --db PATH [--session ID] [--format csv|json]: stored spectra and fits.

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
};

// What the user can fix (the path, the file, the session id) is bad input; the rest a failure.
Failure store_failure(const store::StoreError& error) {
  using Kind = store::StoreError::Kind;
  switch (error.kind) {
    case Kind::not_found:
    case Kind::corrupt:
    case Kind::newer_schema:
    case Kind::invalid_argument: return Failure{kBadInput, error.message};
    default: return Failure{kFailure, error.message};
  }
}

store::Store open_for_export(const std::string& path) {
  store::OpenOptions options;
  options.read_only = true;  // never changes the file, and runs beside a live skinspecd
  auto opened = store::Store::open(path, options);
  if (!opened && opened.error().kind == store::StoreError::Kind::older_schema) {
    // Written by an older skinspec: migrating it forward is what any writer would do first.
    opened = store::Store::open(path);
  }
  if (!opened) throw store_failure(opened.error());
  return std::move(*opened);
}

void run_export(const ExportArgs& args) {
  const auto format = args.format == "csv" ? records::ExportFormat::csv : records::ExportFormat::json;
  const auto db = open_for_export(args.db);
  store::Result<void> written;
  if (args.session) {
    // Held back until complete, so that an unknown session prints nothing on stdout.
    std::ostringstream out;
    if (format == records::ExportFormat::csv) records::write_csv_header(out);
    written = records::export_session(db, *args.session, format, out);
    if (written) std::cout << out.view();
  } else {
    written = records::export_all(db, format, std::cout);
  }
  if (!written) throw store_failure(written.error());
  std::cout.flush();
}

}  // namespace

void add_export_command(CLI::App& app) {
  auto args = std::make_shared<ExportArgs>();
  auto* command = app.add_subcommand("export", "write the stored spectra and fits of one session or all");
  command->add_option("--db", args->db, "the skinspec database file")->required();
  command->add_option("--session", args->session, "the session id (default: every session)");
  command->add_option("--format", args->format, "csv (one row per wavelength) or json (one line per session)")
      ->check(CLI::IsMember({"csv", "json"}))
      ->capture_default_str();
  command->callback([args] { run_export(*args); });
}

}  // namespace skinspec::cli
