#pragma once
// Queries on a database that bypass the store, for checks and for databases made by hand:
// a SQLite file (a path, or "sqlite:PATH") or a PostgreSQL database (a libpq URI).

#include <memory>
#include <string>

#include "skinspec/store/store.hpp"

namespace skinspec::testing {

class RawDatabase {
 public:
  virtual ~RawDatabase() = default;
  // The first column of the first row, as text ("" for NULL) or as an integer; each throws
  // std::runtime_error when the query fails or returns no row.
  virtual std::string text(const std::string& sql) = 0;
  virtual long long integer(const std::string& sql) = 0;
  // Runs statements that return nothing (several, separated by ';').
  virtual void execute(const std::string& sql) = 0;
  virtual store::Backend backend() const = 0;
};

// Opened now; a PostgreSQL connection stays open for the object's lifetime.
std::unique_ptr<RawDatabase> raw_database(const std::string& target);

// What must hold of a database whenever its writer died, read outside the store: every stored
// measurement's job has succeeded and names it and its fit (or no fit, when it has none),
// every succeeded job has its measurement. Empty when it holds; else what does not.
std::string jobs_and_rows_disagreement(const std::string& target);

}  // namespace skinspec::testing
