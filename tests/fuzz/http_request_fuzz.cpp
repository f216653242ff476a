// libFuzzer target: the bytes a client sends on one connection, through the server's own
// request handling (api/src/http_exchange.hpp: the parser and its limits, the framing checks,
// the request the router sees, the reply written back) into the router over a real store and
// the model, with access tokens required. The requests the bytes hold are answered in turn, as
// on a kept-alive connection, until the bytes end, a request cannot be read, or an answer
// closes the connection. Besides not crashing: every answer is a well-formed HTTP response
// that reads back as written, with no body for a HEAD, and with the JSON error body for every
// status of 400 and above. Build and run with scripts/fuzz.

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include <boost/asio/buffer.hpp>
#include <boost/beast/http/error.hpp>
#include <boost/beast/http/write.hpp>
#include <nlohmann/json.hpp>

#include "fitter_loader.hpp"
#include "http_exchange.hpp"
#include "skinspec/api/router.hpp"
#include "skinspec/store/store.hpp"

namespace api = skinspec::api;
namespace detail = skinspec::api::detail;
namespace http = boost::beast::http;
using nlohmann::json;

namespace {

// The tokens the seed requests in tests/data/http/ carry.
constexpr const char* kReadToken = "fuzz-read-token-0123456789";
constexpr const char* kOperatorToken = "fuzz-operator-token-0123456789";
constexpr detail::RequestLimits kLimits{16 * 1024, 4 * 1024};

// Stops the run so that libFuzzer keeps the input that broke an invariant.
void require(bool condition, const char* invariant) {
  if (!condition) {
    std::fprintf(stderr, "http invariant broken: %s\n", invariant);
    std::abort();
  }
}

// The model, loaded once.
const skinspec::Fitter& fitter() {
  static const skinspec::Fitter loaded = [] {
    auto model = skinspec::load_fitter();
    require(model.has_value(), "the model loads (set SKINSPEC_DATA_DIR)");
    return std::move(*model);
  }();
  return loaded;
}

// The store (in a scratch directory, on tmpfs when there is one) and the router.
struct Service {
  std::filesystem::path dir;
  std::optional<skinspec::store::Store> store;
  std::unique_ptr<api::Router> router;

