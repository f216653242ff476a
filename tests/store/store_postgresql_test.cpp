// The store on PostgreSQL, where it differs from a SQLite file: what opening refuses and
// leaves untouched (an unreachable server, a refused role, another application's database, a
// newer schema, a role that only reads), two programs opening one database at once, a server
// that goes away mid-work or runs out of disk (a clear error, no partial rows, the next request
// served again once it is back), a network cut between a writer and its backend, and a copy
// refused part way. The records themselves are store_test's, run on both engines.

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <stdlib.h>

#include <filesystem>
#include <fstream>
#include <future>
#include <thread>

#include "skinspec/store/copy.hpp"
#include "skinspec/store/store.hpp"
#include "skinspec/testkit/postgres_cluster.hpp"
#include "skinspec/testkit/store_samples.hpp"
#include "skinspec/testkit/unix_relay.hpp"

namespace skinspec {
namespace {

using namespace skinspec::store;
using ::testing::HasSubstr;
using testing::postgres_cluster;
using testing::sample_fit;
using testing::sample_measurement;
using testing::sample_session;
using Kind = StoreError::Kind;

template <typename T>
T value_of(Result<T> result) {
  if (!result) throw std::runtime_error(result.error().message);
  return std::move(*result);
}

struct Database {
  std::string name = postgres_cluster().create_database();
  std::string uri = postgres_cluster().uri(name);
  long long tables() const {
    return postgres_cluster().integer(name, "SELECT count(*) FROM pg_tables WHERE schemaname = 'public'");
  }
};

TEST(PostgresqlStoreTest, ANewDatabaseGetsTheCurrentSchemaAndNamesItsBackend) {
  Database db;
  auto store = value_of(Store::open(db.uri));
  EXPECT_EQ(store.backend(), Backend::postgresql);
  EXPECT_EQ(backend_of(db.uri), Backend::postgresql);
  EXPECT_EQ(backend_of("postgres://x@/y"), Backend::postgresql);
  EXPECT_EQ(backend_of("sqlite:lab.db"), Backend::sqlite);
  EXPECT_EQ(store.schema_version(), current_schema_version());
  EXPECT_EQ(postgres_cluster().integer(db.name, "SELECT version FROM skinspec_schema"), current_schema_version());
  EXPECT_EQ(postgres_cluster().text(db.name, "SELECT application FROM skinspec_schema"), "skinspec");
}

TEST(PostgresqlStoreTest, AnUnreachableServerOrARefusedRoleIsRefusedByName) {
  Database db;
  const auto nowhere = Store::open("postgresql://skinspec@/" + db.name + "?host=/nonexistent-socket-dir");
  ASSERT_FALSE(nowhere);
  EXPECT_EQ(nowhere.error().kind, Kind::unreachable);
  EXPECT_THAT(nowhere.error().message, HasSubstr("cannot reach the database server"));

  const auto in_uri = Store::open("postgresql://skinspec:secret@/" + db.name);
  ASSERT_FALSE(in_uri);
  EXPECT_EQ(in_uri.error().kind, Kind::invalid_argument);
  EXPECT_THAT(in_uri.error().message, HasSubstr("PGPASSFILE"));

  testing::ScratchDirectory dir;
  const auto passwords = dir.file("pgpass");
  std::ofstream(passwords) << "*:*:*:skinspec_pw:wrong\n";
  std::filesystem::permissions(passwords, std::filesystem::perms::owner_read | std::filesystem::perms::owner_write);
  ::setenv("PGPASSFILE", passwords.c_str(), 1);
  const auto wrong = Store::open(postgres_cluster().uri(db.name, "skinspec_pw"));
  ::unsetenv("PGPASSFILE");
  ASSERT_FALSE(wrong);
  EXPECT_EQ(wrong.error().kind, Kind::access_denied);
  EXPECT_THAT(wrong.error().message, ::testing::Not(HasSubstr("wrong")));

  const auto missing = Store::open(postgres_cluster().uri("no_such_database"));
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().kind, Kind::unreachable);
  EXPECT_THAT(missing.error().message, HasSubstr("no_such_database"));
  EXPECT_EQ(db.tables(), 0);
}

TEST(PostgresqlStoreTest, AnotherApplicationsDatabaseIsLeftUntouched) {
  Database db;
  postgres_cluster().execute(
      db.name, "CREATE TABLE orders (id int); INSERT INTO orders VALUES (1); ALTER TABLE orders OWNER TO skinspec");
  const auto refused = Store::open(db.uri);
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().kind, Kind::corrupt);
  EXPECT_THAT(refused.error().message, HasSubstr("another application"));
  EXPECT_EQ(db.tables(), 1);

