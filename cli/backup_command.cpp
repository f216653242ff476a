// skinspec backup --db PATH --to FILE: a consistent copy of a SQLite store, taken while
// skinspecd writes it; skinspec backup --verify FILE: the check of such a copy.

#include <fmt/format.h>

#include <iostream>

#include "common.hpp"
#include "skinspec/store/backup.hpp"

namespace skinspec::cli {

namespace {

struct BackupArgs {
  std::string db, to, verify;
};

void print(const store::BackupReport& report, std::string_view what) {
  std::cout << fmt::format("{}: {}; schema version {}, {} bytes\n", report.path, what, report.schema_version,
                           report.bytes);
  for (const auto& [table, rows] : report.rows) std::cout << fmt::format("  {:<18} {:>9}\n", table, rows);
  std::cout.flush();
  if (!std::cout) throw Failure{kFailure, "cannot write to standard output"};
}

// A copy that is damaged, or not a skinspec database, is the file the user named: bad input.
Failure verify_failure(const store::StoreError& error) {
  return error.kind == store::StoreError::Kind::corrupt ? Failure{kBadInput, error.message} : store_failure(error);
}

void run_backup(const BackupArgs& args) {
  if (!args.verify.empty()) {
    const auto checked = store::verify_backup(args.verify);
    if (!checked) throw verify_failure(checked.error());
    return print(*checked, "a whole skinspec database");
  }
  if (args.db.empty() || args.to.empty()) throw Failure{kBadInput, "give --db and --to, or --verify FILE"};
  store::OpenOptions options;
  options.mode = store::OpenMode::read_only;  // beside the live skinspecd, as skinspec export reads
  auto from = store::Store::open(args.db, options);
  if (!from) throw store_failure(from.error());
  const auto copied = store::backup_database(*from, args.to);
  if (!copied) throw store_failure(copied.error());
  print(*copied, fmt::format("a consistent copy of {}, checked", args.db));
}

}  // namespace

void add_backup_command(CLI::App& app) {
  auto args = std::make_shared<BackupArgs>();
  auto* command =
      app.add_subcommand("backup", "copy a SQLite store consistently while skinspecd writes it, or check a copy");
  auto* db = command->add_option("--db", args->db, "the SQLite store to copy (only read)");
  auto* to = command->add_option("--to", args->to, "the copy: a new file, written whole or not at all");
  command->add_option("--verify", args->verify, "check a copy: a skinspec database, whole, and its rows by table")
      ->excludes(db)
      ->excludes(to);
  command->callback([args] { run_backup(*args); });
}

}  // namespace skinspec::cli
