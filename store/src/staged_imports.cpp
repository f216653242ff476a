#include "staged_imports.hpp"

#include <vector>

namespace skinspec::store::detail {

Id begin_import(Connection& c, std::optional<Id> job_id, std::string_view bench, Time now) {
  auto insert = c.prepare("INSERT INTO imports (job_id, bench, started_at) VALUES (?1, ?2, ?3) RETURNING id");
  insert.bind(job_id, bench, now);
  if (!insert.step()) fail(StoreError::Kind::internal, "an import's row returned no id");
  const Id id = insert.integer(0);
  insert.run();
  return id;
}

void publish_import(Connection& c, Id import_id, Time now) {
  auto update = c.prepare("UPDATE imports SET published_at = ?2 WHERE id = ?1 AND published_at IS NULL RETURNING id");
  update.bind(import_id, now);
  if (!update.step()) fail(StoreError::Kind::internal, "the import to publish has no unpublished row");
  update.run();
}

bool remove_part_of_import(Connection& c, Id import_id, int limit) {
  // A publication whose outcome was not known (its connection lost after the COMMIT went out)
  // may have committed: a published import is kept whole.
  auto unpublished = c.prepare("SELECT 1 FROM imports WHERE id = ?1 AND published_at IS NULL", RowLock::update);
  unpublished.bind(import_id);
  if (!unpublished.step()) return true;
  unpublished.run();
  // The same measurements for both: the first `limit` of the import by id, as its index orders them.
  c.prepare(
       "DELETE FROM fits WHERE measurement_id IN "
       "(SELECT id FROM measurements WHERE import_id = ?1 ORDER BY id LIMIT ?2)")
      .bind(import_id, limit)
      .run();
  auto removed = c.prepare(
      "DELETE FROM measurements WHERE id IN (SELECT id FROM measurements WHERE import_id = ?1 ORDER BY id LIMIT ?2) "
      "RETURNING id");
  removed.bind(import_id, limit);
  bool any = false;
  while (removed.step()) any = true;
  if (any) return false;
  c.prepare("DELETE FROM imports WHERE id = ?1 AND published_at IS NULL").bind(import_id).run();
  return true;
}

int remove_unpublished_imports(Connection& writer, int limit, std::optional<std::string_view> bench) {
  std::vector<Id> unpublished;
  {
    Transaction transaction(writer, TransactionKind::read);
    auto rows =
        writer.prepare("SELECT id FROM imports WHERE published_at IS NULL AND (bench = ?1 OR ?1 IS NULL) ORDER BY id");
    rows.bind(bench);
    while (rows.step()) unpublished.push_back(rows.integer(0));
    transaction.commit();
  }
  for (const Id id : unpublished) {
    for (bool gone = false; !gone;) {
      Transaction transaction(writer, TransactionKind::write);
      gone = remove_part_of_import(writer, id, limit);
      transaction.commit();
    }
  }
  return static_cast<int>(unpublished.size());
}

}  // namespace skinspec::store::detail