  OpenOptions read_only;
  read_only.mode = OpenMode::read_only;
  EXPECT_EQ(Store::open(db.uri, read_only).error().kind, Kind::corrupt);
  Database empty;
  const auto nothing = Store::open(empty.uri, read_only);
  ASSERT_FALSE(nothing);
  EXPECT_EQ(nothing.error().kind, Kind::corrupt);
  EXPECT_EQ(empty.tables(), 0);
}

TEST(PostgresqlStoreTest, ANewerSchemaIsRefusedAndLeftAsItWas) {
  Database db;
  value_of(Store::open(db.uri));
  const auto newer = current_schema_version() + 1;
  postgres_cluster().execute(db.name, "UPDATE skinspec_schema SET version = " + std::to_string(newer));
  for (const auto mode : {OpenMode::read_write, OpenMode::read_only}) {
    OpenOptions options;
    options.mode = mode;
    const auto refused = Store::open(db.uri, options);
    ASSERT_FALSE(refused);
    EXPECT_EQ(refused.error().kind, Kind::newer_schema);
  }
  EXPECT_EQ(postgres_cluster().integer(db.name, "SELECT version FROM skinspec_schema"), newer);
}

// A role that may read the tables but not write them: refused at once for writing, with
// nothing written (not even recovery), and fine for reading.
TEST(PostgresqlStoreTest, ARoleThatOnlyReadsIsRefusedForWritingAndServedForReading) {
  Database db;
  Id session = 0;
  {
    auto store = value_of(Store::open(db.uri));
    session = value_of(store.create_session(sample_session(1)));
    Job job;
    job.kind = "measure";
    job.session_id = session;
    const auto id = value_of(store.create_job(job)).job.id;
    value_of(store.update_job(id, {.state = JobState::running}));
  }
  postgres_cluster().execute(db.name, "GRANT SELECT ON ALL TABLES IN SCHEMA public TO skinspec_reader");
  const auto uri = postgres_cluster().uri(db.name, "skinspec_reader");
  const auto refused = Store::open(uri);
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().kind, Kind::read_only);
  EXPECT_THAT(refused.error().message, HasSubstr("role skinspec_reader may not write"));
  EXPECT_EQ(postgres_cluster().text(db.name, "SELECT state FROM sessions"), "open");
  EXPECT_EQ(postgres_cluster().text(db.name, "SELECT state FROM jobs"), "running");

  OpenOptions read_only;
  read_only.mode = OpenMode::read_only;
  auto reader = value_of(Store::open(uri, read_only));
  EXPECT_EQ(value_of(reader.session(session)).subject, sample_session(1).subject);
  EXPECT_EQ(reader.create_session(sample_session(2)).error().kind, Kind::read_only);

  postgres_cluster().execute("postgres", "ALTER ROLE skinspec_reader SET default_transaction_read_only = on");
  Database fresh;
  postgres_cluster().execute(fresh.name, "ALTER DATABASE " + fresh.name + " OWNER TO skinspec_reader");
  const auto read_only_role = Store::open(postgres_cluster().uri(fresh.name, "skinspec_reader"));
  postgres_cluster().execute("postgres", "ALTER ROLE skinspec_reader RESET default_transaction_read_only");
  ASSERT_FALSE(read_only_role);
  EXPECT_EQ(read_only_role.error().kind, Kind::read_only);
  EXPECT_EQ(fresh.tables(), 0);
}

