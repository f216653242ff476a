#pragma once
// The PostgreSQL engine's own SQL for writes that the shared SQL makes in more statements than
// PostgreSQL needs: each statement saved is a round trip to the server saved.

#include <string>
#include <string_view>

namespace skinspec::store::postgresql {

// One statement that inserts a measurement and its fit and returns both ids: the
// measurement's `measurement_columns` take ?1 ... ?`measurement_count`, the fit's `fit_columns`
// the next `fit_count` parameters, and its measurement_id is the new measurement's (a
// data-modifying WITH: the measurement's row and the fit's are written by one statement).
std::string measurement_with_fit_insert(std::string_view measurement_columns, int measurement_count,
                                        std::string_view fit_columns, int fit_count);

}  // namespace skinspec::store::postgresql
