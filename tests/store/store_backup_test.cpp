// Backups (store/backup.hpp): a copy taken while another connection writes holds exactly the
// commits of one moment; a copy never replaces a file; a damaged one is found; a PostgreSQL store
// is refused (pg_dump's), and pg_dump/pg_restore, as docs/store.md gives them, bring back every row.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <thread>

#include "skinspec/store/backup.hpp"
#include "skinspec/store/copy.hpp"
#include "skinspec/testkit/postgres_cluster.hpp"
#include "skinspec/testkit/process.hpp"
#include "skinspec/testkit/store_samples.hpp"

namespace skinspec::store {
namespace {

namespace fs = std::filesystem;
using testing::sample_fit;
using testing::sample_measurement;
using testing::sample_session;
using testing::value_of;
using Kind = StoreError::Kind;

Store read_only(const std::string& path) {
  OpenOptions options;
  options.mode = OpenMode::read_only;
  return value_of(Store::open(path, options));
}

std::int64_t rows_of(const BackupReport& report, const std::string& table) {
  for (const auto& [name, rows] : report.rows)
    if (name == table) return rows;
  return -1;
}

// The measurements of a store in the order stored: "sample N" labels, each checked against the
// sample it was made from.
std::vector<int> checked_samples(const std::string& path, Id session) {
  const auto store = read_only(path);
  const auto detail = value_of(store.session_detail(session));
  std::vector<int> numbers;
  for (const auto& m : detail.measurements) {
    EXPECT_EQ(testing::check_sample_measurement(m), "") << path;
    numbers.push_back(std::stoi(m.label.substr(std::string("sample ").size())));
  }
  EXPECT_EQ(detail.fits.size(), detail.measurements.size()) << path << ": every measurement with its fit";
  return numbers;
}

TEST(StoreBackup, ACopyTakenWhileAnotherConnectionWritesHoldsTheCommitsOfOneMoment) {
  testing::ScratchDirectory dir;
  const auto path = dir.file("lab.db");
  auto writer = value_of(Store::open(path));
  const Id session = value_of(writer.create_session(sample_session(1)));
  std::atomic<bool> stop{false};
  std::atomic<int> written{0};
  std::thread writing([&] {
    for (int n = 1; !stop; ++n) {
      value_of(writer.record_measurement(sample_measurement(session, n), sample_fit(n)));
      written = n;
    }
  });
  while (written < 20) std::this_thread::yield();
  const auto source = read_only(path);
  std::vector<std::string> copies;
  for (int i = 0; i < 4; ++i) {
    copies.push_back(dir.file("copy" + std::to_string(i) + ".db"));
    const auto report = value_of(backup_database(source, copies.back()));
    EXPECT_EQ(report.path, fs::absolute(copies.back()).string());
    EXPECT_GE(rows_of(report, "measurements"), 20);
    std::this_thread::sleep_for(std::chrono::milliseconds(30));
  }
  stop = true;
  writing.join();
  const auto all = checked_samples(path, session);
  for (const auto& copy : copies) {
    const auto report = value_of(verify_backup(copy));
    EXPECT_EQ(report.schema_version, current_schema_version());
    // The copy holds samples 1..k, each whole with its fit: what was committed at one moment.
    const auto held = checked_samples(copy, session);
    ASSERT_FALSE(held.empty());
    EXPECT_EQ(held, std::vector<int>(all.begin(), all.begin() + static_cast<std::ptrdiff_t>(held.size()))) << copy;
    EXPECT_EQ(rows_of(report, "measurements"), static_cast<std::int64_t>(held.size()));
    EXPECT_FALSE(fs::exists(copy + "-wal")) << "a copy is a file of its own";
  }
  EXPECT_LT(checked_samples(copies.front(), session).size(), all.size()) << "the writer went on after the first copy";
}

TEST(StoreBackup, ACopyNeverReplacesAFileAndLeavesNothingWhenRefused) {
  testing::ScratchDirectory dir;
  const auto path = dir.file("lab.db");
  {
    value_of(Store::open(path));
  }
  const auto source = read_only(path);
  const auto taken = dir.file("taken.db");
  std::ofstream(taken) << "a researcher's file";
  const auto refused = backup_database(source, taken);
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().kind, Kind::conflict);
  EXPECT_EQ(testing::file_bytes(taken), "a researcher's file");
  const auto nowhere = backup_database(source, dir.file("no-such-dir/copy.db"));
  ASSERT_FALSE(nowhere);
  std::vector<std::string> left;
  for (const auto& entry : fs::directory_iterator(dir.path())) left.push_back(entry.path().filename().string());
  EXPECT_THAT(left, ::testing::Each(::testing::Not(::testing::HasSubstr("copy")))) << "no partial copy left";
  EXPECT_THAT(left, ::testing::Each(::testing::Not(::testing::HasSubstr("partial"))));
}

TEST(StoreBackup, ADamagedCopyOrAnotherFileIsFoundByTheCheck) {
  testing::ScratchDirectory dir;
  const auto path = dir.file("lab.db");
  {
    auto store = value_of(Store::open(path));
    const Id session = value_of(store.create_session(sample_session(1)));
    for (int n = 1; n <= 200; ++n) value_of(store.record_measurement(sample_measurement(session, n), sample_fit(n)));
  }
  const auto copy = dir.file("copy.db");
  value_of(backup_database(read_only(path), copy));
  const auto bytes = testing::file_bytes(copy);
  // A page in the middle overwritten from its start, where a b-tree page has its header and an
  // overflow page (most of this file: spectra) the number of the next: the file still opens, the
  // check finds it. (The rest of an overflow page is payload, which the check does not read.)
  std::fstream damage(copy, std::ios::in | std::ios::out | std::ios::binary);
  damage.seekp(static_cast<std::streamoff>(bytes.size() / 2 / 4096 * 4096));
  damage << std::string(3000, '\x5a');
  damage.close();
  const auto damaged = verify_backup(copy);
  ASSERT_FALSE(damaged);
  EXPECT_EQ(damaged.error().kind, Kind::corrupt) << damaged.error().message;
  std::ofstream(dir.file("notes.db")) << "not a database at all, and long enough to have a header..............";
  EXPECT_EQ(verify_backup(dir.file("notes.db")).error().kind, Kind::corrupt);
  EXPECT_EQ(verify_backup(dir.file("missing.db")).error().kind, Kind::not_found);
}

TEST(StoreBackup, APostgresqlStoreIsRefusedAndPgDumpAndPgRestoreBringBackEveryRow) {
  testing::PostgresCluster cluster;
  const auto source_db = cluster.create_database();
  {
    auto store = value_of(Store::open(cluster.uri(source_db)));
    const Id session = value_of(store.create_session(sample_session(1)));
    for (int n = 1; n <= 30; ++n) value_of(store.record_measurement(sample_measurement(session, n), sample_fit(n)));
    testing::store_sample_map(store, session, "arm", testing::sample_map_bytes(3 << 20, 5));
    testing::ScratchDirectory dir;
    EXPECT_EQ(backup_database(store, dir.file("copy.db")).error().kind, Kind::invalid_argument);
  }
  // The recipe of docs/store.md, "Backups": a dump in pg_dump's custom format, restored into a
  // new database owned by the store's role.
  testing::ScratchDirectory dir;
  const auto dump = dir.file("lab.dump");
  const auto dumped = testing::run_process(testing::PostgresCluster::program("pg_dump"),
                                           {"--format=custom", "--file", dump, cluster.uri(source_db, "admin")});
  ASSERT_EQ(dumped.exit_status, 0) << dumped.describe();
  const auto restored_db = cluster.create_database();
  const auto restored = testing::run_process(
      testing::PostgresCluster::program("pg_restore"),
      {"--no-owner", "--role=skinspec", "--exit-on-error", "--dbname", cluster.uri(restored_db, "admin"), dump});
  ASSERT_EQ(restored.exit_status, 0) << restored.describe();
  // Both copied into SQLite files: every table's rows and digest (every value of every row) equal.
  const auto digests = [&](const std::string& database) {
    auto copy = value_of(Store::open(dir.file(database + ".db")));
    return value_of(copy_database(value_of(Store::open(cluster.uri(database))), copy)).tables;
  };
  const auto before = digests(source_db), after = digests(restored_db);
  ASSERT_EQ(before.size(), after.size());
  for (std::size_t i = 0; i < before.size(); ++i) {
    EXPECT_EQ(before[i].rows, after[i].rows) << before[i].table;
    EXPECT_EQ(before[i].digest, after[i].digest) << before[i].table;
  }
  // The restored database is written by the store as the original was.
  auto again = value_of(Store::open(cluster.uri(restored_db)));
  EXPECT_TRUE(again.create_session(sample_session(2)));
}

}  // namespace
}  // namespace skinspec::store
