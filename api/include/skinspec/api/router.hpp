#pragma once
// The service as a pure function from a request to a response: no sockets, no threads of its
// own. The server (server.hpp) reads requests off connections and hands them here; tests call
// it directly. The route table is the single list of what the service offers; GET /openapi.json
// is generated from it.

#include <chrono>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "skinspec/api/errors.hpp"
#include "skinspec/api/metrics.hpp"
#include "skinspec/api/tokens.hpp"

namespace skinspec {
class Fitter;
namespace store {
class Store;
}
}  // namespace skinspec

namespace skinspec::api {

class Acquisition;
class RenderCache;
class BodyCache;
class FitJobs;
class JobBoard;

struct Request {
  std::string method;                          // "GET", "POST", ...
  std::string target;                          // path and query, as sent: "/api/v1/sessions?site=forearm"
  std::map<std::string, std::string> headers;  // names in lower case
  std::string body;
  std::string peer = {};  // the client's address, as the audit trail records it
};

// A body that comes piece by piece after the response's header, such as Server-Sent Events.
// The server pulls it on a thread of its own, so next() may block.
class EventSource {
 public:
  virtual ~EventSource() = default;
  // The next piece to send; when nothing came within `keep_alive`, a piece that keeps the
  // connection alive; nullopt when the stream has ended.
  virtual std::optional<std::string> next(std::chrono::milliseconds keep_alive) = 0;
  // Ends the stream (the client left, the server stops): a blocked or later next() returns
  // nullopt at once. Thread-safe.
  virtual void close() = 0;
};

struct Response {
  int status = 200;
  std::string content_type = "application/json";
  std::string body;
  std::vector<std::pair<std::string, std::string>> headers;  // extra headers (Allow, Location)
  std::shared_ptr<EventSource> events = nullptr;             // when set, the body: sent in chunks after the header
};

// Where the cubes of skin maps come from and where map jobs work (docs/maps.md, "In the service").
struct MapFiles {
  // The directory whose cubes POST /api/v1/maps may name by a path inside it; empty: uploads only.
  std::filesystem::path data_dir;
  // Where map jobs keep uploads and answers until they are stored; the system's temporary
  // directory when empty.
  std::filesystem::path work_dir;
};

struct RouterContext {
  store::Store* store = nullptr;              // null: data routes answer 503
  const Fitter* fitter = nullptr;             // null: fitting routes answer 503
  Acquisition* acquisition = nullptr;         // null: no instrument; measurement routes answer 503
  std::shared_ptr<Metrics> metrics;           // created when null
  std::shared_ptr<RenderCache> render_cache;  // images of GET /api/v1/fits/{id}/render.png; created when null
  std::shared_ptr<BodyCache> body_cache;      // answers of GET /api/v1/fits/{id}; created when null
  // This program's queued and running jobs of every kind; created when null. The acquisition
  // given runs its measurements on the same board.
  std::shared_ptr<JobBoard> job_board;
  // Imports and refits; created on job_board when null and there are a store and a fitter.
  std::shared_ptr<FitJobs> fit_jobs;
  MapFiles maps;
  // The bearer tokens every route needs one of (but those of RouteInfo::needs_token false),
  // of a scope that covers the route's; null: no token is asked for (loopback without
  // --token-file). The daemon replaces the set on SIGHUP.
  std::shared_ptr<const Keyring> tokens;
  std::size_t max_spectrum_samples = 10000;
};

struct RouteInfo {
  std::string method;
  std::string path;  // template with {id} segments
  std::string summary;
  // The least scope of a token that may call it (tokens.hpp).
  Scope scope = Scope::read;
  std::string request_schema;   // name in components/schemas, empty for none
  std::string response_schema;  // name in components/schemas, or "text/csv", "text/plain"
  int success_status = 200;
  // CPU-heavy (fits, renders): the server runs it on its bounded compute pool.
  bool heavy = false;
  // Takes a file as its body: the server allows it the upload limit instead of the body limit.
  bool upload = false;
  // A GET its handler may answer from the cache of answers alone (a stored fit): the server
  // asks for that on the thread that read the request (Router::answer_from_memory).
  bool from_memory = false;
  // False for a route that answers without a token even when the service asks for them (a
  // liveness probe knows no token).
  bool needs_token = true;
};

class Router {
 public:
  explicit Router(RouterContext context);
  ~Router();
  Router(const Router&) = delete;
  Router& operator=(const Router&) = delete;

  // Never throws: every failure becomes a JSON error response.
  Response handle(const Request& request) const;

  static const std::vector<RouteInfo>& routes();
  // Whether `method` on `target` (as in a Request) is a heavy route.
  static bool is_heavy(const std::string& method, const std::string& target);
  // The answer to `request` for a route that may be answered from memory (RouteInfo::from_memory)
  // when memory alone can give it (an answer served before, or a refusal of the request as it
  // stands), as handle() would; nothing otherwise. It never waits
  // for the database, so the server asks it on the thread that read the request, and hands
  // the request to a worker only when it answers nothing.
  std::optional<Response> answer_from_memory(const Request& request) const;
  // Whether `method` on `target` takes a file as its body (RouteInfo::upload).
  static bool is_upload(const std::string& method, const std::string& target);
  // An upload's refusal for want of the token (401, 403), from its header alone, so that the
  // server need not take in a large body that would be refused anyway.
  std::optional<ApiError> refuse_upload(const Request& header) const;
  // OpenAPI 3.1, generated from routes(), with this build's version.
  static nlohmann::json openapi_document();

  Metrics& metrics() const { return *context_.metrics; }

  struct Handlers;

 private:
  std::optional<Response> answer(const Request& request, bool from_memory_only) const;
  // The route `method` on `target` (as in a Request) matches; null for none.
  static const RouteInfo* route_of(const std::string& method, const std::string& target);
  RouterContext context_;
};

// A response carrying `error` in the one JSON shape, with its status.
Response error_response(const ApiError& error);

}  // namespace skinspec::api