// Measurement and fit rows are kept whole in their pages (version 7): how many of the two tables
// have that setting.
long long tables_keeping_rows_whole(const std::string& database) {
  return postgres_cluster().integer(database,
                                    "SELECT count(*) FROM pg_class WHERE relname IN ('measurements', 'fits') AND "
                                    "'toast_tuple_target=8160' = ANY (reloptions)");
}

TEST(PostgresqlStoreTest, AVersion6DatabaseIsMigratedWithItsRows) {
  Database db;
  Id measurement = 0;
  {
    auto store = value_of(Store::open(db.uri));
    const Id session = value_of(store.create_session(sample_session(1)));
    measurement = value_of(store.record_measurement(sample_measurement(session, 1), sample_fit(1))).measurement_id;
  }
  EXPECT_EQ(tables_keeping_rows_whole(db.name), 2);
  postgres_cluster().execute(db.name,
                             "ALTER TABLE measurements RESET (toast_tuple_target); ALTER TABLE fits RESET "
                             "(toast_tuple_target); DROP TABLE audit, map_pictures, map_data, maps; "
                             "ALTER TABLE measurements DROP COLUMN import_id; DROP TABLE imports; "
                             "UPDATE skinspec_schema SET version = 6");
  ASSERT_EQ(tables_keeping_rows_whole(db.name), 0);
  auto store = value_of(Store::open(db.uri));
  EXPECT_EQ(store.schema_version(), current_schema_version());
  EXPECT_EQ(tables_keeping_rows_whole(db.name), 2);
  EXPECT_EQ(testing::check_sample_measurement(value_of(store.measurement(measurement))), "");
  EXPECT_EQ(value_of(store.fits_of_measurement(measurement)).size(), 1u);
}

// Version 9 adds maps to a version-8 database, beside its rows.
TEST(PostgresqlStoreTest, AVersion8DatabaseGetsMaps) {
  Database db;
  Id session = 0;
  {
    auto store = value_of(Store::open(db.uri));
    session = value_of(store.create_session(sample_session(1)));
  }
  postgres_cluster().execute(
      db.name,
      "DROP TABLE audit, map_pictures, map_data, maps; ALTER TABLE measurements DROP COLUMN import_id; "
      "DROP TABLE imports; UPDATE skinspec_schema SET version = 8");
  auto store = value_of(Store::open(db.uri));
  EXPECT_EQ(store.schema_version(), current_schema_version());
  const Id map = testing::store_sample_map(store, session, "arm", testing::sample_map_bytes(1000, 8));
  EXPECT_EQ(value_of(store.map(map)).session_id, session);
  EXPECT_EQ(value_of(store.session(session)).subject, sample_session(1).subject);
}

// Two programs opening one new database at the same moment: one becomes the writer and makes
// the schema, the other is told the database is busy.
TEST(PostgresqlStoreTest, TwoProgramsOpeningAtOnceOneWritesTheOtherIsBusy) {
  for (int round = 0; round < 5; ++round) {
    Database db;
    std::promise<void> go;
    auto ready = go.get_future().share();
    auto open_it = [&] {
      ready.wait();
      return Store::open(db.uri);
    };
    auto first = std::async(std::launch::async, open_it);
    auto second = std::async(std::launch::async, open_it);
    go.set_value();
    auto a = first.get();
    auto b = second.get();
    ASSERT_NE(a.has_value(), b.has_value()) << (a ? "" : a.error().message) << (b ? "" : b.error().message);
    const auto& refused = a ? b.error() : a.error();
    EXPECT_EQ(refused.kind, Kind::busy) << refused.message;
    EXPECT_EQ(postgres_cluster().integer(db.name, "SELECT version FROM skinspec_schema"), current_schema_version());
    auto& writer = a ? *a : *b;
    EXPECT_GT(value_of(writer.create_session(sample_session(1))), 0);
  }
}

