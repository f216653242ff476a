#pragma once
// The PostgreSQL engine's own SQL for writes that the shared SQL makes in more statements than
// PostgreSQL needs: each statement saved is a round trip to the server saved.

#include <string>
#include <string_view>

namespace skinspec::store::postgresql {

// The one statement that records a measurement, with its fit when there is one, and ends the
// measurement's job when it is a job's: what the checks need is read (the session locked for
// share, the job for update), and the rows are written only when those checks pass, so that it
// can go out with its transaction's COMMIT. The measurement's `measurement_columns` take ?1 ...
// ?`measurement_count`, the fit's `fit_columns` the next `fit_count` parameters, and when it ends
// a job, the next one is the head of the job's new result: the caller's result without its
// closing brace (store_write.cpp, result_head()), which the statement completes with the ids.
struct Recording {
  std::string_view measurement_columns;
  int measurement_count = 0;
  std::string_view fit_columns;  // empty: no fit
  int fit_count = 0;
  std::string_view job_columns;  // empty: no job to end; else the ended job's columns returned
};
std::string recording_statement(const Recording& shape);

// Its one row's columns: what the checks read (NULL where there was no such row), the new ids
// (NULL where nothing was written) and, from job_row on, the ended job's `job_columns`.
enum RecordingColumn : int {
  job_state,
  job_session_id,
  session_state,
  white_kind,
  instrument_count,
  new_measurement_id,
  new_fit_id,
  job_row,
};

}  // namespace skinspec::store::postgresql
