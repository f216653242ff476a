// The router called directly, without sockets: every route, the error shape and statuses,
// strict input checks, access control, and the OpenAPI document against the route table.

#include <gtest/gtest.h>

#include <charconv>
#include <cstring>
#include <map>
#include <set>

#include "fit_json.hpp"
#include "http_caching.hpp"
#include "fitter_loader.hpp"
#include "skinspec/records/fit_record.hpp"
#include "skinspec/api/render_cache.hpp"
#include "skinspec/api/router.hpp"
#include "skinspec/records/cgats.hpp"
#include "skinspec/spectral/colour.hpp"
#include "skinspec/spectral/skin_tone.hpp"
#include "skinspec/store/store.hpp"
#include "skinspec/version.hpp"
#include "support/png_reader.hpp"
#include "skinspec/testkit/store_samples.hpp"

namespace skinspec::api {
namespace {

using nlohmann::json;

const Fitter& shared_fitter() {
  static const Fitter fitter = [] {
    auto loaded = load_fitter(SKINSPEC_TEST_DATA_DIR);
    if (!loaded) throw std::runtime_error(loaded.error());
    return std::move(*loaded);
  }();
  return fitter;
}

std::vector<double> grid() {
  std::vector<double> wl;
  for (int w = 380; w <= 780; w += 4) wl.push_back(w);
  return wl;
}
std::vector<double> skin_like(const std::vector<double>& wl) {
  std::vector<double> r;
  for (double w : wl) r.push_back(0.25 + 0.0006 * (w - 380));
  return r;
}

Request req(std::string method, std::string target, std::string body = "", bool json_type = true) {
  Request r{std::move(method), std::move(target), {}, std::move(body)};
  if (json_type && !r.body.empty()) r.headers["content-type"] = "application/json";
  return r;
}

class ApiRouterTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto opened = store::Store::open(dir_.file("api.db"));
    ASSERT_TRUE(opened) << opened.error().message;
    db_.emplace(std::move(*opened));
    RouterContext context;
    context.store = &*db_;
    context.fitter = &shared_fitter();
    router_ = std::make_unique<Router>(context);
  }
  Response call(std::string method, std::string target, std::string body = "", bool json_type = true) {
    return router_->handle(req(std::move(method), std::move(target), std::move(body), json_type));
  }
  static json body(const Response& r) { return json::parse(r.body); }
  // What a render's X-Render-Cache header says: hit or miss.
  static std::string render_cache(const Response& r) {
    for (const auto& [name, value] : r.headers)
      if (name == "X-Render-Cache") return value;
    return "none";
  }
  static void expect_error(const Response& r, int status, const std::string& code) {
    EXPECT_EQ(r.status, status) << r.body;
    const json b = json::parse(r.body, nullptr, false);
    ASSERT_TRUE(b.is_object()) << r.body;
    ASSERT_TRUE(b.contains("error")) << r.body;
    EXPECT_EQ(b["error"]["code"], code) << r.body;
    EXPECT_TRUE(b["error"]["message"].is_string());
    EXPECT_EQ(r.content_type, "application/json");
  }
  store::Id add_measurement(store::Id session) {
    auto m = testing::sample_measurement(session, 1);
    m.reflectance = {grid(), skin_like(grid())};
    auto recorded = db_->record_measurement(m, std::nullopt);
    EXPECT_TRUE(recorded) << recorded.error().message;
    return recorded->measurement_id;
  }

  testing::ScratchDirectory dir_;
  std::optional<store::Store> db_;
  std::unique_ptr<Router> router_;
};

TEST(ApiErrors, EveryKindHasOneStatus) {
  const std::pair<ErrorKind, int> expected[] = {{ErrorKind::bad_request, 400},
                                                {ErrorKind::unauthorized, 401},
                                                {ErrorKind::forbidden, 403},
                                                {ErrorKind::not_found, 404},
                                                {ErrorKind::method_not_allowed, 405},
                                                {ErrorKind::conflict, 409},
                                                {ErrorKind::payload_too_large, 413},
                                                {ErrorKind::unsupported_media_type, 415},
                                                {ErrorKind::unprocessable, 422},
                                                {ErrorKind::unavailable, 503},
                                                {ErrorKind::timeout, 504},
                                                {ErrorKind::internal, 500}};
  for (const auto& [kind, status] : expected) {
    EXPECT_EQ(http_status(kind), status);
    const json b = json::parse(error_body({kind, "", "m"}));
    EXPECT_EQ(b["error"]["code"], std::string(default_code(kind)));
    EXPECT_EQ(error_response({kind, "x", "m"}).status, status);
  }
}

// What the client did wrong is a 4xx; a database that is unavailable for now a 503; one that
// is broken a 500. The store's message is passed on.
TEST(ApiErrors, EveryStoreErrorKindHasOneStatusAndCode) {
  using K = store::StoreError::Kind;
  const std::map<K, std::pair<int, std::string>> expected = {{K::invalid_argument, {422, "invalid_value"}},
                                                             {K::not_found, {404, "not_found"}},
                                                             {K::conflict, {409, "conflict"}},
                                                             {K::busy, {503, "database_busy"}},
                                                             {K::full, {507, "storage_full"}},
                                                             {K::read_only, {503, "database_read_only"}},
                                                             {K::io, {500, "database_io"}},
                                                             {K::corrupt, {500, "database_corrupt"}},
                                                             {K::newer_schema, {500, "database_schema"}},
                                                             {K::older_schema, {500, "database_schema"}},
                                                             {K::internal, {500, "database_error"}},
                                                             {K::unreachable, {503, "database_unreachable"}},
                                                             {K::access_denied, {500, "database_access_denied"}}};
  for (int k = 0; k <= static_cast<int>(K::access_denied); ++k) {
    const auto kind = static_cast<K>(k);
    const auto it = expected.find(kind);
    ASSERT_NE(it, expected.end()) << store::to_string(kind);
    const ApiError error = from_store_error({kind, "what the store said", 0});
    EXPECT_EQ(http_status(error.kind), it->second.first) << store::to_string(kind);
    EXPECT_EQ(error.code, it->second.second) << store::to_string(kind);
    EXPECT_EQ(error.message, "what the store said");
  }
}

TEST_F(ApiRouterTest, HealthzReportsDatabaseAndVersion) {
  const auto r = call("GET", "/healthz");
  ASSERT_EQ(r.status, 200);
  EXPECT_EQ(body(r)["status"], "ok");
  EXPECT_EQ(body(r)["version"], std::string(kVersion));
  EXPECT_EQ(body(r)["database"]["state"], "open");
}

TEST_F(ApiRouterTest, UnknownRoutesAndMethods) {
  expect_error(call("GET", "/nope"), 404, "not_found");
  expect_error(call("GET", "/api/v1/sessions/abc"), 404, "not_found");
  expect_error(call("GET", "/api/v1/sessions/0"), 404, "not_found");
  expect_error(call("GET", "/api/v1/sessions/"), 404, "not_found");
  const auto r = call("DELETE", "/api/v1/sessions/1");
  expect_error(r, 405, "method_not_allowed");
  ASSERT_EQ(r.headers.size(), 1u);
  EXPECT_EQ(r.headers[0].first, "Allow");
  EXPECT_EQ(r.headers[0].second, "GET, PATCH");
  expect_error(call("PUT", "/api/v1/fit", "{}"), 405, "method_not_allowed");
}

TEST_F(ApiRouterTest, PathTraversalAndBadPathsAreRefused) {
  expect_error(call("GET", "/api/v1/../../etc/passwd"), 400, "invalid_path");
  expect_error(call("GET", "/api/v1/%2e%2e/x"), 400, "invalid_path");
  expect_error(call("GET", "/api/v1/%2E%2E%2Fetc"), 400, "invalid_path");
  expect_error(call("GET", "/api/v1/fits/%zz"), 400, "invalid_path");
  expect_error(call("GET", "/api/v1/fits/\xff\xfe"), 400, "invalid_path");
  expect_error(call("GET", "/api/v1/fits/%00"), 400, "invalid_path");
  expect_error(call("GET", "relative"), 400, "invalid_path");
  expect_error(call("GET", "/api/v1/sessions?site=%ff"), 400, "invalid_query");
}