// The server stopped with a transaction's work half done: the write fails as unreachable and
// nothing of it is stored; once the server is back the same Store serves the next request.
TEST(PostgresqlStoreTest, AServerThatGoesAwayFailsTheWriteWholeAndIsReachedAgainAfterwards) {
  Database db;
  auto store = value_of(Store::open(db.uri));
  const Id session = value_of(store.create_session(sample_session(1)));
  value_of(store.record_measurement(sample_measurement(session, 1), sample_fit(1)));
  value_of(store.session_detail(session));  // a read connection, idle in the pool from now on

  postgres_cluster().stop("immediate");
  const auto lost = store.record_measurement(sample_measurement(session, 2), sample_fit(2));
  ASSERT_FALSE(lost);
  EXPECT_EQ(lost.error().kind, Kind::unreachable) << lost.error().message;
  const auto unread = store.session_detail(session);
  ASSERT_FALSE(unread);
  EXPECT_EQ(unread.error().kind, Kind::unreachable);

  postgres_cluster().start();
  // Every connection the Store had is gone; the first read and the first write succeed.
  EXPECT_EQ(value_of(store.session(session)).subject, sample_session(1).subject);
  EXPECT_EQ(postgres_cluster().integer(db.name, "SELECT count(*) FROM measurements"), 1);
  EXPECT_EQ(postgres_cluster().integer(db.name, "SELECT count(*) FROM fits"), 1);
  const auto again = value_of(store.record_measurement(sample_measurement(session, 3), sample_fit(3)));
  EXPECT_GT(again.measurement_id, 0);
  const auto detail = value_of(store.session_detail(session));
  EXPECT_EQ(detail.measurements.size(), 2u);
  EXPECT_EQ(detail.fits.size(), 2u);
}

// A server restarted while a read connection sat idle in the pool: the first read after it finds
// that connection gone and runs once more on a new one, so the caller sees no error.
TEST(PostgresqlStoreTest, AReadAfterARestartRunsAgainOnANewConnection) {
  Database db;
  auto store = value_of(Store::open(db.uri));
  const Id session = value_of(store.create_session(sample_session(1)));
  value_of(store.session(session));  // leaves its read connection idle in the pool
  postgres_cluster().stop("immediate");
  postgres_cluster().start();
  const auto read = store.session(session);
  ASSERT_TRUE(read) << read.error().message;
  EXPECT_EQ(read->subject, sample_session(1).subject);
}

// The backend holding `bench`'s writer lock on `db` (the store's two-key advisory lock: its
// key 'SKSQ', then the bench's name hashed), or 0 if none does.
long long writer_lock_holder(const Database& db, const std::string& bench) {
  return postgres_cluster().integer(
      db.name,
      "SELECT coalesce(max(pid), 0) FROM pg_locks WHERE locktype = 'advisory' AND granted AND objsubid = 2 AND "
      "classid::bigint = x'534B5351'::bigint AND objid::bigint = (hashtext('" +
          bench + "')::bigint & 4294967295) AND database = (SELECT oid FROM pg_database WHERE datname = " +
          "current_database())");
}

// The server ended the writer's connection between two requests (an administrator, a
// restart): the next write finds it gone before sending anything and runs on a new connection,
// so the caller sees it stored, once. (A connection that ends while its write, sent with its
// COMMIT, is out leaves the outcome unknown, and the error says so.)
TEST(PostgresqlStoreTest, AWriterConnectionTheServerEndedIsReplacedAndTheWriteStoredOnce) {
  Database db;
  auto store = value_of(Store::open(db.uri));
  const Id session = value_of(store.create_session(sample_session(1)));
  const auto writer_pid = writer_lock_holder(db, "");
  postgres_cluster().execute("postgres", "SELECT pg_terminate_backend(" + std::to_string(writer_pid) + ", 5000)");
  const auto stored = value_of(store.record_measurement(sample_measurement(session, 1), sample_fit(1)));
  EXPECT_EQ(postgres_cluster().integer(db.name, "SELECT count(*) FROM measurements"), 1);
  EXPECT_EQ(postgres_cluster().integer(
                db.name, "SELECT count(*) FROM fits WHERE measurement_id = " + std::to_string(stored.measurement_id)),
            1);
}

