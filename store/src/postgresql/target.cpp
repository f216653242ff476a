#include "postgresql/target.hpp"

#include <fmt/format.h>
#include <libpq-fe.h>

#include <memory>

#include "db.hpp"

namespace skinspec::store::postgresql {

using Kind = StoreError::Kind;

bool is_postgresql_uri(const std::string& target) {
  return target.starts_with("postgresql://") || target.starts_with("postgres://");
}

namespace {

using ConninfoOptions = std::unique_ptr<PQconninfoOption, decltype(&PQconninfoFree)>;

// libpq's parse errors quote the URI or a part of it, a password included: each quoted part
// becomes "...".
std::string without_quoted_parts(const std::string& message) {
  std::string out;
  bool quoted = false;
  for (const char c : message) {
    if (c == '"') {
      if (!quoted) out += "\"...\"";
      quoted = !quoted;
    } else if (!quoted) {
      out += c;
    }
  }
  return out;
}

// libpq's reading of `uri`; throws invalid_argument when it has none.
ConninfoOptions parsed(const std::string& uri) {
  char* error = nullptr;
  ConninfoOptions options(PQconninfoParse(uri.c_str(), &error), &PQconninfoFree);
  if (!options) {
    std::string message = error ? error : "libpq cannot parse it";
    PQfreemem(error);
    while (!message.empty() && message.back() == '\n') message.pop_back();
    detail::fail(Kind::invalid_argument, "not a PostgreSQL connection URI: " + without_quoted_parts(message));
  }
  return options;
}

std::string value_of(const ConninfoOptions& options, std::string_view keyword) {
  for (auto* option = options.get(); option->keyword; ++option)
    if (keyword == option->keyword && option->val) return option->val;
  return "";
}

std::string display_of(const ConninfoOptions& options) {
  const auto user = value_of(options, "user");
  const auto port = value_of(options, "port");
  return fmt::format("postgresql://{}{}{}/{}", user.empty() ? "" : user + "@", value_of(options, "host"),
                     port.empty() ? "" : ":" + port, value_of(options, "dbname"));
}

}  // namespace

Target parse_target(const std::string& uri) {
  const auto options = parsed(uri);
  if (!value_of(options, "password").empty() || !value_of(options, "sslpassword").empty())
    detail::fail(Kind::invalid_argument, "put the password in PGPASSFILE or ~/.pgpass, not in the URI");
  return Target{uri, display_of(options), value_of(options, "user")};
}

std::string display_form(const std::string& uri) {
  try {
    return display_of(parsed(uri));
  } catch (const detail::Failure&) {
    return "postgresql://(a URI libpq cannot parse)";
  }
}

std::vector<std::pair<std::string, std::string>> connection_keywords(const Target& target,
                                                                     const ConnectSettings& settings) {
  std::vector<std::pair<std::string, std::string>> keywords = {
      {"application_name", settings.application_name},
      {"connect_timeout", "10"},
      {"keepalives", "1"},
      {"keepalives_idle", "10"},
      {"keepalives_interval", "5"},
      {"keepalives_count", "3"},
      {"dbname", target.uri},  // expanded by libpq: what the URI says overrides the above
      {"client_encoding", "UTF8"},
  };
  return keywords;
}

}  // namespace skinspec::store::postgresql