TEST_F(ApiRouterTest, FitReturnsTheFieldsOfTheCommandLine) {
  const auto wl = grid();
  const auto refl = skin_like(wl);
  const auto r =
      call("POST", "/api/v1/fit", json{{"wavelength_nm", wl}, {"reflectance", refl}, {"site", "forearm"}}.dump());
  ASSERT_EQ(r.status, 200) << r.body;
  FitOptions options;
  options.model = kDefaultModel;
  auto direct = shared_fitter().fit(*Spectrum::create(wl, refl), options);
  ASSERT_TRUE(direct);
  EXPECT_EQ(body(r), json::parse(fit_to_json("spectrum", *direct).dump()));

  const auto several =
      call("POST", "/api/v1/fit", json{{"wavelength_nm", wl}, {"spectra", {{"a", refl}, {"b", refl}}}}.dump());
  ASSERT_EQ(several.status, 200) << several.body;
  ASSERT_EQ(body(several)["fits"].size(), 2u);
  EXPECT_EQ(body(several)["fits"][1]["name"], "b");
  EXPECT_EQ(body(several)["fits"][1]["params"], body(r)["params"]);
}

TEST_F(ApiRouterTest, FitRefusesBadInput) {
  const auto wl = grid();
  const json good = {{"wavelength_nm", wl}, {"reflectance", skin_like(wl)}};
  auto with = [&](const char* key, json value) {
    json b = good;
    b[key] = std::move(value);
    return b.dump();
  };
  expect_error(call("POST", "/api/v1/fit", "{\"wavelength_nm\": [1,2"), 400, "malformed_json");
  expect_error(call("POST", "/api/v1/fit", "{\"site\": \"\xc3\x28\"}"), 400, "invalid_utf8");
  expect_error(call("POST", "/api/v1/fit", "[1,2]"), 422, "wrong_type");
  expect_error(call("POST", "/api/v1/fit", good.dump(), false), 415, "unsupported_media_type");
  Request text = req("POST", "/api/v1/fit", good.dump());
  text.headers["content-type"] = "text/plain";
  expect_error(router_->handle(text), 415, "unsupported_media_type");
  expect_error(call("POST", "/api/v1/fit", json{{"reflectance", skin_like(wl)}}.dump()), 422, "missing_field");
  expect_error(call("POST", "/api/v1/fit", json{{"wavelength_nm", wl}}.dump()), 422, "missing_field");
  expect_error(call("POST", "/api/v1/fit", with("wavelength_nm", "400")), 422, "wrong_type");
  expect_error(call("POST", "/api/v1/fit", with("reflectance", json::array({"a", "b"}))), 422, "wrong_type");
  expect_error(call("POST", "/api/v1/fit", with("site", 3)), 422, "wrong_type");
  expect_error(call("POST", "/api/v1/fit", with("site", "elbow")), 422, "unknown_site");
  expect_error(call("POST", "/api/v1/fit", with("extra", 1)), 422, "unknown_field");
  expect_error(call("POST", "/api/v1/fit", with("reflectance", json::array({0.1, 0.2}))), 422, "unequal_lengths");
  // Huge numbers: out of range when a double holds them, malformed when it cannot; NaN is not JSON.
  std::string huge = good.dump();
  huge.replace(huge.find("0.25"), 4, "1e300");
  expect_error(call("POST", "/api/v1/fit", huge), 422, "out_of_range");
  huge.replace(huge.find("1e300"), 5, "1e999");
  expect_error(call("POST", "/api/v1/fit", huge), 400, "malformed_json");
  std::string nan = good.dump();
  nan.replace(nan.find("0.25"), 4, "NaN");
  expect_error(call("POST", "/api/v1/fit", nan), 400, "malformed_json");
  auto decreasing = wl;
  std::reverse(decreasing.begin(), decreasing.end());
  expect_error(call("POST", "/api/v1/fit", with("wavelength_nm", decreasing)), 422, "invalid_spectrum");
  expect_error(call("POST", "/api/v1/fit", with("spectra", json::object({{"a", skin_like(wl)}}))), 422,
               "missing_field");
}

TEST_F(ApiRouterTest, WhiteStandards) {
  const json ws = {
      {"name", "Spectralon 99"}, {"certificate", "C-1"}, {"wavelength_nm", {380, 780}}, {"reflectance", {0.99, 0.99}}};
  const auto created = call("POST", "/api/v1/white-standards", ws.dump());
  ASSERT_EQ(created.status, 201) << created.body;
  const auto id = body(created)["id"].get<std::int64_t>();
  const auto one = call("GET", "/api/v1/white-standards/" + std::to_string(id));
  ASSERT_EQ(one.status, 200);
  EXPECT_EQ(body(one)["name"], "Spectralon 99");
  EXPECT_EQ(body(call("GET", "/api/v1/white-standards"))["white_standards"].size(), 1u);
  expect_error(call("GET", "/api/v1/white-standards/999"), 404, "not_found");
  expect_error(call("POST", "/api/v1/white-standards", json{{"name", "x"}}.dump()), 422, "missing_field");
  json bad = ws;
  bad["reflectance"] = {0.99, 7};
  expect_error(call("POST", "/api/v1/white-standards", bad.dump()), 422, "out_of_range");
}

TEST_F(ApiRouterTest, SessionsCreateListPaginateFilterAndClose) {
  for (int i = 0; i < 5; ++i) {
    const json s = {{"site", i % 2 ? "cheek" : "forearm"}, {"subject", "S" + std::to_string(i)}, {"operator", "op"}};
    ASSERT_EQ(call("POST", "/api/v1/sessions", s.dump()).status, 201);
  }
  expect_error(call("POST", "/api/v1/sessions", json{{"site", "forearm"}}.dump()), 422, "missing_field");
  expect_error(call("POST", "/api/v1/sessions", json{{"site", "elbow"}, {"subject", "x"}}.dump()), 422, "unknown_site");
  expect_error(
      call("POST", "/api/v1/sessions", json{{"site", "forearm"}, {"subject", "x"}, {"white_standard_id", 42}}.dump()),
      422, "unknown_white_standard");

  auto page = body(call("GET", "/api/v1/sessions?limit=2"));
  ASSERT_EQ(page["sessions"].size(), 2u);
  EXPECT_EQ(page["sessions"][0]["subject"], "S4");
  std::set<std::string> seen;
  for (int pages = 0; pages < 10; ++pages) {
    for (const auto& s : page["sessions"]) seen.insert(s["subject"].get<std::string>());
    if (page["next_cursor"].is_null()) break;
    page =
        body(call("GET", "/api/v1/sessions?limit=2&cursor=" + std::to_string(page["next_cursor"].get<std::int64_t>())));
  }
  EXPECT_EQ(seen.size(), 5u);
  EXPECT_EQ(body(call("GET", "/api/v1/sessions?site=cheek"))["sessions"].size(), 2u);
  EXPECT_EQ(body(call("GET", "/api/v1/sessions?from=2000-01-01T00:00:00Z&to=2999-01-01T00:00:00Z"))["sessions"].size(),
            5u);
  EXPECT_EQ(body(call("GET", "/api/v1/sessions?to=2000-01-01T00:00:00Z"))["sessions"].size(), 0u);
  expect_error(call("GET", "/api/v1/sessions?state=sleeping"), 400, "invalid_parameter");
  expect_error(call("GET", "/api/v1/sessions?from=yesterday"), 400, "invalid_parameter");
  expect_error(call("GET", "/api/v1/sessions?limit=0"), 400, "invalid_parameter");
  expect_error(call("GET", "/api/v1/sessions?colour=red"), 400, "unknown_parameter");

  const auto patched = call("PATCH", "/api/v1/sessions/1", json{{"notes", "dry skin"}, {"close", true}}.dump());
  ASSERT_EQ(patched.status, 200) << patched.body;
  EXPECT_EQ(body(patched)["state"], "complete");
  EXPECT_EQ(body(patched)["notes"], "dry skin");
  EXPECT_EQ(body(call("GET", "/api/v1/sessions?state=complete"))["sessions"].size(), 1u);
  expect_error(call("PATCH", "/api/v1/sessions/1", json{{"state", "open"}}.dump()), 409, "conflict");
  expect_error(call("PATCH", "/api/v1/sessions/2", json::object().dump()), 422, "missing_field");
  expect_error(call("PATCH", "/api/v1/sessions/99", json{{"notes", "x"}}.dump()), 404, "not_found");
}