// A relay in front of the cluster's socket, in a directory of its own, and the URI of `db`
// through it.
struct RelayedDatabase {
  testing::ScratchDirectory dir;
  std::filesystem::path server = postgres_cluster().socket();
  testing::UnixRelay relay{dir.path() / server.filename(), server};
  std::string uri(const Database& db) const {
    return "postgresql://skinspec@/" + db.name + "?host=" + dir.path().string();
  }
};

long long backends_with_pid(const Database& db, long long pid) {
  return postgres_cluster().integer(db.name,
                                    "SELECT count(*) FROM pg_stat_activity WHERE pid = " + std::to_string(pid));
}

// A Store that wrote through a relay, with a session, whose writer the relay has just cut off:
// its backend lives on, still holding the bench's writer lock, since a server notices a
// vanished client only when it next reads from it.
struct CutOffWriter {
  Database db;
  RelayedDatabase relayed;
  Store store = value_of(Store::open(relayed.uri(db)));
  Id session = value_of(store.create_session(sample_session(1)));
  long long backend = writer_lock_holder(db, "");
  CutOffWriter() { relayed.relay.cut_clients(); }
};

// The next write connects again, ends the old backend, takes the lock and is stored once.
TEST(PostgresqlStoreTest, AWriterCutOffFromItsBackendEndsThatBackendAndTakesItsLockAgain) {
  CutOffWriter cut;
  ASSERT_NE(cut.backend, 0);
  EXPECT_EQ(writer_lock_holder(cut.db, ""), cut.backend);  // the server saw nothing of the cut
  const auto stored = value_of(cut.store.record_measurement(sample_measurement(cut.session, 1), sample_fit(1)));
  const auto new_backend = writer_lock_holder(cut.db, "");
  EXPECT_NE(new_backend, 0);
  EXPECT_NE(new_backend, cut.backend);
  EXPECT_EQ(backends_with_pid(cut.db, cut.backend), 0);
  EXPECT_EQ(postgres_cluster().integer(cut.db.name, "SELECT count(*) FROM measurements"), 1);
  EXPECT_EQ(postgres_cluster().integer(cut.db.name, "SELECT count(*) FROM fits WHERE measurement_id = " +
                                                        std::to_string(stored.measurement_id)),
            1);
}

// By the time the cut-off Store writes again its old backend has gone and another program
// serves the bench: that program's backend is not ended; the write is refused as `busy` and
// stores nothing, and the other program goes on writing.
TEST(PostgresqlStoreTest, AWriterCutOffWhoseBenchAnotherProgramTookIsBusyAndEndsNoBackend) {
  CutOffWriter cut;
  ASSERT_NE(cut.backend, 0);
  postgres_cluster().execute("postgres", "SELECT pg_terminate_backend(" + std::to_string(cut.backend) + ", 5000)");
  auto other = value_of(Store::open(cut.db.uri));
  const auto other_backend = writer_lock_holder(cut.db, "");
  ASSERT_NE(other_backend, 0);
  ASSERT_NE(other_backend, cut.backend);

  const auto refused = cut.store.record_measurement(sample_measurement(cut.session, 1), sample_fit(1));
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().kind, Kind::busy) << refused.error().message;
  EXPECT_EQ(writer_lock_holder(cut.db, ""), other_backend);
  EXPECT_EQ(postgres_cluster().integer(cut.db.name, "SELECT count(*) FROM measurements"), 0);
  value_of(other.record_measurement(sample_measurement(cut.session, 2), sample_fit(2)));
  EXPECT_EQ(postgres_cluster().integer(cut.db.name, "SELECT count(*) FROM measurements"), 1);
}