  Service() {
    const bool shm = std::filesystem::is_directory("/dev/shm") && ::access("/dev/shm", W_OK) == 0;
    std::string pattern = (shm ? std::string("/dev/shm") : std::filesystem::temp_directory_path().string()) +
                          "/skinspec-http-fuzz-XXXXXX";
    require(::mkdtemp(pattern.data()) != nullptr, "a scratch directory");
    dir = pattern;
    auto opened = skinspec::store::Store::open((dir / "fuzz.db").string());
    require(opened.has_value(), "the store opens");
    store.emplace(std::move(*opened));
    api::RouterContext context;
    context.store = &*store;
    context.fitter = &fitter();
    // As skinspecd reads an old two-token file: the operator's token may do everything.
    context.tokens = std::make_shared<const api::Keyring>(
        std::vector<api::NamedToken>{{"read", api::Scope::read, api::hash_token(kReadToken)},
                                     {"operator", api::Scope::admin, api::hash_token(kOperatorToken)}});
    router = std::make_unique<api::Router>(context);
  }
  Service(const Service&) = delete;
  Service& operator=(const Service&) = delete;
  ~Service() {
    router.reset();
    store.reset();
    std::error_code ignored;
    std::filesystem::remove_all(dir, ignored);
  }
};

// What the requests store stays between inputs, as on a running server, but only for so many:
// a store holding every session and fit of millions of inputs made each list a long one, and
// the run slowed from 2,900 to 500 executions/s over 4 million.
constexpr int kInputsAStore = 1000;

std::optional<Service>& current_service() {
  static std::optional<Service> instance;
  return instance;
}

Service& service() {
  auto& instance = current_service();
  if (!instance) instance.emplace();
  return *instance;
}

void renew_service_now_and_then() {
  static int inputs = 0;
  if (++inputs % kInputsAStore == 0) current_service().reset();
}

void check_error_body(const api::Response& response) {
  if (response.status < 400) return;
  require(response.content_type == "application/json", "an error is JSON");
  const json body = json::parse(response.body, nullptr, false);
  require(body.is_object() && body.contains("error") && body["error"].is_object(), "an error has the error object");
  const json& error = body["error"];
  require(error.contains("code") && error["code"].is_string() && !error["code"].get<std::string>().empty(),
          "an error has a code");
  require(error.contains("message") && error["message"].is_string(), "an error has a message");
}

// The reply as written reads back as the same response; a HEAD's has no body.
void check_reply(const detail::Reply& reply, bool head) {
  require(reply.result_int() >= 100 && reply.result_int() <= 599, "a status of three digits");
  require(!head || reply.body().empty(), "no body for a HEAD");
  std::ostringstream written;
  written << reply;
  const std::string bytes = written.str();
  http::response_parser<http::string_body> parser;
  parser.eager(true);
  parser.skip(head);
  boost::beast::error_code ec;
  const std::size_t used = parser.put(boost::asio::buffer(bytes), ec);
  if (ec == http::error::need_more && !head && !reply.has_content_length() && !reply.chunked()) {
    // A body that ends with the connection (a HEAD answered for a stream has none).
    parser.put_eof(ec);
  }
  require(!ec, "a reply parses");
  require(parser.is_done(), "a reply is complete");
  require(used == bytes.size() || head, "a reply has nothing after its end");
  require(parser.get().result_int() == reply.result_int(), "a reply reads back with its status");
  require(head || parser.get().body() == reply.body(), "a reply reads back with its body");
}

// Answers a request that could not be read, as the server does before closing.
void answer_failure(const api::ApiError& error) {
  const api::Response response = api::error_response(error);
  check_error_body(response);
  require(response.status == 400 || response.status == 413, "a request that cannot be read is a 400 or a 413");
  check_reply(detail::error_reply(error, 11, false), false);
}

// Feeds the parser from `rest` until `done()`. False when the bytes end first: the client is
// gone and nothing is answered. A parse error is left in `ec`.
template <typename Done>
bool feed(detail::RequestParser& parser, std::string_view& rest, boost::beast::error_code& ec, Done done) {
  while (!done()) {
    const std::size_t used = parser.put(boost::asio::buffer(rest.data(), rest.size()), ec);
    rest.remove_prefix(used);
    if (ec == http::error::need_more || (!ec && used == 0)) return false;
    if (ec) return true;
  }
  return true;
}

// One request off the front of `rest` and its answer; false when the connection ends.
bool exchange(std::string_view& rest) {
  detail::RequestParser parser;
  detail::prepare_parser(parser, kLimits);
  boost::beast::error_code ec;
  if (!feed(parser, rest, ec, [&] { return parser.is_header_done(); })) return false;
  if (ec) return answer_failure(detail::read_failure(ec, kLimits)), false;
  if (const auto refused = detail::check_framing(parser.get())) {
    require(refused->code == "invalid_framing", "framing refusals say so");
    return answer_failure(*refused), false;
  }
  parser.eager(true);
  if (!feed(parser, rest, ec, [&] { return parser.is_done(); })) return false;
  if (ec) return answer_failure(detail::read_failure(ec, kLimits)), false;

  const detail::RequestMessage message = parser.release();
  const api::Request request = detail::to_request(message);
  const bool head = detail::is_head(message);
  require(!head || request.method == "GET", "a HEAD reaches the router as a GET");
  const bool heavy = api::Router::is_heavy(request.method, request.target);
  const api::Response response = service().router->handle(request);
  check_error_body(response);
  if (heavy) {
    require(response.status != 405, "a heavy route has its method");
    require(response.status != 404 || response.body.find("no route") == std::string::npos, "a heavy route exists");
  }
  if (response.events && !head) {
    // A stream ends the connection after it; its header is all there is to check here.
    response.events->close();
    const detail::Reply header = detail::stream_header(response, message.version());
    require(header.chunked() && !header.keep_alive(), "a stream is chunked and ends the connection");
    return false;
  }
  const detail::Reply reply = detail::to_reply(response, message, message.keep_alive());
  check_reply(reply, head);
  return reply.keep_alive();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  renew_service_now_and_then();
  std::string_view rest(reinterpret_cast<const char*>(data), size);
  while (!rest.empty() && exchange(rest)) {
  }
  return 0;
}