TEST_F(ApiRouterTest, MeasurementsFitsRefitAndExport) {
  ASSERT_EQ(call("POST", "/api/v1/sessions", json{{"site", "forearm"}, {"subject", "S"}}.dump()).status, 201);
  const store::Id m = add_measurement(1);
  const auto got = call("GET", "/api/v1/measurements/" + std::to_string(m));
  ASSERT_EQ(got.status, 200) << got.body;
  EXPECT_TRUE(body(got)["fit_id"].is_null());
  EXPECT_EQ(body(got)["reflectance"]["values"].size(), grid().size());
  EXPECT_TRUE(
      body(got)["provenance"]["raw_reply_base64"].get<std::string>().starts_with("MDAwMCwwDQo"));  // "0000,0\r\n"

  const auto refit = call("POST", "/api/v1/measurements/" + std::to_string(m) + "/fit", json{{"site", "cheek"}}.dump());
  ASSERT_EQ(refit.status, 201) << refit.body;
  EXPECT_EQ(body(refit)["site"], "cheek");
  const auto fit_id = body(refit)["id"].get<std::int64_t>();
  const auto stored = call("GET", "/api/v1/fits/" + std::to_string(fit_id));
  ASSERT_EQ(stored.status, 200);
  auto direct = shared_fitter().fit(
      *Spectrum::create(grid(), skin_like(grid())),
      FitOptions{
          .model = kDefaultModel, .site = "cheek", .lateral_diffusion = true, .weights = {}, .held = {}, .start = {}});
  ASSERT_TRUE(direct);
  const json cli = json::parse(fit_to_json("x", *direct).dump());
  // The stored fit is the fit as the command line gives it, its judgement of what the spectrum
  // determined included.
  for (const auto& item : cli.items()) {
    if (item.key() != "name") {
      EXPECT_EQ(body(stored)[item.key()], item.value()) << item.key();
    }
  }
  EXPECT_EQ(body(stored)["model"], "extended");
  EXPECT_EQ(body(stored)["constants_digest"], shared_fitter().optics(ModelKind::extended).constants_digest());
  EXPECT_EQ(body(call("GET", "/api/v1/measurements/" + std::to_string(m)))["fit_id"], fit_id);
  // With no body the session's site is used.
  const auto again = router_->handle(Request{"POST", "/api/v1/measurements/" + std::to_string(m) + "/fit", {}, ""});
  ASSERT_EQ(again.status, 201) << again.body;
  EXPECT_EQ(body(again)["site"], "forearm");

  const auto detail = body(call("GET", "/api/v1/sessions/1"));
  EXPECT_EQ(detail["measurements"].size(), 1u);
  EXPECT_EQ(detail["fits"].size(), 2u);
  const auto csv = call("GET", "/api/v1/sessions/1/export.csv");
  ASSERT_EQ(csv.status, 200);
  EXPECT_EQ(csv.content_type.rfind("text/csv", 0), 0u);
  // The units' comment line first, then the header.
  EXPECT_EQ(csv.body.rfind("# units,", 0), 0u);
  EXPECT_EQ(csv.body.find("\nsession_id,"), csv.body.find('\n'));
  EXPECT_GT(std::count(csv.body.begin(), csv.body.end(), '\n'), 100);
  expect_error(call("GET", "/api/v1/sessions/7/export.csv"), 404, "not_found");
  const auto cgats = call("GET", "/api/v1/sessions/1/export.cgats");
  ASSERT_EQ(cgats.status, 200);
  EXPECT_EQ(cgats.content_type.rfind("text/plain", 0), 0u);
  const auto spectra = records::parse_cgats(cgats.body);
  ASSERT_TRUE(spectra) << spectra.error().message;
  ASSERT_EQ(spectra->size(), 1u);
  EXPECT_EQ((*spectra)[0].sample_id, std::to_string(m));
  EXPECT_EQ((*spectra)[0].reflectance.size(),
            body(call("GET", "/api/v1/measurements/" + std::to_string(m)))["reflectance"]["values"].size());
  expect_error(call("GET", "/api/v1/sessions/7/export.cgats"), 404, "not_found");
  // The whole session in one request, spectra included, however it is asked for.
  EXPECT_EQ(body(call("GET", "/api/v1/sessions/1?include=spectra")), detail);
  expect_error(call("GET", "/api/v1/sessions/1?include=thumbnails"), 400, "invalid_parameter");
  expect_error(call("GET", "/api/v1/sessions/1?fields=all"), 400, "unknown_parameter");
  expect_error(call("GET", "/api/v1/measurements/77"), 404, "not_found");
  expect_error(call("GET", "/api/v1/fits/77"), 404, "not_found");
  expect_error(call("POST", "/api/v1/measurements/77/fit", "{}"), 404, "not_found");
}

TEST_F(ApiRouterTest, RendersAFitAsPngCachedByItsParameters) {
  ASSERT_EQ(call("POST", "/api/v1/sessions", json{{"site", "forearm"}, {"subject", "S"}}.dump()).status, 201);
  const store::Id m = add_measurement(1);
  const auto refit = call("POST", "/api/v1/measurements/" + std::to_string(m) + "/fit", "{}");
  ASSERT_EQ(refit.status, 201) << refit.body;
  const std::string base = "/api/v1/fits/" + std::to_string(body(refit)["id"].get<std::int64_t>()) + "/render.png";

  const auto first = call("GET", base + "?size=64x48&illuminant=A&scale_melanin=2");
  ASSERT_EQ(first.status, 200) << first.body;
  EXPECT_EQ(first.content_type, "image/png");
  EXPECT_EQ(render_cache(first), "miss");
  const auto png = testing::decode_png(first.body);
  ASSERT_TRUE(png.has_value());
  EXPECT_EQ(png->width, 64);
  EXPECT_EQ(png->height, 48);
  // The same parameters in another order: the cached bytes.
  const auto again = call("GET", base + "?scale_melanin=2&illuminant=A&size=64x48");
  EXPECT_EQ(render_cache(again), "hit");
  EXPECT_EQ(again.body, first.body);
  // Tagged immutable, never gzipped; a client holding it gets 304.
  std::string etag;
  for (const auto& [name, value] : first.headers) {
    if (name == "ETag") etag = value;
    if (name == "Cache-Control") {
      EXPECT_EQ(value, "public, max-age=31536000, immutable");
    }
    EXPECT_NE(name, "Content-Encoding");
  }
  ASSERT_FALSE(etag.empty());
  auto conditional = req("GET", base + "?size=64x48&illuminant=A&scale_melanin=2");
  conditional.headers["if-none-match"] = etag;
  conditional.headers["accept-encoding"] = "gzip";
  EXPECT_EQ(router_->handle(conditional).status, 304);
  conditional.headers.erase("if-none-match");
  EXPECT_EQ(router_->handle(conditional).body, first.body) << "a PNG is not compressed again";
  const auto darker = call("GET", base + "?size=64x48&illuminant=A&scale_melanin=4");
  EXPECT_EQ(render_cache(darker), "miss");
  EXPECT_NE(darker.body, first.body);
  const auto defaults = testing::decode_png(call("GET", base).body);
  ASSERT_TRUE(defaults.has_value());
  EXPECT_EQ(defaults->width, 256);

  for (const char* query : {"size=0x5", "size=5000x5000", "size=64", "illuminant=F2", "scale_melanin=-1",
                            "scale_bilirubin=nan", "scale_total_hemoglobin=abc", "scale_bilirubin=101"})
    expect_error(call("GET", base + "?" + query), 400, "invalid_parameter");
  expect_error(call("GET", base + "?colour=red"), 400, "unknown_parameter");
  expect_error(call("GET", "/api/v1/fits/77/render.png"), 404, "not_found");
}