// The server out of disk in the middle of a transaction (its error 53100, raised here by a
// trigger as the server raises it when a write finds no space): the write fails as `full`,
// nothing of it is stored, and once space is back the same Store writes again.
TEST(PostgresqlStoreTest, ADiskFullMidTransactionIsFullAndLeavesNoPartOfIt) {
  Database db;
  auto store = value_of(Store::open(db.uri));
  const Id session = value_of(store.create_session(sample_session(1)));
  postgres_cluster().execute(db.name,
                             "CREATE FUNCTION no_space() RETURNS trigger LANGUAGE plpgsql AS $$ BEGIN RAISE "
                             "EXCEPTION 'could not extend file: No space left on device' USING ERRCODE = 'disk_full'; "
                             "END $$; CREATE TRIGGER no_space BEFORE INSERT ON fits FOR EACH ROW EXECUTE FUNCTION "
                             "no_space()");
  const auto full = store.record_measurement(sample_measurement(session, 1), sample_fit(1));
  ASSERT_FALSE(full);
  EXPECT_EQ(full.error().kind, Kind::full) << full.error().message;
  EXPECT_EQ(full.error().sql_state, "53100");
  EXPECT_THAT(full.error().message, HasSubstr("No space left on device"));
  EXPECT_EQ(postgres_cluster().integer(db.name, "SELECT count(*) FROM measurements"), 0);
  EXPECT_EQ(value_of(store.session(session)).state, SessionState::open);

  postgres_cluster().execute(db.name, "DROP TRIGGER no_space ON fits");
  value_of(store.record_measurement(sample_measurement(session, 2), sample_fit(2)));
  EXPECT_EQ(postgres_cluster().integer(db.name, "SELECT count(*) FROM measurements"), 1);
  EXPECT_EQ(postgres_cluster().integer(db.name, "SELECT count(*) FROM fits"), 1);
}

// A URI's own options (here a search_path) hold for writing and for reading alike.
TEST(PostgresqlStoreTest, TheUrisOwnOptionsHoldForTheWriterAndTheReaders) {
  Database db;
  postgres_cluster().execute(db.name, "CREATE SCHEMA lab AUTHORIZATION skinspec");
  const auto uri = db.uri + "&options=-c%20search_path%3Dlab";
  Id session = 0;
  {
    auto store = value_of(Store::open(uri));
    session = value_of(store.create_session(sample_session(1)));
    EXPECT_EQ(value_of(store.session(session)).subject, sample_session(1).subject);
  }
  EXPECT_EQ(postgres_cluster().integer(db.name, "SELECT count(*) FROM lab.sessions"), 1);
  EXPECT_EQ(db.tables(), 0);  // nothing in public
  OpenOptions read_only;
  read_only.mode = OpenMode::read_only;
  auto reader = value_of(Store::open(uri, read_only));
  EXPECT_EQ(value_of(reader.session(session)).subject, sample_session(1).subject);
  EXPECT_EQ(reader.create_session(sample_session(2)).error().kind, Kind::read_only);
}

// More rows than one page of the copy: every one arrives, in order, the digests equal, and the
// next id the destination gives follows the largest copied one.
TEST(PostgresqlStoreTest, ACopyOfManyPagesOfRowsArrivesWhole) {
  testing::ScratchDirectory dir;
  const auto file = dir.file("lab.db");
  constexpr int kSessions = 700;
  {
    auto lab = value_of(Store::open(file));
    for (int i = 0; i < kSessions; ++i) value_of(lab.create_session(sample_session(i)));
  }
  OpenOptions read_only;
  read_only.mode = OpenMode::read_only;
  const auto from = value_of(Store::open(file, read_only));
  Database db;
  auto to = value_of(Store::open(db.uri));
  const auto report = value_of(copy_database(from, to));
  EXPECT_FALSE(report.already_copied);
  ASSERT_EQ(report.tables.size(), 11u);
  EXPECT_EQ(report.tables[2].table, "sessions");
  EXPECT_EQ(report.tables[2].rows, kSessions);
  EXPECT_EQ(postgres_cluster().integer(db.name, "SELECT count(*) FROM sessions"), kSessions);
  const auto again = value_of(copy_database(from, to));
  EXPECT_TRUE(again.already_copied);
  EXPECT_EQ(again.tables[2].digest, report.tables[2].digest);
  EXPECT_EQ(value_of(to.create_session(sample_session(1))), kSessions + 1);
}

