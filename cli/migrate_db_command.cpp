// skinspec migrate-db --from SOURCE --to DESTINATION: a whole database copied into another of
// either engine (a lab's SQLite file into PostgreSQL), ids, raw replies, fits and jobs as they
// are, verified table by table; run again, it finds the copy there and writes nothing.

#include <fmt/format.h>

#include <iostream>

#include "common.hpp"
#include "skinspec/store/copy.hpp"

namespace skinspec::cli {

namespace {

struct MigrateArgs {
  std::string from;
  std::string to;
};

store::Store open_store(const std::string& target, store::OpenMode mode) {
  store::OpenOptions options;
  options.mode = mode;
  auto opened = store::Store::open(target, options);
  if (!opened) throw store_failure(opened.error());
  return std::move(*opened);
}

void run_migrate(const MigrateArgs& args) {
  // The source only read (as skinspec export reads it), so it may stay in service meanwhile.
  const auto from = open_store(args.from, store::OpenMode::read_only);
  auto to = open_store(args.to, store::OpenMode::read_write);
  const auto copied = store::copy_database(from, to);
  if (!copied) throw store_failure(copied.error());
  std::cout << fmt::format("{:<18} {:>9}  {}\n", "table", "rows", "digest");
  for (const auto& table : copied->tables)
    std::cout << fmt::format("{:<18} {:>9}  {}\n", table.table, table.rows, table.digest);
  std::cout << (copied->already_copied
                    ? fmt::format("{} already holds these records, each table's digest equal; nothing written\n",
                                  store::display_target(args.to))
                    : fmt::format("copied into {}; every table read back with the source's rows and digest\n",
                                  store::display_target(args.to)));
  std::cout.flush();
  if (!std::cout) throw Failure{kFailure, "cannot write to standard output"};
}

}  // namespace

void add_migrate_db_command(CLI::App& app) {
  auto args = std::make_shared<MigrateArgs>();
  auto* command = app.add_subcommand(
      "migrate-db", "copy a whole skinspec database into another (a SQLite file into PostgreSQL, or back), verified");
  command->add_option("--from", args->from, "the database to copy: a file or a postgresql:// URI (only read)")
      ->required();
  command->add_option("--to", args->to, "where to: a new file, or an empty PostgreSQL database (postgresql://...)")
      ->required();
  command->callback([args] { run_migrate(*args); });
}

}  // namespace skinspec::cli