// A render changes a fit's own parameters: an extended fit's by their names (a saturation set,
// an amount scaled), a paper fit's by the paper's; what the fit's model does not have, or a value
// outside its domain, is a 400 with the error's JSON.
TEST_F(ApiRouterTest, RendersAFitWithItsOwnModelsParametersChanged) {
  const auto fit_of = [&](const char* model) {
    const auto session =
        call("POST", "/api/v1/sessions", json{{"site", "forearm"}, {"subject", "S"}, {"model", model}}.dump());
    EXPECT_EQ(session.status, 201) << session.body;
    const store::Id m = add_measurement(body(session)["id"].get<store::Id>());
    const auto fit = call("POST", "/api/v1/measurements/" + std::to_string(m) + "/fit", "");
    EXPECT_EQ(fit.status, 201) << fit.body;
    return body(fit);
  };
  const json extended = fit_of("extended");
  ASSERT_EQ(extended["model"], "extended");
  const std::string base = "/api/v1/fits/" + std::to_string(extended["id"].get<store::Id>()) + "/render.png?size=24x24";
  const auto own = call("GET", base);
  ASSERT_EQ(own.status, 200) << own.body;
  EXPECT_EQ(render_cache(own), "miss");
  // Changing nothing, whichever way it is said, is the fit's own image.
  char saturation[32];
  const auto written =
      std::to_chars(saturation, std::end(saturation), extended["params"]["oxygen_saturation"].get<double>());
  for (const std::string& same :
       {std::string("&scale_melanin=1"), "&oxygen_saturation=" + std::string(saturation, written.ptr)}) {
    const auto r = call("GET", base + same);
    EXPECT_EQ(render_cache(r), "hit") << same;
    EXPECT_EQ(r.body, own.body) << same;
  }
  for (const char* query : {"&oxygen_saturation=0", "&oxygen_saturation=1", "&scale_total_hemoglobin=3",
                            "&total_hemoglobin=20&oxygen_saturation=0.4", "&scale_bilirubin=0&dermis_scattering=60",
                            "&surface_reflectance=0.1&dermis_scattering_power=2"}) {
    const auto r = call("GET", base + query);
    ASSERT_EQ(r.status, 200) << query << ": " << r.body;
    EXPECT_NE(r.body, own.body) << query;
  }
  EXPECT_NE(call("GET", base + "&oxygen_saturation=0").body, call("GET", base + "&oxygen_saturation=1").body);
  // The paper's haemoglobins are not the extended model's: the message names the model's own.
  for (const char* query :
       {"&scale_oxyhemoglobin=2", "&scale_deoxyhemoglobin=1", "&oxyhemoglobin=3", "&saturation=0.5"}) {
    const auto r = call("GET", base + query);
    expect_error(r, 400, "unknown_parameter");
    EXPECT_NE(body(r)["error"]["message"].get<std::string>().find("total_hemoglobin"), std::string::npos) << r.body;
  }
  for (const char* query : {"&oxygen_saturation=1.5", "&oxygen_saturation=-0.1", "&oxygen_saturation=abc",
                            "&scale_oxygen_saturation=2", "&scale_surface_reflectance=1", "&melanin=5&scale_melanin=2",
                            "&scale_total_hemoglobin=101", "&dermis_scattering=0", "&melanin=1e5", "&melanin=inf"})
    expect_error(call("GET", base + query), 400, "invalid_parameter");

  const json paper = fit_of("paper");
  ASSERT_EQ(paper["model"], "paper");
  const std::string paper_base =
      "/api/v1/fits/" + std::to_string(paper["id"].get<store::Id>()) + "/render.png?size=24x24";
  const auto paper_own = call("GET", paper_base);
  ASSERT_EQ(paper_own.status, 200) << paper_own.body;
  const auto scaled = call("GET", paper_base + "&scale_oxyhemoglobin=2&scale_deoxyhemoglobin=0.5&deoxyhemoglobin=0");
  expect_error(scaled, 400, "invalid_parameter");  // deoxy-haemoglobin twice
  const auto paper_changed = call("GET", paper_base + "&scale_oxyhemoglobin=2&scale_deoxyhemoglobin=0.5");
  ASSERT_EQ(paper_changed.status, 200) << paper_changed.body;
  const auto whiter = call("GET", paper_base + "&surface_reflectance=0.5");
  ASSERT_EQ(whiter.status, 200) << whiter.body;
  EXPECT_NE(whiter.body, paper_own.body);
  for (const char* query : {"&scale_total_hemoglobin=2", "&oxygen_saturation=0.5", "&dermis_scattering=30"})
    expect_error(call("GET", paper_base + query), 400, "unknown_parameter");
  expect_error(call("GET", paper_base + "&scale_deoxyhemoglobin=101"), 400, "invalid_parameter");
}

// GET /api/v1/models is each model's ParamSpec table as it is, with a label for people, and needs
// neither a database nor the model tables.
TEST_F(ApiRouterTest, TheModelsRouteDescribesEachModelsParametersFromItsTables) {
  const auto r = call("GET", "/api/v1/models");
  ASSERT_EQ(r.status, 200) << r.body;
  const json doc = body(r);
  EXPECT_EQ(doc["default"], to_string(kDefaultModel));
  ASSERT_EQ(doc["models"].size(), kModelKinds.size());
  for (std::size_t k = 0; k < kModelKinds.size(); ++k) {
    const json& model = doc["models"][k];
    const ModelSpec& spec = model_spec(kModelKinds[k]);
    EXPECT_EQ(model["name"], to_string(kModelKinds[k]));
    ASSERT_EQ(model["params"].size(), spec.params.size());
    for (std::size_t p = 0; p < spec.params.size(); ++p) {
      const json& param = model["params"][p];
      const ParamSpec& ps = spec.params[p];
      EXPECT_EQ(param["name"], ps.name);
      EXPECT_EQ(param["unit"], ps.unit) << ps.name;
      EXPECT_FALSE(param["unit"].get<std::string>().empty()) << ps.name;
      EXPECT_EQ(param["bounds"], json::array({ps.lower, ps.upper})) << ps.name;
      EXPECT_EQ(param["default"], ps.initial) << ps.name;
      EXPECT_EQ(param["domain"], json::array({ps.domain_lower, ps.domain_upper})) << ps.name;
      EXPECT_EQ(param["absorber"], ps.absorber) << ps.name;
      EXPECT_EQ(param["source"], ps.source) << ps.name;
      // Every parameter has a label of its own, not its name again.
      EXPECT_NE(param["label"], ps.name) << ps.name;
    }
    std::vector<std::string> derived;
    for (const auto& d : model["derived"]) {
      derived.push_back(d["name"]);
      EXPECT_FALSE(d["unit"].get<std::string>().empty()) << d;
      EXPECT_NE(d["label"], d["name"]) << d;
    }
    // The quantities a fit derives, as fits give them.
    EXPECT_EQ(derived, (std::vector<std::string>{"oxygen_saturation", "blood_volume_fraction"}));
    // How well a fit matches its spectrum, as fits give it, in the units the command line prints.
    ASSERT_EQ(model["skin_tone"].size(), 4u);
    EXPECT_EQ(model["skin_tone"][0], json({{"name", "ita_deg"}, {"label", "ITA°"}, {"unit", kItaUnit}}));
    EXPECT_EQ(model["skin_tone"][1]["name"], "ita_class");
    for (const std::size_t i : {2u, 3u}) EXPECT_EQ(model["skin_tone"][i]["unit"], kSkinIndexUnit);
    ASSERT_EQ(model["fit_quality"].size(), 2u);
    EXPECT_EQ(model["fit_quality"][0]["name"], "rmse");
    EXPECT_EQ(model["fit_quality"][0]["unit"], kRmseUnit);
    EXPECT_EQ(model["fit_quality"][1]["name"], "delta_e00_d65");
    EXPECT_EQ(model["fit_quality"][1]["unit"], kDeltaE00Unit);
    for (const auto& q : model["fit_quality"]) {
      EXPECT_FALSE(q["unit"].get<std::string>().empty()) << q;
      EXPECT_NE(q["label"], q["name"]) << q;
    }
  }
  expect_error(call("GET", "/api/v1/models?model=paper"), 400, "unknown_parameter");
  const Router bare{RouterContext{}};
  EXPECT_EQ(bare.handle(req("GET", "/api/v1/models")).body, r.body);

  // The OpenAPI document's ModelList has every member a model has.
  const json openapi = body(call("GET", "/openapi.json"));
  const json& documented_model = openapi["components"]["schemas"]["ModelList"]["properties"]["models"]["items"];
  for (const auto& member : doc["models"][0].items())
    EXPECT_TRUE(documented_model["properties"].contains(member.key())) << member.key();

  // The render route's documented parameters are those of the models: each one, and a scale of
  // each amount only.
  std::set<std::string> documented;
  for (const auto& p : openapi["paths"]["/api/v1/fits/{id}/render.png"]["get"]["parameters"])
    documented.insert(p["name"].get<std::string>());
  std::set<std::string> expected = {"id", "illuminant", "size"};
  for (const ModelKind kind : kModelKinds)
    for (const ParamSpec& ps : model_spec(kind).params) {
      expected.insert(std::string(ps.name));
      if (ps.absorber) expected.insert("scale_" + std::string(ps.name));
    }
  EXPECT_EQ(documented, expected);
  EXPECT_TRUE(expected.contains("scale_total_hemoglobin"));
  EXPECT_FALSE(expected.contains("scale_oxygen_saturation"));
}

