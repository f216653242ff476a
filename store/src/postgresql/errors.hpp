#pragma once
// What PostgreSQL's error codes (SQLSTATE) mean to the store's callers.

#include <string_view>

#include "skinspec/store/types.hpp"

namespace skinspec::store::postgresql {

StoreError::Kind kind_of_sql_state(std::string_view sql_state);

// Whether a statement that failed with `sql_state` left nothing committed and may pass when
// its whole transaction is run again (a serialisation failure, a deadlock, a lock timeout).
bool retryable_sql_state(std::string_view sql_state);

// Whether `sql_state` says the connection is gone (the server shut down or ended it).
bool connection_lost_sql_state(std::string_view sql_state);

}  // namespace skinspec::store::postgresql
