#pragma once
// A PostgreSQL database named by a libpq connection URI ("postgresql://[user@][host][:port]/
// dbname[?param=value...]", or "postgres://"): what libpq is given to connect, and the form
// shown in messages. A password is never taken from the URI: libpq reads it from PGPASSFILE or
// ~/.pgpass, so that it never appears on a command line or in a log.

#include <string>
#include <utility>
#include <vector>

namespace skinspec::store::postgresql {

bool is_postgresql_uri(const std::string& target);

struct Target {
  std::string uri;      // as given
  std::string display;  // postgresql://user@host:port/dbname, each part only when the URI names it
  std::string user;     // the role the URI names, or empty (libpq's default)
};

struct ConnectSettings {
  std::string application_name = "skinspec";
  // Every transaction of the connection read-only (a Store opened to read): even a bug cannot
  // write. Otherwise the session is set for writing durably (Connection::apply).
  bool read_only = false;
};

// Throws invalid_argument for a URI libpq cannot parse or one that holds a password.
Target parse_target(const std::string& uri);

// `uri` as messages show it: postgresql://user@host:port/dbname, never a password (nor the
// parameters, which could hold one).
std::string display_form(const std::string& uri);

// libpq's keywords and values for connecting to `target`: the store's defaults (timeouts,
// keepalives), then the URI (whose parameters override the defaults), then what the store
// needs whatever the URI says (UTF-8).
std::vector<std::pair<std::string, std::string>> connection_keywords(const Target& target,
                                                                     const ConnectSettings& settings);

}  // namespace skinspec::store::postgresql
