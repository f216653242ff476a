// The store's PostgreSQL connection layer (store/src/postgresql/) against a real throwaway
// server: values of every type the store uses in binary both ways, placeholders and row locks,
// transactions and read-only snapshots, the server's errors as the store's kinds, a lost
// connection, and each way connecting can fail.

#include <gtest/gtest.h>
#include <stdlib.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <thread>

#include "db.hpp"
#include "postgresql/connection.hpp"
#include "postgresql/errors.hpp"
#include "postgresql/target.hpp"
#include "skinspec/testkit/postgres_cluster.hpp"
#include "skinspec/testkit/store_samples.hpp"

namespace skinspec::store::postgresql {
namespace {

using testing::postgres_cluster;
using Kind = StoreError::Kind;

detail::Failure failure_of(const std::function<void()>& action) {
  try {
    action();
  } catch (const detail::Failure& failure) {
    return failure;
  }
  ADD_FAILURE() << "it did not fail";
  return {};
}

std::unique_ptr<Connection> connect(const std::string& uri, ConnectSettings settings = {}) {
  return std::make_unique<Connection>(parse_target(uri), settings);
}

// A new database of the test's cluster, and a connection to it as its owner.
struct Database {
  std::string name = postgres_cluster().create_database();
  std::string uri = postgres_cluster().uri(name);
  std::unique_ptr<Connection> connection = connect(uri);
};

TEST(PostgresqlSqlTest, PlaceholdersBecomeNumberedParametersOutsideQuotesAndCommentsAndLocksAreAppended) {
  EXPECT_EQ(postgresql_sql("SELECT a FROM t WHERE (b = ?1 OR ?1 IS NULL) AND c < ?12", RowLock::none),
            "SELECT a FROM t WHERE (b = $1 OR $1 IS NULL) AND c < $12");
  EXPECT_EQ(postgresql_sql("SELECT '?1', 'it''s ?2', \"?3\", ?4 -- ?5\n, ?6 /* ?7 */", RowLock::none),
            "SELECT '?1', 'it''s ?2', \"?3\", $4 -- ?5\n, $6 /* ?7 */");
  EXPECT_EQ(postgresql_sql("SELECT ? FROM t", RowLock::none), "SELECT ? FROM t");
  EXPECT_EQ(postgresql_sql("SELECT 1 FROM t WHERE id = ?1", RowLock::share), "SELECT 1 FROM t WHERE id = $1 FOR SHARE");
  EXPECT_EQ(postgresql_sql("SELECT 1 FROM t", RowLock::update), "SELECT 1 FROM t FOR UPDATE");
}

TEST(PostgresqlErrorsTest, EachSqlStateHasTheKindACallerCanActOn) {
  const std::vector<std::pair<std::string, Kind>> expected = {{"23505", Kind::conflict},
                                                              {"23503", Kind::conflict},
                                                              {"23514", Kind::conflict},
                                                              {"22012", Kind::invalid_argument},
                                                              {"22021", Kind::invalid_argument},
                                                              {"54000", Kind::invalid_argument},
                                                              {"53100", Kind::full},
                                                              {"53300", Kind::busy},
                                                              {"53200", Kind::busy},
                                                              {"40001", Kind::busy},
                                                              {"40P01", Kind::busy},
                                                              {"55P03", Kind::busy},
                                                              {"25006", Kind::read_only},
                                                              {"42501", Kind::read_only},
                                                              {"08006", Kind::unreachable},
                                                              {"57P01", Kind::unreachable},
                                                              {"57P03", Kind::unreachable},
                                                              {"28P01", Kind::access_denied},
                                                              {"28000", Kind::access_denied},
                                                              {"3D000", Kind::not_found},
                                                              {"42P01", Kind::corrupt},
                                                              {"42703", Kind::corrupt},
                                                              {"XX001", Kind::corrupt},
                                                              {"58030", Kind::io},
                                                              {"42601", Kind::internal},
                                                              {"P0001", Kind::internal},
                                                              {"", Kind::internal}};
  for (const auto& [state, kind] : expected) EXPECT_EQ(kind_of_sql_state(state), kind) << state;
  EXPECT_TRUE(retryable_sql_state("40001"));
  EXPECT_TRUE(retryable_sql_state("40P01"));
  EXPECT_FALSE(retryable_sql_state("23505"));
  EXPECT_TRUE(connection_lost_sql_state("08003"));
  EXPECT_TRUE(connection_lost_sql_state("57P01"));
  EXPECT_FALSE(connection_lost_sql_state("53100"));
}

TEST(PostgresqlTargetTest, AUriIsShownWithoutItsParametersAndAPasswordInItIsRefused) {
  const auto target = parse_target("postgresql://skinspec@db.lab:5433/lab?connect_timeout=3&sslmode=disable");
  EXPECT_EQ(target.display, "postgresql://skinspec@db.lab:5433/lab");
  EXPECT_EQ(target.user, "skinspec");
  EXPECT_EQ(parse_target("postgres:///lab?host=/run/pg").display, "postgresql:///run/pg/lab");

  const auto password = failure_of([] { parse_target("postgresql://skinspec:secret@db.lab/lab"); });
  EXPECT_EQ(password.error.kind, Kind::invalid_argument);
  EXPECT_NE(password.error.message.find("PGPASSFILE"), std::string::npos);
  EXPECT_EQ(password.error.message.find("secret"), std::string::npos);
  EXPECT_EQ(failure_of([] { parse_target("postgresql://db.lab/lab?password=secret"); }).error.kind,
            Kind::invalid_argument);
  EXPECT_EQ(failure_of([] { parse_target("postgresql://db.lab/lab?no_such_option=1"); }).error.kind,
            Kind::invalid_argument);

  // The store's defaults come before the URI, so that what the URI says wins; UTF-8 after it.
  const auto keywords = connection_keywords(target, {.application_name = "skinspecd/a", .read_only = true});
  const auto at = [&](const std::string& name) {
    return std::ranges::find(keywords, name, &std::pair<std::string, std::string>::first) - keywords.begin();
  };
  EXPECT_LT(at("connect_timeout"), at("dbname"));
  EXPECT_LT(at("dbname"), at("client_encoding"));
  EXPECT_EQ(keywords[static_cast<std::size_t>(at("application_name"))].second, "skinspecd/a");
  // The URI's own options (a search_path, say) are never replaced: read-only is set on the session.
  EXPECT_EQ(at("options"), static_cast<std::ptrdiff_t>(keywords.size()));

  // libpq quotes the URI in its parse errors; a message never repeats it, nor its password.
  const auto unparsable = failure_of([] { parse_target("postgresql://u:secret@[bad/db"); }).error;
  EXPECT_EQ(unparsable.kind, Kind::invalid_argument);
  EXPECT_EQ(unparsable.message.find("secret"), std::string::npos) << unparsable.message;
  EXPECT_EQ(failure_of([] { parse_target("postgresql://db.lab/lab?sslpassword=secret"); }).error.kind,
            Kind::invalid_argument);
}

TEST(PostgresqlConnectionTest, EveryTypeTheStoreUsesRoundTripsInBinary) {
  Database db;
  auto& c = *db.connection;
  c.execute(
      "CREATE TABLE v (id bigint GENERATED BY DEFAULT AS IDENTITY PRIMARY KEY, i bigint, r double precision, "
      "b boolean, t text, j json, y bytea, at timestamptz)");
  struct Row {
    std::optional<std::int64_t> i;
    std::optional<double> r;
    std::optional<bool> b;
    std::optional<std::string> t, j, y;
    std::optional<Time> at;
  };
  const std::string bytes("\0\x01\xff\x7f'?1", 7);
  const std::vector<Row> rows = {
      {std::numeric_limits<std::int64_t>::max(), 1.0 / 3.0, true, "h\xc3\xa9llo 'quoted' ?1",
       R"({"b":1,  "a" : [1.0, 2e0]})", bytes, Time(std::chrono::microseconds(-1))},
      {std::numeric_limits<std::int64_t>::min(), -std::numeric_limits<double>::infinity(), false, "", "[]", "",
       Time(std::chrono::microseconds(946'684'800'000'000 - 123'456'789)) + std::chrono::hours(24 * 365 * 60)},
      {},
  };
  std::vector<Id> ids;
  for (const auto& row : rows) {
    auto insert = c.prepare("INSERT INTO v (i, r, b, t, j, y, at) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7) RETURNING id");
    const auto blob = row.y ? std::optional<detail::Blob>(detail::Blob{*row.y}) : std::nullopt;
    insert.bind(row.i, row.r, row.b, row.t, row.j, blob, row.at);
    ASSERT_TRUE(insert.step());
    ids.push_back(insert.integer(0));
    EXPECT_FALSE(insert.step());
  }
  for (std::size_t n = 0; n < rows.size(); ++n) {
    auto read = c.prepare("SELECT i, r, b, t, j, y, at FROM v WHERE id = ?1");
    read.bind(ids[n]);
    ASSERT_TRUE(read.step());
    const auto& row = rows[n];
    EXPECT_EQ(read.optional_integer(0), row.i) << n;
    if (row.r) {
      EXPECT_EQ(read.real(1), *row.r) << n;
    } else {
      EXPECT_TRUE(read.is_null(1) && std::isnan(read.real(1))) << n;
    }
    EXPECT_EQ(read.is_null(2) ? std::nullopt : std::optional<bool>(read.boolean(2)), row.b) << n;
    EXPECT_EQ(read.is_null(3) ? std::nullopt : std::optional<std::string>(read.text(3)), row.t) << n;
    EXPECT_EQ(read.is_null(4) ? std::nullopt : std::optional<std::string>(read.text(4)), row.j) << n;
    EXPECT_EQ(read.is_null(5) ? std::nullopt : std::optional<std::string>(read.blob(5)), row.y) << n;
    EXPECT_EQ(read.optional_time(6), row.at) << n;
    EXPECT_FALSE(read.step());
  }
  // What the server itself makes of the bound time: the same instant.
  EXPECT_EQ(c.query_text("SELECT to_char(at AT TIME ZONE 'UTC', 'YYYY-MM-DD HH24:MI:SS.US') FROM v WHERE id = " +
                         std::to_string(ids[0])),
            "1969-12-31 23:59:59.999999");

  // A filter that is off when its parameter is NULL; the statement is prepared once.
  const auto count_where = [&](std::optional<std::int64_t> i) {
    auto count = c.prepare("SELECT count(*) FROM v WHERE (i = ?1 OR ?1 IS NULL)");
    count.bind(i);
    EXPECT_TRUE(count.step());
    return count.integer(0);
  };
  EXPECT_EQ(count_where(std::nullopt), 3);
  const auto prepared = c.query_integer("SELECT count(*) FROM pg_prepared_statements");
  EXPECT_EQ(count_where(std::numeric_limits<std::int64_t>::max()), 1);
  EXPECT_EQ(c.query_integer("SELECT count(*) FROM pg_prepared_statements"), prepared);
}

TEST(PostgresqlConnectionTest, TransactionsCommitOrRollBackAndAReadSnapshotNeitherWritesNorLocks) {
  Database db;
  auto& c = *db.connection;
  c.execute("CREATE TABLE t (x bigint)");
  const auto rows = [&] { return postgres_cluster().integer(db.name, "SELECT count(*) FROM t"); };

  c.begin(TransactionKind::write);
  EXPECT_TRUE(c.in_transaction());
  c.prepare("INSERT INTO t VALUES (?1)").bind(1).run();
  c.rollback();
  EXPECT_FALSE(c.in_transaction());
  EXPECT_EQ(rows(), 0);
  {
    detail::Transaction transaction(*db.connection, TransactionKind::write);
    c.prepare("INSERT INTO t VALUES (?1)").bind(2).run();
    EXPECT_EQ(rows(), 0);  // not before COMMIT
    transaction.commit();
  }
  EXPECT_EQ(rows(), 1);

  // A read transaction is one snapshot, and read-only.
  c.begin(TransactionKind::read);
  EXPECT_EQ(c.query_integer("SELECT count(*) FROM t"), 1);
  postgres_cluster().execute(db.name, "INSERT INTO t VALUES (3)");
  EXPECT_EQ(c.query_integer("SELECT count(*) FROM t"), 1);
  auto write = failure_of([&] { c.prepare("INSERT INTO t VALUES (?1)").bind(4).run(); });
  EXPECT_EQ(write.error.kind, Kind::read_only);
  EXPECT_EQ(write.error.sql_state, "25006");
  c.rollback();
  c.begin(TransactionKind::read);
  auto lock = failure_of([&] { c.prepare("SELECT x FROM t", RowLock::update).step(); });
  EXPECT_EQ(lock.error.sql_state, "25006") << lock.error.message;  // FOR UPDATE was appended
  c.rollback();
  EXPECT_EQ(c.query_integer("SELECT count(*) FROM t"), 2);

  // A connection opened to read cannot write even outside a transaction.
  auto reader = connect(db.uri, {.application_name = "skinspec", .read_only = true});
  EXPECT_EQ(failure_of([&] { reader->execute("INSERT INTO t VALUES (5)"); }).error.kind, Kind::read_only);
  EXPECT_EQ(rows(), 2);
}

TEST(PostgresqlConnectionTest, TheServersErrorsBecomeTheStoresKindsAndTheConnectionGoesOn) {
  Database db;
  auto& c = *db.connection;
  c.execute("CREATE TABLE u (k text UNIQUE, n bigint CHECK (n >= 0))");
  c.prepare("INSERT INTO u VALUES (?1, ?2)").bind("a", 1).run();
  const auto insert = [&](const std::string& k, std::int64_t n) {
    return failure_of([&] { c.prepare("INSERT INTO u VALUES (?1, ?2)").bind(k, n).run(); }).error;
  };
  const auto duplicate = insert("a", 2);
  EXPECT_EQ(duplicate.kind, Kind::conflict);
  EXPECT_EQ(duplicate.sql_state, "23505");
  EXPECT_NE(duplicate.message.find("duplicate key value violates unique constraint"), std::string::npos);
  EXPECT_NE(duplicate.message.find("Key (k)=(a) already exists"), std::string::npos);  // the detail
  EXPECT_EQ(insert("b", -1).sql_state, "23514");
  const auto nul = insert(std::string("c\0d", 3), 1);
  EXPECT_EQ(nul.kind, Kind::invalid_argument);
  EXPECT_EQ(nul.sql_state, "22021");
  const auto division = failure_of([&] { c.prepare("SELECT 1 / ?1").bind(0).step(); }).error;
  EXPECT_EQ(division.kind, Kind::invalid_argument);
  const auto missing = failure_of([&] { c.prepare("SELECT x FROM missing"); }).error;
  EXPECT_EQ(missing.kind, Kind::corrupt);
  EXPECT_EQ(missing.sql_state, "42P01");
  const auto full = failure_of([&] {
                      c.execute("DO $$ BEGIN RAISE EXCEPTION 'could not extend file' USING ERRCODE = '53100'; END $$");
                    }).error;
  EXPECT_EQ(full.kind, Kind::full);
  EXPECT_NE(full.message.find("could not extend file"), std::string::npos);
  const auto wrong_type = failure_of([&] { c.prepare("INSERT INTO u VALUES (?1, ?2)").bind(1, 1); }).error;
  EXPECT_EQ(wrong_type.kind, Kind::internal);
  EXPECT_NE(wrong_type.message.find("parameter $1 is text"), std::string::npos) << wrong_type.message;

  EXPECT_FALSE(c.broken());
  EXPECT_EQ(c.query_integer("SELECT count(*) FROM u"), 1);
}

TEST(PostgresqlConnectionTest, StatementsSentGoOutWithTheNextOneSteppedInOrderAndAFailureStopsTheRest) {
  Database db;
  auto& c = *db.connection;
  c.execute("CREATE TABLE u (k text UNIQUE)");
  const auto stored = [&] { return postgres_cluster().text(db.name, "SELECT string_agg(k, ',' ORDER BY k) FROM u"); };

  {  // Nothing goes out before a statement is stepped; then each runs in the order sent.
    auto first = c.prepare("INSERT INTO u VALUES (?1) RETURNING k");
    first.bind("a").send();
    EXPECT_EQ(stored(), "");
    auto count = c.prepare("SELECT count(*) FROM u");
    ASSERT_TRUE(count.step());
    EXPECT_EQ(count.integer(0), 1);
    ASSERT_TRUE(first.step());
    EXPECT_EQ(first.text(0), "a");
  }
  {  // In a transaction: a statement that fails stops those sent after it, which fail as it did.
    c.begin(TransactionKind::write);
    auto fine = c.prepare("INSERT INTO u VALUES (?1)");
    fine.bind("b").send();
    auto failing = c.prepare("INSERT INTO u VALUES (?1) RETURNING 1 / 0");
    failing.bind("c").send();
    auto after = c.prepare("INSERT INTO u VALUES (?1) RETURNING k");
    after.bind("d").send();
    EXPECT_FALSE(fine.step());
    const auto failed = failure_of([&] { failing.step(); });
    EXPECT_EQ(failed.error.sql_state, "22012");
    const auto skipped = failure_of([&] { after.step(); });
    EXPECT_EQ(skipped.error.sql_state, "22012");
    EXPECT_EQ(skipped.error.message, failed.error.message);
    EXPECT_EQ(failure_of([&] { c.commit(); }).error.kind, Kind::internal);  // rolled back, not committed
    c.rollback();
    EXPECT_EQ(stored(), "a");
  }
  {  // A statement sent and dropped before anything ran does not run; one sent and not stepped
     // runs before COMMIT; the same statement cannot be bound again while it waits.
    c.begin(TransactionKind::write);
    c.prepare("INSERT INTO u VALUES (?1)").bind("dropped").send();
    auto kept = c.prepare("INSERT INTO u VALUES (?1) RETURNING k");
    kept.bind("kept").send();
    EXPECT_EQ(failure_of([&] { c.prepare("INSERT INTO u VALUES (?1) RETURNING k"); }).error.kind, Kind::internal);
    c.commit();
    ASSERT_TRUE(kept.step());
    EXPECT_EQ(kept.text(0), "kept");
    EXPECT_EQ(stored(), "a,kept");
    EXPECT_FALSE(c.in_transaction());
  }
}

// A transaction's last statement takes the COMMIT with it, in its round trip; its rows are read
// after, and nothing runs in the transaction after it.
TEST(PostgresqlConnectionTest, TheLastStatementGoesOutWithTheCommitAndNothingRunsAfterIt) {
  Database db;
  auto& c = *db.connection;
  c.execute("CREATE TABLE u (k text UNIQUE)");
  const auto stored = [&] { return postgres_cluster().text(db.name, "SELECT string_agg(k, ',' ORDER BY k) FROM u"); };

  {  // Committed with the statement: commit() has nothing left to do.
    c.begin(TransactionKind::write);
    auto first = c.prepare("INSERT INTO u VALUES (?1)");
    first.bind("a").run();
    auto last = c.prepare("INSERT INTO u VALUES (?1) RETURNING k || '!'");
    last.bind("b").send_with_commit();
    ASSERT_TRUE(last.step());
    EXPECT_EQ(last.text(0), "b!");
    EXPECT_FALSE(c.in_transaction());
    EXPECT_EQ(stored(), "a,b");
    EXPECT_EQ(failure_of([&] { c.prepare("SELECT 1").step(); }).error.kind, Kind::internal);
    EXPECT_EQ(failure_of([&] { c.execute("SELECT 1"); }).error.kind, Kind::internal);
    c.commit();
    EXPECT_FALSE(c.in_transaction());
  }
  {  // A last statement that fails takes nothing with it: the transaction is rolled back.
    c.begin(TransactionKind::write);
    c.prepare("INSERT INTO u VALUES (?1)").bind("c").run();
    auto last = c.prepare("INSERT INTO u VALUES (?1) RETURNING k");
    last.bind("a").send_with_commit();  // "a" is taken
    const auto failed = failure_of([&] { last.step(); });
    EXPECT_EQ(failed.error.kind, Kind::conflict) << failed.error.message;
    EXPECT_EQ(failed.error.sql_state, "23505");
    EXPECT_FALSE(c.broken());
    c.rollback();
    EXPECT_EQ(stored(), "a,b");
  }
  {  // Sent and not stepped yet, it runs with the COMMIT when the transaction commits; dropped
     // before anything ran, it does not run, and the COMMIT goes out alone.
    c.begin(TransactionKind::write);
    auto last = c.prepare("INSERT INTO u VALUES (?1)");
    last.bind("d").send_with_commit();
    c.commit();
    EXPECT_FALSE(last.step());
    EXPECT_EQ(stored(), "a,b,d");
  }
  {
    c.begin(TransactionKind::write);
    c.prepare("INSERT INTO u VALUES (?1)").bind("c").run();
    c.prepare("INSERT INTO u VALUES (?1)").bind("dropped").send_with_commit();
    c.commit();
    EXPECT_EQ(stored(), "a,b,c,d");
  }
  // Outside a transaction there is no COMMIT to send it with.
  EXPECT_EQ(failure_of([&] { c.prepare("INSERT INTO u VALUES (?1)").bind("e").send_with_commit(); }).error.kind,
            Kind::internal);
  EXPECT_EQ(stored(), "a,b,c,d");
}

// The server ended the connection between two requests: that is found before anything is sent
// (the store's writer is replaced then), and a last statement sent on it regardless fails
// without having gone out, so it may run again.
TEST(PostgresqlConnectionTest, AConnectionTheServerEndedIsFoundSoBeforeALastStatementGoesOut) {
  Database db;
  db.connection->execute("CREATE TABLE t (x bigint)");
  auto c = connect(db.uri);
  c->prepare("INSERT INTO t VALUES (?1)");  // prepared now: nothing below needs the server
  EXPECT_TRUE(c->still_connected());
  EXPECT_TRUE(c->still_connected());
  postgres_cluster().execute("postgres", "SELECT pg_terminate_backend(" + std::to_string(c->backend_pid()) + ", 5000)");
  EXPECT_FALSE(c->still_connected());
  EXPECT_TRUE(c->broken());
  c->begin(TransactionKind::write);
  const auto lost = failure_of([&] { c->prepare("INSERT INTO t VALUES (?1)").bind(1).send_with_commit().step(); });
  EXPECT_EQ(lost.error.kind, Kind::unreachable) << lost.error.message;
  EXPECT_TRUE(lost.retryable);
  EXPECT_EQ(lost.error.message.find("unknown"), std::string::npos) << lost.error.message;
  c->rollback();
  EXPECT_EQ(postgres_cluster().integer(db.name, "SELECT count(*) FROM t"), 0);
}

// The failure of a last statement whose connection is lost while it is out: the server is
// stopped in `mode` while the statement waits on a row lock it needs (BEGIN and a first
// statement already ran, so the statement and COMMIT go out in a pipeline).
detail::Failure lost_while_out(std::string_view mode) {
  Database db;
  db.connection->execute("CREATE TABLE t (x bigint PRIMARY KEY)");
  auto holder = connect(db.uri);
  holder->begin(TransactionKind::write);
  holder->prepare("INSERT INTO t VALUES (?1)").bind(1).run();  // the key the statement below waits for
  auto c = connect(db.uri);
  c->begin(TransactionKind::write);
  c->prepare("INSERT INTO t VALUES (?1)").bind(2).run();
  auto last = c->prepare("INSERT INTO t VALUES (?1) RETURNING x");
  last.bind(1).send_with_commit();
  std::thread stopper([mode] {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    postgres_cluster().stop(std::string(mode));
  });
  auto lost = failure_of([&] { last.step(); });
  stopper.join();
  c->rollback();
  holder->rollback();
  postgres_cluster().start();
  EXPECT_EQ(postgres_cluster().integer(db.name, "SELECT count(*) FROM t"), 0);
  return lost;
}

// Stopped fast, the server ends the waiting statement with its own error: it stopped before
// COMMIT, so nothing was committed and the write may run again.
TEST(PostgresqlConnectionTest, ALastStatementTheServerEndedWithItsOwnErrorMayRunAgain) {
  const auto lost = lost_while_out("fast");
  EXPECT_EQ(lost.error.kind, Kind::unreachable) << lost.error.message;
  EXPECT_EQ(lost.error.sql_state, "57P01") << lost.error.message;
  EXPECT_TRUE(lost.retryable);
  EXPECT_EQ(lost.error.message.find("unknown"), std::string::npos) << lost.error.message;
}

// Stopped at once, the server only closes the connection: whether COMMIT ran cannot be told, the
// failure says so, and the write is not run again.
TEST(PostgresqlConnectionTest, ALastStatementWhoseConnectionJustClosedLeavesItsOutcomeUnknown) {
  const auto lost = lost_while_out("immediate");
  EXPECT_EQ(lost.error.kind, Kind::unreachable) << lost.error.message;
  EXPECT_FALSE(lost.retryable);
  EXPECT_NE(lost.error.message.find("whether it was stored is unknown"), std::string::npos) << lost.error.message;
}

TEST(PostgresqlConnectionTest, ALostConnectionIsUnreachableAndOnlyAnUncommittedTransactionMayRunAgain) {
  Database db;
  db.connection->execute("CREATE TABLE t (x bigint)");
  const auto terminate = [&](Connection& c) {
    postgres_cluster().execute("postgres", "SELECT pg_terminate_backend(" + std::to_string(c.backend_pid()) + ")");
  };

  auto c = connect(db.uri);
  c->begin(TransactionKind::write);
  c->prepare("INSERT INTO t VALUES (?1)").bind(1).run();
  terminate(*c);
  const auto lost = failure_of([&] { c->prepare("INSERT INTO t VALUES (?1)").bind(2).run(); });
  EXPECT_EQ(lost.error.kind, Kind::unreachable) << lost.error.message;
  EXPECT_TRUE(lost.retryable);
  EXPECT_TRUE(c->broken());
  c->rollback();

  c = connect(db.uri);
  c->begin(TransactionKind::write);
  c->prepare("INSERT INTO t VALUES (?1)").bind(3).run();
  terminate(*c);
  const auto committing = failure_of([&] { c->commit(); });
  EXPECT_EQ(committing.error.kind, Kind::unreachable);
  EXPECT_FALSE(committing.retryable);
  EXPECT_NE(committing.error.message.find("whether it was stored is unknown"), std::string::npos);
  EXPECT_EQ(postgres_cluster().integer(db.name, "SELECT count(*) FROM t"), 0);

  postgres_cluster().stop("immediate");
  const auto down = failure_of([&] { connect(db.uri); });
  EXPECT_EQ(down.error.kind, Kind::unreachable);
  EXPECT_NE(down.error.message.find("cannot reach the database server at postgresql://skinspec@"), std::string::npos)
      << down.error.message;
  postgres_cluster().start();
  EXPECT_EQ(connect(db.uri)->query_integer("SELECT count(*) FROM t"), 0);
}

TEST(PostgresqlConnectionTest, ConnectingFailsWithTheCauseNamed) {
  auto& cluster = postgres_cluster();
  const auto name = cluster.create_database();
  testing::ScratchDirectory scratch;
  const auto passwords = scratch.file("pgpass");
  ::setenv("PGPASSFILE", passwords.c_str(), 1);

  const auto no_password = failure_of([&] { connect(cluster.uri(name, "skinspec_pw")); }).error;
  EXPECT_EQ(no_password.kind, Kind::access_denied);
  EXPECT_NE(no_password.message.find("no password for role skinspec_pw"), std::string::npos) << no_password.message;

  std::ofstream(passwords) << "*:*:*:skinspec_pw:wrong\n";
  std::filesystem::permissions(passwords, std::filesystem::perms::owner_read | std::filesystem::perms::owner_write);
  const auto wrong = failure_of([&] { connect(cluster.uri(name, "skinspec_pw")); }).error;
  EXPECT_EQ(wrong.kind, Kind::access_denied);
  EXPECT_NE(wrong.message.find("refused the password of role skinspec_pw"), std::string::npos) << wrong.message;
  EXPECT_EQ(wrong.message.find("wrong"), std::string::npos);

  std::ofstream(passwords) << "*:*:*:skinspec_pw:right\n";
  EXPECT_EQ(connect(cluster.uri(name, "skinspec_pw"))->query_text("SELECT current_user"), "skinspec_pw");
  ::unsetenv("PGPASSFILE");

  const auto no_database = failure_of([&] { connect(cluster.uri("nowhere")); }).error;
  EXPECT_EQ(no_database.kind, Kind::unreachable);
  EXPECT_NE(no_database.message.find("\"nowhere\" does not exist"), std::string::npos) << no_database.message;

  const auto no_server =
      failure_of([&] { connect("postgresql://skinspec@/" + name + "?host=" + scratch.path().string()); }).error;
  EXPECT_EQ(no_server.kind, Kind::unreachable);
  EXPECT_NE(no_server.message.find("No such file or directory"), std::string::npos) << no_server.message;
}

}  // namespace
}  // namespace skinspec::store::postgresql