// A stored fit never changes: once served, its answer comes from the cache of answers, with no
// SQL (shown by removing the row under it), tagged immutable; a client holding it gets 304.
TEST_F(ApiRouterTest, AStoredFitIsServedOnceFromTheDatabaseThenFromItsCachedAnswer) {
  const auto session = db_->create_session(testing::sample_session(1));
  ASSERT_TRUE(session);
  const auto ids = db_->record_measurement(testing::sample_measurement(*session, 1), testing::sample_fit(1));
  ASSERT_TRUE(ids && ids->fit_id);
  const std::string path = "/api/v1/fits/" + std::to_string(*ids->fit_id);
  const auto first = call("GET", path);
  ASSERT_EQ(first.status, 200) << first.body;
  const auto header = [](const Response& r, const std::string& name) {
    for (const auto& [key, value] : r.headers)
      if (key == name) return value;
    return std::string();
  };
  const std::string etag = header(first, "ETag");
  EXPECT_EQ(etag.size(), 18u) << etag;
  EXPECT_EQ(header(first, "Cache-Control"), "public, max-age=31536000, immutable");

  testing::sqlite_execute(dir_.file("api.db"), "DELETE FROM fits WHERE id = " + std::to_string(*ids->fit_id));
  const auto again = call("GET", path);
  EXPECT_EQ(again.status, 200);
  EXPECT_EQ(again.body, first.body);

  auto conditional = req("GET", path);
  conditional.headers["if-none-match"] = "\"0000000000000000\", " + etag;
  const auto unchanged = router_->handle(conditional);
  EXPECT_EQ(unchanged.status, 304);
  EXPECT_TRUE(unchanged.body.empty());
  EXPECT_EQ(header(unchanged, "ETag"), etag);
  conditional.headers["if-none-match"] = "\"0000000000000000\"";
  EXPECT_EQ(router_->handle(conditional).status, 200);
  // Another database behind another router: its own cache.
  RouterContext other;
  other.store = &*db_;
  other.fitter = &shared_fitter();
  expect_error(Router(other).handle(req("GET", path)), 404, "not_found");
}

TEST_F(ApiRouterTest, OnlyAStoredFitServedBeforeIsAnsweredFromMemory) {
  const auto session = db_->create_session(testing::sample_session(1));
  ASSERT_TRUE(session);
  const auto ids = db_->record_measurement(testing::sample_measurement(*session, 1), testing::sample_fit(1));
  ASSERT_TRUE(ids && ids->fit_id);
  const std::string id = std::to_string(*ids->fit_id);
  const std::string path = "/api/v1/fits/" + id;
  EXPECT_FALSE(router_->answer_from_memory(req("GET", path)));  // not served yet: the database has it
  const auto served = call("GET", path);
  ASSERT_EQ(served.status, 200);
  // Now held: the same answer, even with the row gone from the database.
  testing::sqlite_execute(dir_.file("api.db"), "DELETE FROM fits WHERE id = " + id);
  const auto held = router_->answer_from_memory(req("GET", path));
  ASSERT_TRUE(held);
  EXPECT_EQ(held->status, 200);
  EXPECT_EQ(held->body, served.body);
  const auto encoded =
      router_->answer_from_memory(req("GET", "/api/v1/fits/%" + std::to_string(30 + id[0] - '0') + id.substr(1)));
  ASSERT_TRUE(encoded);
  EXPECT_EQ(encoded->body, served.body);
  // A refusal needs nothing but the request.
  const auto with_query = router_->answer_from_memory(req("GET", path + "?x=1"));
  ASSERT_TRUE(with_query);
  EXPECT_EQ(with_query->status, 400);
  for (const auto& [method, target] : std::vector<std::pair<std::string, std::string>>{
           {"DELETE", path},
           {"POST", path},
           {"GET", path + "/render.png"},
           {"GET", "/api/v1/fits/" + std::to_string(*ids->fit_id + 1)},
           {"GET", "/api/v1/measurements/" + std::to_string(ids->measurement_id)},
           {"GET", "/healthz"},
       })
    EXPECT_FALSE(router_->answer_from_memory(req(method, target))) << method << ' ' << target;
}

TEST(HttpCaching, TagsEncodingsAndConditions) {
  EXPECT_EQ(detail::etag_of(""), "\"cbf29ce484222325\"");
  EXPECT_TRUE(detail::etag_matches("*", "\"a\""));
  EXPECT_TRUE(detail::etag_matches("W/\"a\"", "\"a\""));
  EXPECT_TRUE(detail::etag_matches("\"b\" , \"a\"", "\"a\""));
  EXPECT_FALSE(detail::etag_matches("\"b\"", "\"a\""));
  EXPECT_FALSE(detail::etag_matches("", "\"a\""));
  EXPECT_TRUE(detail::accepts_gzip("gzip"));
  EXPECT_TRUE(detail::accepts_gzip("deflate, GZIP;q=0.5, br"));
  EXPECT_TRUE(detail::accepts_gzip("x-gzip"));
  EXPECT_FALSE(detail::accepts_gzip("gzip;q=0"));
  EXPECT_FALSE(detail::accepts_gzip("gzip; q=0.000"));
  EXPECT_FALSE(detail::accepts_gzip("deflate, br"));
  EXPECT_FALSE(detail::accepts_gzip("gzipped"));
  EXPECT_FALSE(detail::accepts_gzip(""));
}

