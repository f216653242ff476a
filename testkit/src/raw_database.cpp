#include "skinspec/testkit/raw_database.hpp"

#include <libpq-fe.h>

#include <stdexcept>

#include "skinspec/testkit/store_samples.hpp"

namespace skinspec::testing {

namespace {

class SqliteDatabase final : public RawDatabase {
 public:
  explicit SqliteDatabase(std::string path) : path_(std::move(path)) {}
  std::string text(const std::string& sql) override { return sqlite_text(path_, sql); }
  long long integer(const std::string& sql) override { return sqlite_integer(path_, sql); }
  void execute(const std::string& sql) override { sqlite_execute(path_, sql); }
  store::Backend backend() const override { return store::Backend::sqlite; }

 private:
  std::string path_;
};

using Result = std::unique_ptr<PGresult, decltype(&PQclear)>;

class PostgresqlDatabase final : public RawDatabase {
 public:
  explicit PostgresqlDatabase(const std::string& uri) : connection_(PQconnectdb(uri.c_str()), &PQfinish) {
    if (PQstatus(connection_.get()) != CONNECTION_OK)
      throw std::runtime_error("cannot connect to " + uri + ": " + PQerrorMessage(connection_.get()));
  }
  std::string text(const std::string& sql) override {
    const auto result = query(sql, PGRES_TUPLES_OK);
    if (PQntuples(result.get()) < 1 || PQnfields(result.get()) < 1)
      throw std::runtime_error("'" + sql + "' returned no row");
    return PQgetvalue(result.get(), 0, 0);
  }
  long long integer(const std::string& sql) override {
    const auto value = text(sql);
    try {
      return std::stoll(value);
    } catch (const std::exception&) {
      throw std::runtime_error("'" + sql + "' returned '" + value + "', not an integer");
    }
  }
  void execute(const std::string& sql) override { query(sql, PGRES_COMMAND_OK); }
  store::Backend backend() const override { return store::Backend::postgresql; }

 private:
  // PQexec runs a script of several statements; the result is the last one's.
  Result query(const std::string& sql, ExecStatusType expected) {
    Result result(PQexec(connection_.get(), sql.c_str()), &PQclear);
    const auto status = PQresultStatus(result.get());
    if (status != expected && !(expected == PGRES_COMMAND_OK && status == PGRES_TUPLES_OK))
      throw std::runtime_error("'" + sql + "' failed: " + PQerrorMessage(connection_.get()));
    return result;
  }

  std::unique_ptr<PGconn, decltype(&PQfinish)> connection_;
};

}  // namespace

std::unique_ptr<RawDatabase> raw_database(const std::string& target) {
  if (target.starts_with("postgresql://") || target.starts_with("postgres://"))
    return std::make_unique<PostgresqlDatabase>(target);
  if (target.starts_with("sqlite:")) return std::make_unique<SqliteDatabase>(target.substr(7));
  return std::make_unique<SqliteDatabase>(target);
}

std::string jobs_and_rows_disagreement(const std::string& target) {
  auto db = raw_database(target);
  const bool sqlite = db->backend() == store::Backend::sqlite;
  // The ids a job's result names, in each dialect.
  const std::string measurement_named =
      sqlite ? "json_extract(j.result, '$.measurement_id')" : "(j.result ->> 'measurement_id')::bigint";
  const std::string fit_named = sqlite ? "json_extract(j.result, '$.fit_id')" : "(j.result ->> 'fit_id')::bigint";
  const std::string differs = sqlite ? "IS NOT" : "IS DISTINCT FROM";
  const std::pair<std::string, std::string> checks[] = {
      {"measurements of a job that has not succeeded or does not name them and their fit",
       "SELECT count(*) FROM measurements m JOIN jobs j ON j.id = m.job_id WHERE j.state <> 'succeeded' OR " +
           measurement_named + " " + differs + " m.id OR " + fit_named + " " + differs +
           " (SELECT min(f.id) FROM fits f WHERE f.measurement_id = m.id)"},
      {"succeeded jobs without their measurement",
       "SELECT count(*) FROM jobs j WHERE j.state = 'succeeded' AND NOT EXISTS (SELECT 1 FROM measurements m WHERE "
       "m.job_id = j.id AND m.id = " +
           measurement_named + ")"},
  };
  std::string problems;
  for (const auto& [what, sql] : checks)
    if (const auto n = db->integer(sql); n != 0) problems += std::to_string(n) + " " + what + "; ";
  return problems;
}

}  // namespace skinspec::testing