// A map's data of several pieces, its pictures and its job go onto PostgreSQL and back into a
// file with the same digests, and read back the same from each.
TEST(PostgresqlStoreTest, AMapIsCopiedOntoPostgresqlAndBackWhole) {
  testing::ScratchDirectory dir;
  const auto file = dir.file("lab.db");
  const auto bytes = testing::sample_map_bytes(9 * (std::int64_t{1} << 20) / 2, 7);
  Id map = 0;
  {
    auto lab = value_of(Store::open(file));
    const Id session = value_of(lab.create_session(sample_session(1)));
    value_of(lab.record_measurement(sample_measurement(session, 1), sample_fit(1)));
    testing::store_sample_map(lab, session, "small", testing::sample_map_bytes(10, 1));
    map = testing::store_sample_map(lab, std::nullopt, "arm", bytes);
  }
  OpenOptions read_only;
  read_only.mode = OpenMode::read_only;
  const auto from = value_of(Store::open(file, read_only));
  Database db;
  auto onto = value_of(Store::open(db.uri));
  const auto there = value_of(copy_database(from, onto));
  const auto back_file = dir.file("back.db");
  auto back = value_of(Store::open(back_file));
  const auto returned = value_of(copy_database(onto, back));
  ASSERT_EQ(there.tables.size(), returned.tables.size());
  for (std::size_t i = 0; i < there.tables.size(); ++i) {
    EXPECT_EQ(there.tables[i].digest, returned.tables[i].digest) << there.tables[i].table;
    EXPECT_EQ(there.tables[i].rows, returned.tables[i].rows) << there.tables[i].table;
  }
  EXPECT_EQ(there.tables[9].table, "map_pictures");
  EXPECT_EQ(there.tables[8].rows, 9);  // the answers and reflectance of each: five and two pieces, one and one
  for (const Store* store : {&onto, &back}) {
    std::string data;
    ASSERT_TRUE(store->read_map_data(map, [&](std::string_view piece) {
      data += piece;
      return true;
    }));
    EXPECT_TRUE(data == bytes);
    EXPECT_EQ(value_of(store->map(map)).pictures, (std::vector<std::string>{"melanin", "bilirubin"}));
  }
}

// A copy the destination refuses part way (PostgreSQL takes only UTF-8 text; a SQLite file may
// hold other bytes) leaves the destination as empty as it was.
TEST(PostgresqlStoreTest, ACopyRefusedPartWayLeavesTheDestinationEmpty) {
  testing::ScratchDirectory dir;
  const auto file = dir.file("lab.db");
  {
    auto lab = value_of(Store::open(file));
    const Id first = value_of(lab.create_session(sample_session(1)));
    value_of(lab.record_measurement(sample_measurement(first, 1), sample_fit(1)));
    auto odd = sample_session(2);
    odd.notes = "latin-1 \xe9t\xe9";
    value_of(lab.create_session(odd));
  }
  OpenOptions read_only;
  read_only.mode = OpenMode::read_only;
  const auto from = value_of(Store::open(file, read_only));
  Database db;
  auto to = value_of(Store::open(db.uri));
  const auto refused = copy_database(from, to);
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().kind, Kind::invalid_argument) << refused.error().message;
  for (const auto* table : {"sessions", "measurements", "fits"})
    EXPECT_EQ(postgres_cluster().integer(db.name, std::string("SELECT count(*) FROM ") + table), 0) << table;
  EXPECT_EQ(value_of(to.create_session(sample_session(3))), 1);
}

}  // namespace
}  // namespace skinspec
