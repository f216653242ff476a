#pragma once
// The service's one error shape, {"error": {"code": "...", "message": "..."}}, the one place
// where error kinds become HTTP statuses, and the one place where the store's errors become
// the service's.

#include <string>
#include <string_view>

#include "skinspec/store/types.hpp"

namespace skinspec::api {

enum class ErrorKind {
  bad_request,             // 400: malformed JSON, invalid UTF-8, a bad path or query
  unauthorized,            // 401: no or unknown bearer token
  forbidden,               // 403: a token whose scope is below the route's
  not_found,               // 404: no such route or record
  method_not_allowed,      // 405: the path exists, the method does not
  conflict,                // 409: not allowed in the record's current state
  payload_too_large,       // 413: body over the limit
  unsupported_media_type,  // 415: a body that is not application/json
  unprocessable,           // 422: well-formed JSON with wrong types, missing fields, bad values
  unavailable,             // 503: database or model not available, store busy
  insufficient_storage,    // 507: the database's disk is full
  timeout,                 // 504: the work did not finish in time
  internal,                // 500: anything else
};

int http_status(ErrorKind kind);
std::string_view default_code(ErrorKind kind);

struct ApiError {
  ErrorKind kind = ErrorKind::internal;
  std::string code;  // machine-readable, e.g. "malformed_json"; default_code(kind) when empty
  std::string message;
};

// The JSON body of an error response.
std::string error_body(const ApiError& error);

// A store error as every route and the acquisition report it. What the client asked for that
// the store refused: invalid_argument → 422 invalid_value, not_found → 404, conflict → 409.
// The database unavailable for now (a retry after the condition clears may succeed): busy,
// full, read_only, unreachable → 503 database_busy, database_full, database_read_only,
// database_unreachable. The database or the program broken: io, corrupt, newer_schema,
// older_schema, internal, access_denied → 500 database_io, database_corrupt, database_schema,
// database_error, database_access_denied.
ApiError from_store_error(const store::StoreError& error);

}  // namespace skinspec::api