TEST(RenderCache, DropsTheLeastRecentlyUsedBeyondItsBudget) {
  RenderCache cache(25);
  cache.put("a", std::string(10, 'a'));
  cache.put("b", std::string(10, 'b'));
  EXPECT_EQ(cache.find("a"), std::string(10, 'a'));  // a is now the most recent
  cache.put("c", std::string(10, 'c'));
  EXPECT_FALSE(cache.find("b"));
  EXPECT_TRUE(cache.find("a"));
  EXPECT_TRUE(cache.find("c"));
  cache.put("huge", std::string(26, 'h'));  // larger than the budget: not kept, nothing evicted
  EXPECT_FALSE(cache.find("huge"));
  EXPECT_EQ(cache.size(), 2u);
}

TEST_F(ApiRouterTest, OpenApiDocumentAndRouteTableAgree) {
  const auto r = call("GET", "/openapi.json");
  ASSERT_EQ(r.status, 200);
  const json doc = body(r);
  EXPECT_EQ(doc["openapi"], "3.1.0");
  std::set<std::pair<std::string, std::string>> table, documented;
  for (const auto& route : Router::routes()) {
    std::string method = route.method;
    for (char& ch : method) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    table.emplace(method, route.path);
  }
  for (const auto& path : doc["paths"].items())
    for (const auto& op : path.value().items()) {
      documented.emplace(op.key(), path.key());
      // Every referenced schema exists.
      const std::string text = op.value().dump();
      for (auto pos = text.find("#/components/schemas/"); pos != std::string::npos;
           pos = text.find("#/components/schemas/", pos + 1)) {
        const auto start = pos + std::string("#/components/schemas/").size();
        const auto name = text.substr(start, text.find('"', start) - start);
        EXPECT_TRUE(doc["components"]["schemas"].contains(name)) << name;
      }
    }
  EXPECT_EQ(table, documented);
  // The session states as the store names them, in every place that lists them.
  const json states = {"open", "complete", "interrupted", "aborted"};
  EXPECT_EQ(doc["components"]["schemas"]["Session"]["properties"]["state"]["enum"], states);
  EXPECT_EQ(doc["components"]["schemas"]["SessionUpdate"]["properties"]["state"]["enum"], states);
  // Every documented route answers something other than 404 / 405 through the router.
  for (const auto& [method, path] : documented) {
    std::string upper = method;
    for (char& ch : upper) ch = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
    std::string target = path;
    if (const auto at = target.find("{id}"); at != std::string::npos) target.replace(at, 4, "1");
    if (const auto at = target.find("{parameter}"); at != std::string::npos) target.replace(at, 11, "melanin");
    const auto answer = call(upper, target, "{}");
    EXPECT_NE(answer.status, 405) << method << ' ' << path;
    if (answer.status == 404) {
      EXPECT_NE(body(answer)["error"]["message"].get<std::string>().rfind("no route", 0), 0u) << path;
    }
  }
}

TEST_F(ApiRouterTest, MetricsCountRequestsFitsAndErrors) {
  call("GET", "/healthz");
  call("GET", "/nope");
  const auto wl = grid();
  call("POST", "/api/v1/fit", json{{"wavelength_nm", wl}, {"reflectance", skin_like(wl)}}.dump());
  const auto r = call("GET", "/metrics");
  ASSERT_EQ(r.status, 200);
  EXPECT_EQ(r.content_type.rfind("text/plain", 0), 0u);
  EXPECT_NE(r.body.find("skinspec_http_requests_total{route=\"GET /healthz\",status=\"200\"} 1"), std::string::npos)
      << r.body;
  EXPECT_NE(r.body.find("skinspec_http_errors_total{code=\"not_found\"} 1"), std::string::npos);
  EXPECT_NE(r.body.find("skinspec_fits_total{outcome=\"ok\"} 1"), std::string::npos);
  EXPECT_NE(r.body.find("skinspec_http_request_duration_seconds_count{route=\"POST /api/v1/fit\"} 1"),
            std::string::npos);
}

// As skinspecd reads an old two-token file: "read" of scope read, "operator" of scope admin.
std::shared_ptr<const Keyring> legacy_tokens() {
  return std::make_shared<const Keyring>(
      std::vector<NamedToken>{{"read", Scope::read, hash_token("read-token-0123456789")},
                              {"operator", Scope::admin, hash_token("operator-token-0123456789")}});
}

Request with_token(Request r, const std::string& token) {
  r.headers["authorization"] = "Bearer " + token;
  return r;
}

TEST_F(ApiRouterTest, TokensGuardEveryRouteButHealthz) {
  RouterContext context;
  context.store = &*db_;
  context.fitter = &shared_fitter();
  context.tokens = legacy_tokens();
  const Router guarded(context);
  EXPECT_EQ(guarded.handle(req("GET", "/healthz")).status, 200);
  const auto none = guarded.handle(req("GET", "/api/v1/sessions"));
  expect_error(none, 401, "unauthorized");
  expect_error(guarded.handle(with_token(req("GET", "/api/v1/sessions"), "wrong")), 401, "unauthorized");
  EXPECT_EQ(guarded.handle(with_token(req("GET", "/api/v1/sessions"), "read-token-0123456789")).status, 200);
  const std::string session = json{{"site", "forearm"}, {"subject", "S"}}.dump();
  expect_error(guarded.handle(with_token(req("POST", "/api/v1/sessions", session), "read-token-0123456789")), 403,
               "forbidden");
  EXPECT_EQ(guarded.handle(with_token(req("POST", "/api/v1/sessions", session), "operator-token-0123456789")).status,
            201);
}

// The scope each route needs, as docs/api.md and docs/security.md give them: every GET is
// read; the work of a bench (sessions, fits, jobs) is measure; the lab's white standards admin.
const std::map<std::string, Scope>& expected_scopes() {
  static const std::map<std::string, Scope> scopes = {
      {"POST /api/v1/fit", Scope::measure},
      {"POST /api/v1/sessions", Scope::measure},
      {"PATCH /api/v1/sessions/{id}", Scope::measure},
      {"POST /api/v1/measurements/{id}/fit", Scope::measure},
      {"POST /api/v1/sessions/{id}/measurements", Scope::measure},
      {"POST /api/v1/sessions/{id}/imports", Scope::measure},
      {"POST /api/v1/refits", Scope::measure},
      {"DELETE /api/v1/jobs/{id}", Scope::measure},
      {"POST /api/v1/maps", Scope::measure},
      {"POST /api/v1/white-standards", Scope::admin},
      {"GET /api/v1/audit", Scope::admin},
      {"GET /api/v1/audit/export.csv", Scope::admin},
      {"GET /api/v1/audit/export.jsonl", Scope::admin},
  };
  return scopes;
}

TEST(ApiRouterRoutes, EachRouteDeclaresItsScope) {
  for (const auto& r : Router::routes()) {
    const std::string route = r.method + " " + r.path;
    const auto it = expected_scopes().find(route);
    EXPECT_EQ(r.scope, it == expected_scopes().end() ? Scope::read : it->second) << route;
    if (r.method != "GET") {
      EXPECT_NE(r.scope, Scope::read) << route << ": only GETs are read";
    }
    EXPECT_EQ(r.needs_token, route != "GET /healthz") << route;
  }
}

