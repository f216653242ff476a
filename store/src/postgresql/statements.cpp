#include "postgresql/statements.hpp"

#include <fmt/format.h>

#include "db.hpp"

namespace skinspec::store::postgresql {

std::string measurement_with_fit_insert(std::string_view measurement_columns, int measurement_count,
                                        std::string_view fit_columns, int fit_count) {
  return fmt::format(
      "WITH m AS (INSERT INTO measurements ({}) VALUES ({}) RETURNING id), "
      "f AS (INSERT INTO fits (measurement_id, {}) SELECT id, {} FROM m RETURNING id) "
      "SELECT m.id, f.id FROM m, f",
      measurement_columns, detail::placeholders(1, measurement_count), fit_columns,
      detail::placeholders(measurement_count + 1, fit_count));
}

}  // namespace skinspec::store::postgresql
