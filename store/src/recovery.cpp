// Recovery after a writer that died: the same SQL on every engine.

#include "recovery.hpp"

#include "codec.hpp"
#include "staged_imports.hpp"

namespace skinspec::store::detail {

// Such a job has stored nothing: a job's measurement or map is stored in the transaction that
// ends it (complete_measurement_job, complete_map_job). ?1 is the bench, NULL for every bench; a bench's recovery also
// covers what was written before benches (bench '') when ?2.
RecoveryReport mark_interrupted(Connection& writer, RecoveryPolicy policy, const Owner& owner, Time now) {
  RecoveryReport report;
  const std::optional<std::string_view> bench = owner.bench;
  {
    auto running = writer.prepare(policy == RecoveryPolicy::all_open_sessions
                                      ? "SELECT id FROM sessions WHERE state = 'open' AND (bench = ?1 OR (bench = '' "
                                        "AND ?2) OR ?1 IS NULL) ORDER BY id"
                                      : "SELECT DISTINCT s.id FROM sessions s JOIN jobs j ON j.session_id = s.id "
                                        "WHERE s.state = 'open' AND j.state IN ('queued', 'running') "
                                        "AND (j.bench = ?1 OR (j.bench = '' AND ?2) OR ?1 IS NULL) ORDER BY s.id");
    running.bind(bench, owner.with_unowned);
    while (running.step()) report.interrupted_sessions.push_back(running.integer(0));
  }
  {
    auto active = writer.prepare(
        "SELECT id FROM jobs WHERE state IN ('queued', 'running') AND (bench = ?1 OR (bench = '' AND ?2) OR ?1 IS "
        "NULL) "
        "ORDER BY id");
    active.bind(bench, owner.with_unowned);
    while (active.step()) report.failed_jobs.push_back(active.integer(0));
  }
  const auto interrupted =
      detail::encode_job_error({JobErrorCode::interrupted, "the program running it stopped before it finished"});
  // Each guarded by its state: another program may have ended it since it was selected.
  for (const Id id : report.interrupted_sessions) {
    writer
        .prepare(
            "UPDATE sessions SET state = 'interrupted', updated_at = ?2, ended_at = ?2 WHERE id = ?1 "
            "AND state = 'open'")
        .bind(id, now)
        .run();
  }
  for (const Id id : report.failed_jobs) {
    writer
        .prepare(
            "UPDATE jobs SET state = 'failed', error = ?2, finished_at = ?3 WHERE id = ?1 "
            "AND state IN ('queued', 'running')")
        .bind(id, interrupted, now)
        .run();
  }
  return report;
}

RecoveryReport recover(Connection& writer, RecoveryPolicy policy, const Owner& owner, Time now, int import_batch) {
  remove_unpublished_imports(writer, import_batch, owner.bench);
  Transaction transaction(writer, detail::TransactionKind::write);
  auto report = mark_interrupted(writer, policy, owner, now);
  transaction.commit();
  return report;
}

}  // namespace skinspec::store::detail