// A request of every route with a token of every scope: 403 exactly when the token's scope is
// below the route's, naming both; the handler's own answer (200, 404, 415, 422 ...) otherwise.
TEST_F(ApiRouterTest, ATokenCallsTheRoutesOfItsScopeAndBelowOnly) {
  RouterContext context;
  context.store = &*db_;
  context.fitter = &shared_fitter();
  context.tokens =
      std::make_shared<const Keyring>(std::vector<NamedToken>{{"viewer", Scope::read, hash_token("read-secret")},
                                                              {"ana", Scope::measure, hash_token("measure-secret")},
                                                              {"lab", Scope::admin, hash_token("admin-secret")}});
  const Router guarded(context);
  const std::map<Scope, std::string> secrets = {
      {Scope::read, "read-secret"}, {Scope::measure, "measure-secret"}, {Scope::admin, "admin-secret"}};
  const std::map<Scope, std::string> names = {{Scope::read, "viewer"}, {Scope::measure, "ana"}, {Scope::admin, "lab"}};
  int refused = 0;
  for (const auto& route : Router::routes()) {
    std::string target = route.path;
    for (const auto& [from, to] : {std::pair{"{id}", "1"}, std::pair{"{parameter}", "melanin"}})
      for (std::size_t at; (at = target.find(from)) != std::string::npos;) target.replace(at, std::strlen(from), to);
    for (const Scope scope : kScopes) {
      const auto r = guarded.handle(with_token(req(route.method, target), secrets.at(scope)));
      const std::string what = route.method + " " + target + " with a token of scope " + std::string(to_string(scope));
      if (allows(scope, route.scope)) {
        EXPECT_NE(r.status, 401) << what << ": " << r.body;
        EXPECT_NE(r.status, 403) << what << ": " << r.body;
        continue;
      }
      ++refused;
      expect_error(r, 403, "forbidden");
      EXPECT_EQ(body(r)["error"]["message"], route.method + " " + route.path + " needs a token of scope " +
                                                 std::string(to_string(route.scope)) + "; '" + names.at(scope) +
                                                 "' has scope " + std::string(to_string(scope)))
          << what;
    }
  }
  // Each route above read refused to the read token, and the admin routes to the measure token
  // too.
  const auto admin_routes =
      std::ranges::count_if(expected_scopes(), [](const auto& e) { return e.second == Scope::admin; });
  EXPECT_EQ(admin_routes, 4);
  EXPECT_EQ(refused, static_cast<int>(expected_scopes().size() + admin_routes));
}

TEST_F(ApiRouterTest, TheOpenApiDocumentGivesEachOperationItsScope) {
  const json doc = body(call("GET", "/openapi.json"));
  EXPECT_EQ(doc["components"]["securitySchemes"]["bearer"]["scheme"], "bearer");
  for (const auto& r : Router::routes()) {
    std::string method = r.method;
    for (char& ch : method) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    const json& op = doc["paths"][r.path][method];
    if (!r.needs_token) {
      EXPECT_EQ(op["security"], json::array()) << r.path;
      EXPECT_FALSE(op.contains("x-skinspec-scope")) << r.path;
      continue;
    }
    EXPECT_EQ(op["x-skinspec-scope"], to_string(r.scope)) << r.method << ' ' << r.path;
    EXPECT_EQ(op["security"], json::parse(R"([{"bearer": []}])")) << r.method << ' ' << r.path;
  }
}

// The routes report the store's refusals through the one mapping: a read-only or full
// database is a 503, a damaged row a 500, and nothing is half stored.
TEST_F(ApiRouterTest, StoreFailuresReachTheClientAsTheirStatus) {
  ASSERT_EQ(call("POST", "/api/v1/sessions", json{{"site", "forearm"}, {"subject", "S"}}.dump()).status, 201);
  const store::Id m = add_measurement(1);
  const std::string path = dir_.file("api.db");
  const auto router_over = [](store::Store& db) {
    RouterContext context;
    context.store = &db;
    context.fitter = &shared_fitter();
    return std::make_unique<Router>(context);
  };
  const auto open = [&path](bool read_only, std::int64_t max_pages) {
    store::OpenOptions options;
    options.mode = read_only ? store::OpenMode::read_only : store::OpenMode::read_write;
    options.max_pages = max_pages;
    auto opened = store::Store::open(path, options);
    if (!opened) throw std::runtime_error(opened.error().message);
    return std::move(*opened);
  };
  {
    auto reader = open(true, 0);
    const auto router = router_over(reader);
    expect_error(router->handle(req("POST", "/api/v1/sessions", json{{"site", "forearm"}, {"subject", "T"}}.dump())),
                 503, "database_read_only");
    expect_error(router->handle(req("POST", "/api/v1/measurements/" + std::to_string(m) + "/fit", "{}")), 503,
                 "database_read_only");
    EXPECT_EQ(router->handle(req("GET", "/api/v1/sessions/1")).status, 200);
  }
  router_.reset();
  db_.reset();  // the writer lock, for the next writer
  {
    auto capped = open(false, 1);  // below the file's size: a write needing a page is refused
    const auto router = router_over(capped);
    std::vector<double> wl, values;
    for (int i = 0; i < 2000; ++i) {
      wl.push_back(300 + i * 0.25);
      values.push_back(0.9);
    }
    const json ws = {{"name", "PTFE"}, {"wavelength_nm", wl}, {"reflectance", values}};
    expect_error(router->handle(req("POST", "/api/v1/white-standards", ws.dump())), 507, "storage_full");
    EXPECT_EQ(body(router->handle(req("GET", "/api/v1/white-standards")))["white_standards"].size(), 0u);
  }
  testing::sqlite_execute(path, "UPDATE measurements SET radiance = x'0102' WHERE id = " + std::to_string(m));
  auto damaged = open(false, 0);
  expect_error(router_over(damaged)->handle(req("GET", "/api/v1/measurements/" + std::to_string(m))), 500,
               "database_corrupt");
}

TEST(ApiRouterWithoutDatabase, DataRoutesAnswer503) {
  const Router router(RouterContext{});
  const auto r = router.handle(Request{"GET", "/api/v1/sessions", {}, ""});
  EXPECT_EQ(r.status, 503);
  EXPECT_EQ(json::parse(r.body)["error"]["code"], "database_unavailable");
  EXPECT_EQ(router.handle(Request{"GET", "/healthz", {}, ""}).status, 200);
}

TEST_F(ApiRouterTest, ARepeatedKeyInABodyIsRefusedByName) {
  const auto top = call("POST", "/api/v1/sessions", R"({"site": "forearm", "subject": "A", "subject": "B"})");
  expect_error(top, 400, "duplicate_key");
  EXPECT_NE(body(top)["error"]["message"].get<std::string>().find("'subject'"), std::string::npos) << top.body;
  const auto nested =
      call("POST", "/api/v1/fit", R"({"wavelength_nm": [400, 500], "spectra": {"a": [0.1, 0.2], "a": [0.3, 0.4]}})");
  expect_error(nested, 400, "duplicate_key");
  EXPECT_NE(body(nested)["error"]["message"].get<std::string>().find("'a'"), std::string::npos) << nested.body;
  // The same key in two different objects is no repetition.
  const auto sibling =
      call("POST", "/api/v1/fit", R"({"wavelength_nm": [400, 500], "spectra": {"a": [0.1, 0.2]}, "site": "forearm"})");
  EXPECT_NE(sibling.status, 400) << sibling.body;
  const std::string long_key(5000, 'k');
  const auto long_repeat = call("POST", "/api/v1/sessions", "{\"" + long_key + "\": 1, \"" + long_key + "\": 2}");
  expect_error(long_repeat, 400, "duplicate_key");
  EXPECT_LT(long_repeat.body.size(), 400u);
  EXPECT_EQ(call("GET", "/api/v1/sessions").status, 200);
  EXPECT_EQ(body(call("GET", "/api/v1/sessions"))["sessions"].size(), 0u) << "nothing stored from a refused body";
}

TEST_F(ApiRouterTest, TheBearerSchemeIsCaseInsensitive) {
  RouterContext context;
  context.store = &*db_;
  context.tokens = legacy_tokens();
  const Router guarded(context);
  const auto with = [&](const std::string& credentials) {
    Request r = req("GET", "/api/v1/sessions");
    r.headers["authorization"] = credentials;
    return guarded.handle(r);
  };
  for (const char* scheme : {"Bearer", "bearer", "BEARER", "bEaReR"})
    EXPECT_EQ(with(std::string(scheme) + " read-token-0123456789").status, 200) << scheme;
  EXPECT_EQ(with("Bearer   read-token-0123456789").status, 200) << "several spaces";
  for (const char* refused : {"Bearerread-token-0123456789", "Basic read-token-0123456789", "Bearer ", "Bearer",
                              "bearer read-token-012345678", "Bearers read-token-0123456789"})
    expect_error(with(refused), 401, "unauthorized");
}

