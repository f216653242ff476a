// Recovery after a writer that died: the same SQL on every engine.

#include "recovery.hpp"

#include "codec.hpp"

namespace skinspec::store::detail {

// Such a job has stored nothing: a job's measurement is stored in the transaction that ends it
// (complete_measurement_job).
RecoveryReport recover(detail::Connection& writer, RecoveryPolicy policy, Time now) {
  RecoveryReport report;
  Transaction transaction(writer, detail::TransactionKind::write);
  {
    auto running = writer.prepare(policy == RecoveryPolicy::all_open_sessions
                                      ? "SELECT id FROM sessions WHERE state = 'open' ORDER BY id"
                                      : "SELECT DISTINCT s.id FROM sessions s JOIN jobs j ON j.session_id = s.id "
                                        "WHERE s.state = 'open' AND j.state IN ('queued', 'running') ORDER BY s.id");
    while (running.step()) report.interrupted_sessions.push_back(running.integer(0));
  }
  {
    auto active = writer.prepare("SELECT id FROM jobs WHERE state IN ('queued', 'running') ORDER BY id");
    while (active.step()) report.failed_jobs.push_back(active.integer(0));
  }
  const auto interrupted =
      detail::encode_job_error({JobErrorCode::interrupted, "the program running it stopped before it finished"});
  for (const Id id : report.interrupted_sessions) {
    writer.prepare("UPDATE sessions SET state = 'interrupted', updated_at = ?2, ended_at = ?2 WHERE id = ?1")
        .bind(id, now)
        .run();
  }
  for (const Id id : report.failed_jobs) {
    writer.prepare("UPDATE jobs SET state = 'failed', error = ?2, finished_at = ?3 WHERE id = ?1")
        .bind(id, interrupted, now)
        .run();
  }
  transaction.commit();
  return report;
}

}  // namespace skinspec::store::detail
