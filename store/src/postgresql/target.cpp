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

Target parse_target(const std::string& uri) {
  char* error = nullptr;
  std::unique_ptr<PQconninfoOption, decltype(&PQconninfoFree)> options(PQconninfoParse(uri.c_str(), &error),
                                                                       &PQconninfoFree);
  if (!options) {
    std::string message = error ? error : "libpq cannot parse it";
    PQfreemem(error);
    while (!message.empty() && message.back() == '\n') message.pop_back();
    detail::fail(Kind::invalid_argument, "not a PostgreSQL connection URI: " + message);
  }
  const auto value = [&](std::string_view keyword) -> std::string {
    for (auto* option = options.get(); option->keyword; ++option)
      if (keyword == option->keyword && option->val) return option->val;
    return "";
  };
  if (!value("password").empty())
    detail::fail(Kind::invalid_argument, "put the password in PGPASSFILE or ~/.pgpass, not in the URI");
  Target target;
  target.uri = uri;
  target.user = value("user");
  const auto host = value("host");
  const auto port = value("port");
  target.display = fmt::format("postgresql://{}{}{}/{}", target.user.empty() ? "" : target.user + "@", host,
                               port.empty() ? "" : ":" + port, value("dbname"));
  return target;
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
  if (settings.read_only) keywords.emplace_back("options", "-c default_transaction_read_only=on");
  return keywords;
}

}  // namespace skinspec::store::postgresql
