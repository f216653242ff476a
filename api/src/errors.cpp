#include "skinspec/api/errors.hpp"

#include <nlohmann/json.hpp>

namespace skinspec::api {

int http_status(ErrorKind kind) {
  switch (kind) {
    case ErrorKind::bad_request:
      return 400;
    case ErrorKind::unauthorized:
      return 401;
    case ErrorKind::forbidden:
      return 403;
    case ErrorKind::not_found:
      return 404;
    case ErrorKind::method_not_allowed:
      return 405;
    case ErrorKind::conflict:
      return 409;
    case ErrorKind::payload_too_large:
      return 413;
    case ErrorKind::unsupported_media_type:
      return 415;
    case ErrorKind::unprocessable:
      return 422;
    case ErrorKind::unavailable:
      return 503;
    case ErrorKind::insufficient_storage:
      return 507;
    case ErrorKind::timeout:
      return 504;
    case ErrorKind::internal:
      return 500;
  }
  return 500;
}

std::string_view default_code(ErrorKind kind) {
  switch (kind) {
    case ErrorKind::bad_request:
      return "bad_request";
    case ErrorKind::unauthorized:
      return "unauthorized";
    case ErrorKind::forbidden:
      return "forbidden";
    case ErrorKind::not_found:
      return "not_found";
    case ErrorKind::method_not_allowed:
      return "method_not_allowed";
    case ErrorKind::conflict:
      return "conflict";
    case ErrorKind::payload_too_large:
      return "payload_too_large";
    case ErrorKind::unsupported_media_type:
      return "unsupported_media_type";
    case ErrorKind::unprocessable:
      return "unprocessable";
    case ErrorKind::unavailable:
      return "unavailable";
    case ErrorKind::insufficient_storage:
      return "storage_full";
    case ErrorKind::timeout:
      return "timeout";
    case ErrorKind::internal:
      return "internal";
  }
  return "internal";
}

std::string error_body(const ApiError& error) {
  const std::string code = error.code.empty() ? std::string(default_code(error.kind)) : error.code;
  nlohmann::json body = {{"error", {{"code", code}, {"message", error.message}}}};
  return body.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

ApiError from_store_error(const store::StoreError& error) {
  using K = store::StoreError::Kind;
  const auto as = [&error](ErrorKind kind, const char* code) { return ApiError{kind, code, error.message}; };
  switch (error.kind) {
    case K::invalid_argument:
      return as(ErrorKind::unprocessable, "invalid_value");
    case K::not_found:
      return as(ErrorKind::not_found, "not_found");
    case K::conflict:
      return as(ErrorKind::conflict, "conflict");
    case K::busy:
      return as(ErrorKind::unavailable, "database_busy");
    case K::full:
      return as(ErrorKind::insufficient_storage, "storage_full");
    case K::read_only:
      return as(ErrorKind::unavailable, "database_read_only");
    case K::io:
      return as(ErrorKind::internal, "database_io");
    case K::corrupt:
      return as(ErrorKind::internal, "database_corrupt");
    case K::newer_schema:
    case K::older_schema:
      return as(ErrorKind::internal, "database_schema");
    case K::internal:
      return as(ErrorKind::internal, "database_error");
    case K::unreachable:
      return as(ErrorKind::unavailable, "database_unreachable");
    case K::access_denied:
      return as(ErrorKind::internal, "database_access_denied");
  }
  return as(ErrorKind::internal, "database_error");
}

}  // namespace skinspec::api
