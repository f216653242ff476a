#pragma once
// Imports stored in batches (docs/store.md, "Imports"). A transaction that writes a large file at
// once holds the writer while the file is fitted, and on SQLite every page it dirtied until its
// commit: past the page cache they are spilled into the write-ahead log again and again, and no
// checkpoint can copy the log back past it. So a large import is committed a batch at a time, on
// every engine, its measurements naming an import row that every read passes over (kPublished,
// rows.hpp) until one small transaction publishes it with its job's end. An import that is not
// published (it failed, or its writer died) is removed a batch at a time, by its writer or when
// its bench's writer next opens the database.

#include <optional>
#include <string_view>
#include <vector>

#include "db.hpp"
#include "skinspec/store/types.hpp"

namespace skinspec::store::detail {

// A new, unpublished import (of job `job_id` when given) of bench `bench`: its id. Inside the
// caller's transaction.
Id begin_import(Connection& c, std::optional<Id> job_id, std::string_view bench, Time now);

// Makes import `import_id`'s measurements seen by every read. Inside the caller's transaction.
void publish_import(Connection& c, Id import_id, Time now);

// Removes up to `limit` measurements of unpublished import `import_id`, with their fits, and its
// row once none is left, inside the caller's transaction. Whether there is nothing left to remove
// (a published import is left whole).
bool remove_part_of_import(Connection& c, Id import_id, int limit);

// Every unpublished import of `bench` (of every bench when none is given) removed on `writer`,
// `limit` measurements to a transaction: what opening does after a writer died mid-import. Another
// bench's writer may be storing one of its own meanwhile. How many imports were removed.
int remove_unpublished_imports(Connection& writer, int limit, std::optional<std::string_view> bench);

}  // namespace skinspec::store::detail