TEST(ApiRouterRoutes, FitsAndRendersAreTheHeavyRoutes) {
  EXPECT_TRUE(Router::is_heavy("POST", "/api/v1/fit"));
  EXPECT_TRUE(Router::is_heavy("POST", "/api/v1/measurements/12/fit"));
  EXPECT_TRUE(Router::is_heavy("GET", "/api/v1/fits/3/render.png?size=64x64"));
  EXPECT_TRUE(Router::is_heavy("GET", "/api/v1/fits/%33/render.png"));
  for (const auto& [method, target] : std::vector<std::pair<std::string, std::string>>{{"GET", "/healthz"},
                                                                                       {"GET", "/api/v1/fits/3"},
                                                                                       {"GET", "/api/v1/fit"},
                                                                                       {"GET", "/api/v1/sessions"},
                                                                                       {"GET", "/nope"},
                                                                                       {"GET", ""},
                                                                                       {"GET", "x"}})
    EXPECT_FALSE(Router::is_heavy(method, target)) << method << ' ' << target;
  std::set<std::string> heavy;
  for (const auto& r : Router::routes())
    if (r.heavy) heavy.insert(r.method + " " + r.path);
  EXPECT_EQ(heavy, (std::set<std::string>{"POST /api/v1/fit", "POST /api/v1/measurements/{id}/fit",
                                          "GET /api/v1/fits/{id}/render.png", "GET /api/v1/maps/{id}/pixel"}));
}

TEST_F(ApiRouterTest, TheWebConsoleIsServedWithoutATokenAndOutsideTheApiDocument) {
  const auto page = call("GET", "/");
  ASSERT_EQ(page.status, 200) << page.body;
  EXPECT_EQ(page.content_type, "text/html; charset=utf-8");
  EXPECT_NE(page.body.find("<script type=\"module\" src=\"/ui/app.js\">"), std::string::npos);
  for (const char* file : {"app.js", "api.js", "plot.js", "views.js"}) {
    const auto script = call("GET", std::string("/ui/") + file);
    EXPECT_EQ(script.status, 200) << file;
    EXPECT_EQ(script.content_type, "text/javascript; charset=utf-8") << file;
  }
  EXPECT_EQ(call("GET", "/ui/style.css").content_type, "text/css; charset=utf-8");
  expect_error(call("GET", "/ui/missing.js"), 404, "not_found");
  expect_error(call("GET", "/ui/../store.db"), 400, "invalid_path");
  expect_error(call("POST", "/", "{}"), 404, "not_found");
  const json doc = body(call("GET", "/openapi.json"));
  for (const auto& [path, item] : doc["paths"].items()) EXPECT_NE(path.rfind("/ui", 0), 0u) << path;
}

// A session names its model; its measurements are fitted with it unless a refit asks for
// another, and the fit says which.
TEST_F(ApiRouterTest, TheSessionsModelFitsItsMeasurements) {
  const auto created =
      call("POST", "/api/v1/sessions", json{{"site", "forearm"}, {"subject", "S"}, {"model", "paper"}}.dump());
  ASSERT_EQ(created.status, 201) << created.body;
  EXPECT_EQ(body(created)["model"], "paper");
  const store::Id m = add_measurement(1);
  const auto url = "/api/v1/measurements/" + std::to_string(m) + "/fit";
  const auto paper = call("POST", url, "");
  ASSERT_EQ(paper.status, 201) << paper.body;
  EXPECT_EQ(body(paper)["model"], "paper");
  EXPECT_EQ(body(paper)["params"].size(), 5u);
  EXPECT_EQ(body(paper)["constants_digest"], shared_fitter().optics(ModelKind::paper).constants_digest());
  const auto extended = call("POST", url, json{{"model", "extended"}}.dump());
  ASSERT_EQ(extended.status, 201) << extended.body;
  EXPECT_EQ(body(extended)["model"], "extended");
  EXPECT_TRUE(body(extended)["params"].contains("oxygen_saturation"));
  EXPECT_TRUE(body(extended)["determination"]["oxygen_saturation"].contains("determined"));
  EXPECT_NE(body(extended)["constants_digest"], body(paper)["constants_digest"]);
  // Both carry the measured spectrum's skin tone, the same whatever the model, its class one the
  // OpenAPI document lists.
  EXPECT_EQ(body(extended)["skin_tone"], body(paper)["skin_tone"]);
  const json fit_schema = body(call("GET", "/openapi.json"))["components"]["schemas"]["Fit"];
  const json& classes = fit_schema["properties"]["skin_tone"]["properties"]["ita_class"]["enum"];
  EXPECT_EQ(classes, json({"very_light", "light", "intermediate", "tan", "brown", "dark"})) << fit_schema;
  EXPECT_NE(std::ranges::find(classes, body(paper)["skin_tone"]["ita_class"]), classes.end());

  expect_error(call("POST", url, json{{"model", "textbook"}}.dump()), 422, "unknown_model");
  expect_error(call("POST", "/api/v1/sessions", json{{"site", "forearm"}, {"subject", "S"}, {"model", 3}}.dump()), 422,
               "wrong_type");
  const auto defaulted = body(call("POST", "/api/v1/sessions", json{{"site", "forearm"}, {"subject", "T"}}.dump()));
  EXPECT_EQ(defaulted["model"], to_string(kDefaultModel));

  const auto wl = grid();
  const auto fitted = call("POST", "/api/v1/fit",
                           json{{"wavelength_nm", wl}, {"reflectance", skin_like(wl)}, {"model", "paper"}}.dump());
  ASSERT_EQ(fitted.status, 200) << fitted.body;
  EXPECT_EQ(body(fitted)["model"], "paper");
  expect_error(
      call("POST", "/api/v1/fit", json{{"wavelength_nm", wl}, {"reflectance", skin_like(wl)}, {"model", ""}}.dump()),
      422, "unknown_model");
}

TEST_F(ApiRouterTest, SitesAndTheColourOfAMeasurementUnderTwoLights) {
  const json sites = body(call("GET", "/api/v1/sites"))["sites"];
  std::vector<std::string> names;
  for (const auto& s : sites) names.push_back(s["name"]);
  EXPECT_EQ(names, shared_fitter().optics(kDefaultModel).site_names());
  EXPECT_GT(sites[0]["dermis_mm"].get<double>(), sites[0]["epidermis_mm"].get<double>());

  ASSERT_EQ(call("POST", "/api/v1/sessions", json{{"site", "forearm"}, {"subject", "S"}}.dump()).status, 201);
  const store::Id m = add_measurement(1);
  const json colour = body(call("GET", "/api/v1/measurements/" + std::to_string(m)))["colour"];
  const auto& colorimetry = shared_fitter().colorimetry();
  const auto reflectance = *Spectrum::create(grid(), skin_like(grid()));
  for (const char* light : {"D65", "A"}) {
    const auto illuminant = *colorimetry.illuminant(light);
    const Lab lab = colorimetry.lab(reflectance, illuminant);
    EXPECT_NEAR(colour[light]["lab"][0].get<double>(), lab.l, 1e-9) << light;
    EXPECT_NEAR(colour[light]["lab"][2].get<double>(), lab.b, 1e-9) << light;
    const auto rgb = srgb_8bit(xyz_to_linear_srgb(colorimetry.xyz(reflectance, illuminant)));
    EXPECT_EQ(colour[light]["srgb"], json(rgb)) << light;
  }
  // Under the tungsten lamp, unadapted, skin looks warmer than in daylight.
  const auto ratio = [&](const char* light) {
    return colour[light]["srgb"][0].get<double>() / colour[light]["srgb"][2].get<double>();
  };
  EXPECT_GT(ratio("A"), ratio("D65"));
}

}  // namespace
}  // namespace skinspec::api
