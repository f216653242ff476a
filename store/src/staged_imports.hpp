#pragma once
// Imports stored in batches (docs/store.md, "Imports"). A SQLite transaction that writes a large
// file at once holds every page it dirtied until its commit: past the page cache they are spilled
// into the write-ahead log again and again, and no checkpoint can copy the log back past it. So a
// large import is committed a batch at a time, its measurements naming an import row that every
// read passes over (kPublished, rows.hpp) until one small transaction publishes it with its job's
// end. An import that is not published (it failed, or its writer died) is removed a batch at a
// time, by its writer or when the file is next opened.

#include <optional>
#include <vector>

#include "db.hpp"
#include "skinspec/store/types.hpp"

namespace skinspec::store::detail {

// A new, unpublished import (of job `job_id` when given): its id. Inside the caller's transaction.
Id begin_import(Connection& c, std::optional<Id> job_id, Time now);

// Makes import `import_id`'s measurements seen by every read. Inside the caller's transaction.
void publish_import(Connection& c, Id import_id, Time now);

// Removes up to `limit` measurements of unpublished import `import_id`, with their fits, and its
// row once none is left, inside the caller's transaction. Whether the import is gone.
bool remove_part_of_import(Connection& c, Id import_id, int limit);

// Every unpublished import removed on `writer`, `limit` measurements to a transaction: what
// opening does after a writer died mid-import. How many imports were removed.
int remove_unpublished_imports(Connection& writer, int limit);

}  // namespace skinspec::store::detail
