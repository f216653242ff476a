#include "skinspec/api/router.hpp"

#include <algorithm>
#include <charconv>
#include <limits>
#include <sstream>

#include "fit_jobs.hpp"
#include "jobs.hpp"
#include "json_io.hpp"
#include "skinspec/api/acquisition.hpp"
#include "skinspec/fit/fitter.hpp"
#include "skinspec/records/export.hpp"
#include "skinspec/records/fit_record.hpp"
#include "skinspec/records/record_json.hpp"
#include "skinspec/spectral/colour.hpp"
#include "skinspec/spectral/utf8.hpp"
#include "skinspec/store/store.hpp"
#include "http_caching.hpp"
#include "skinspec/version.hpp"
#include "text.hpp"
#include "web.hpp"
#include "fit_json.hpp"
#include "models_route.hpp"
#include "render_route.hpp"
#include "maps_route.hpp"

namespace skinspec::api {

using detail::fail;
using detail::fail_store;
using nlohmann::json;

namespace {

// Stored fit `id`'s key in the cache of answers.
std::string fit_cache_key(store::Id id) { return "fit/" + std::to_string(id); }

// The media type of the request's body, lower case without parameters; empty when not given.
std::string media_type(const Request& request) {
  const auto it = request.headers.find("content-type");
  if (it == request.headers.end()) return {};
  std::string type = it->second.substr(0, it->second.find(';'));
  std::transform(type.begin(), type.end(), type.begin(),
                 [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
  while (!type.empty() && type.back() == ' ') type.pop_back();
  return type;
}

}  // namespace

// What a matched route's handler gets: the request, the ids from its path, its query.
struct Call {
  const Request& request;
  std::vector<store::Id> ids;
  std::vector<std::string> names;  // from {parameter} segments, in order
  std::map<std::string, std::string> query;
  // Set only for a route marked RouteInfo::from_memory, whose handler must then throw
  // NotInMemory rather than go to the database: it runs on the thread that read the request.
  bool from_memory_only = false;
  // Who made the request, by the token it carried; nobody when the service asks for no token
  // (or the route needs none). A handler that records who did something takes the name here.
  std::optional<Caller> caller;
};

// Thrown by a handler asked for an answer from memory alone that does not hold it.
struct NotInMemory {};

struct Router::Handlers {
  using Fn = Response (*)(const RouterContext&, const Call&);

  static store::Store& store_of(const RouterContext& c) {
    if (c.store == nullptr) fail(ErrorKind::unavailable, "database_unavailable", "no database is open");
    return *c.store;
  }
  static const Fitter& fitter_of(const RouterContext& c) {
    if (c.fitter == nullptr) fail(ErrorKind::unavailable, "model_unavailable", "the model tables are not loaded");
    return *c.fitter;
  }
  template <typename T>
  static T value(store::Result<T> result) {
    if (!result) fail_store(result.error());
    return std::move(*result);
  }
  static Response json_response(const json& body, int status = 200) {
    return Response{status, "application/json", detail::dump(body), {}};
  }
  static void no_query(const Call& call) {
    if (!call.query.empty())
      fail(ErrorKind::bad_request, "unknown_parameter", "unknown query parameter '" + call.query.begin()->first + "'");
  }
  // The optional "model" of a request, by name; the default model when absent.
  static ModelKind model_of(const json& body, ModelKind fallback = kDefaultModel) {
    const auto name = detail::optional_string(body, "model", 64);
    if (!name) return fallback;
    const auto model = parse_model_kind(*name);
    if (!model)
      fail(ErrorKind::unprocessable, "unknown_model", "unknown model '" + *name + "' (known: " + model_names() + ")");
    return *model;
  }
  static std::string checked_site(const RouterContext& c, const std::string& site) {
    if (auto known = fitter_of(c).optics(kDefaultModel).site(site); !known)
      fail(ErrorKind::unprocessable, "unknown_site", known.error());
    return site;
  }

  // GET /healthz
  static Response healthz(const RouterContext& c, const Call&) {
    json db = {{"state", c.store ? "open" : "unavailable"}};
    if (c.store) {
      db["path"] = c.store->path();
      db["schema_version"] = c.store->schema_version();
    }
    return json_response({{"status", "ok"},
                          {"version", kVersion},
                          {"database", db},
                          {"model", {{"loaded", c.fitter != nullptr}}},
                          {"instrument", instrument_status(c)}});
  }
  static json instrument_status(const RouterContext& c) {
    if (c.acquisition == nullptr) return {{"device", nullptr}, {"state", "none"}, {"last_error", nullptr}};
    return c.acquisition->instrument_status();
  }
  static Acquisition& acquisition_of(const RouterContext& c) {
    if (c.acquisition == nullptr)
      fail(ErrorKind::unavailable, "no_instrument", "skinspecd was started without --device");
    return *c.acquisition;
  }

  // GET /api/v1/instrument
  static Response instrument(const RouterContext& c, const Call& call) {
    no_query(call);
    return json_response(instrument_status(c));
  }
  // GET /api/v1/benches
  static Response benches(const RouterContext& c, const Call& call) {
    no_query(call);
    const store::Store& db = store_of(c);
    const auto benches = value(db.benches());
    const auto now = value(db.database_time());  // the clock the heartbeats were written by
    json list = json::array();
    for (const auto& b : benches) {
      const bool here = b.name == db.bench();
      json instrument = json::parse(b.instrument, nullptr, false);
      if (here && c.acquisition != nullptr) instrument = c.acquisition->instrument_status();
      list.push_back({{"name", b.name},
                      {"host", b.host},
                      {"pid", b.pid},
                      {"started_at", detail::format_time(b.started_at)},
                      {"heartbeat_at", detail::format_time(b.heartbeat_at)},
                      {"lease_s", std::chrono::duration<double>(b.lease).count()},
                      {"state", store::to_string(store::bench_state(b, now))},
                      {"this", here},
                      {"instrument", instrument.is_object() ? instrument : json::object()}});
    }
    return json_response({{"bench", db.bench()}, {"benches", list}});
  }
  // GET /api/v1/ports
  static Response ports(const RouterContext& c, const Call& call) {
    no_query(call);
    return json_response(acquisition_of(c).ports());
  }
  // POST /api/v1/sessions/{id}/measurements
  static Response measure(const RouterContext& c, const Call& call) {
    const MeasureRequest request = measure_request_of(detail::parse_object(call.request.body));
    const std::string key = idempotency_key(call);
    return accepted(c, acquisition_of(c).submit(call.ids[0], request, key));
  }
  // Only the types and the API's own bounds here: the acquisition holds the exposure and the
  // meter's settings to what the meter takes.
  static MeasureRequest measure_request_of(const json& body) {
    detail::only_fields(
        body, {"kind", "count", "label", "integration_ms", "averages", "sync", "extended_sensitivity", "aperture"});
    MeasureRequest request;
    const auto kind = store::parse_measurement_kind(detail::required_string(body, "kind", 16));
    if (!kind || std::ranges::find(kMeasurementJobKinds, *kind) == kMeasurementJobKinds.end())
      fail(ErrorKind::unprocessable, "invalid_value", "'kind' must be white or sample");
    request.kind = *kind;
    request.count = integer_field(body, "count", 1, 100).value_or(1);
    request.label = detail::optional_string(body, "label", 200).value_or("");
    request.integration_ms = integer_field(body, "integration_ms", 0, 3600000).value_or(0);  // an hour at most
    request.averages =
        integer_field(body, "averages", std::numeric_limits<int>::min(), std::numeric_limits<int>::max()).value_or(1);
    if (const auto it = body.find("sync"); it != body.end() && !it->is_null()) {
      const auto sync = parse_sync_request(*it);
      if (!sync)
        fail(ErrorKind::unprocessable, "invalid_value", "'sync' must be \"off\", \"auto\" or a frequency in Hz");
      request.sync = *sync;
    }
    request.extended_sensitivity = detail::optional_bool(body, "extended_sensitivity").value_or(false);
    request.aperture = detail::optional_string(body, "aperture", 64).value_or("");
    return request;
  }
  // POST /api/v1/sessions/{id}/imports?format=csv|cgats&scale=auto|fraction|percent&name=FILE, the
  // file as the body
  static Response import_spectra(const RouterContext& c, const Call& call) {
    ImportUpload upload;
    upload.session_id = call.ids[0];
    upload.source = "upload";
    std::optional<records::ImportFormat> format;
    for (const auto& [name, text] : call.query) {
      if (name == "format") {
        format = records::parse_import_format(text);
        if (!format) fail(ErrorKind::bad_request, "invalid_parameter", "'format' must be csv or cgats");
      } else if (name == "scale") {
        const auto scale = parse_scale_request(text);
        if (!scale) fail(ErrorKind::bad_request, "invalid_parameter", "'scale' must be " + scale_request_names());
        upload.scale = *scale;
      } else if (name == "name") {
        if (text.empty() || text.size() > 255 || std::ranges::any_of(text, [](unsigned char ch) { return ch < 0x20; }))
          fail(ErrorKind::bad_request, "invalid_parameter", "'name' must be 1 to 255 characters without controls");
        upload.source = text;
      } else {
        fail(ErrorKind::bad_request, "unknown_parameter", "unknown query parameter '" + name + "'");
      }
    }
    if (call.request.body.empty()) fail(ErrorKind::unprocessable, "empty_file", "the body holds no file to import");
    upload.format = format.value_or(records::recognise_import_format(call.request.body));
    upload.bytes = call.request.body;
    return accepted(c, fit_jobs_of(c).submit_import(std::move(upload), idempotency_key(call)));
  }
  // POST /api/v1/refits
  static Response refits(const RouterContext& c, const Call& call) {
    no_query(call);
    const json body = detail::parse_object(call.request.body);
    detail::only_fields(body, {"model", "session_id"});
    records::RefitRequest request;
    request.model = model_of(body);
    if (const auto it = body.find("session_id"); it != body.end()) {
      if (!it->is_number_integer() || it->get<std::int64_t>() < 1)
        fail(ErrorKind::unprocessable, "wrong_type", "'session_id' must be a positive integer");
      request.session_id = it->get<store::Id>();
    }
    return accepted(c, fit_jobs_of(c).submit_refit(request, idempotency_key(call)));
  }
  static std::string idempotency_key(const Call& call) {
    const auto it = call.request.headers.find("idempotency-key");
    if (it == call.request.headers.end()) return {};
    if (it->second.empty() || it->second.size() > 200)
      fail(ErrorKind::bad_request, "invalid_parameter", "'Idempotency-Key' must be 1 to 200 characters");
    return it->second;
  }
  // 202 with the job and its Location; 200 when an idempotency key named an earlier job.
  static Response accepted(const RouterContext& c, const std::expected<store::CreatedJob, ApiError>& created) {
    if (!created) throw detail::HandlerError{created.error()};
    Response r = json_response(job_view(c, created->job.id), created->created ? 202 : 200);
    r.headers.emplace_back("Location", "/api/v1/jobs/" + std::to_string(created->job.id));
    return r;
  }
  static FitJobs& fit_jobs_of(const RouterContext& c) {
    store_of(c);
    fitter_of(c);
    return *c.fit_jobs;  // made by the router whenever there are a store and a fitter
  }
  // What runs a job of this kind, and so knows its live progress (null: nothing here does).
  static const JobWatch* watch_of(const RouterContext& c, const store::Job& job) {
    if (parse_job_kind(job.kind) == JobKind::measure) return c.acquisition ? &c.acquisition->jobs() : nullptr;
    return c.fit_jobs ? &c.fit_jobs->jobs() : nullptr;
  }
  static std::optional<int> integer_field(const json& body, const char* key, int min, int max) {
    const auto it = body.find(key);
    if (it == body.end()) return std::nullopt;
    if (!it->is_number_integer())
      fail(ErrorKind::unprocessable, "wrong_type", std::string("'") + key + "' must be an integer");
    const auto v = it->get<std::int64_t>();
    if (v < min || v > max)
      fail(ErrorKind::unprocessable, "out_of_range",
           std::string("'") + key + "' must be " + std::to_string(min) + " to " + std::to_string(max));
    return static_cast<int>(v);
  }
  static json job_view(const RouterContext& c, store::Id job_id) {
    const store::Store& db = store_of(c);
    return value(current_job_json(db, watch_of(c, value(db.job(job_id))), job_id));
  }
  // GET /api/v1/jobs/{id}
  static Response get_job(const RouterContext& c, const Call& call) {
    no_query(call);
    return json_response(job_view(c, call.ids[0]));
  }
  // GET /api/v1/jobs/{id}/events
  static Response job_events(const RouterContext& c, const Call& call) {
    no_query(call);
    store::Store& db = store_of(c);
    const auto job = value(db.job(call.ids[0]));  // 404 before the stream starts
    Response r{200, "text/event-stream", "", {{"Cache-Control", "no-cache"}}};
    r.events = std::make_shared<JobEvents>(db, watch_of(c, job), call.ids[0]);
    return r;
  }
  // DELETE /api/v1/jobs/{id}
  static Response cancel_job(const RouterContext& c, const Call& call) {
    no_query(call);
    const auto found = value(store_of(c).job(call.ids[0]));  // 404 first
    auto job = parse_job_kind(found.kind) == JobKind::measure ? acquisition_of(c).cancel(found.id)
                                                              : fit_jobs_of(c).cancel(found.id);
    if (!job) throw detail::HandlerError{job.error()};
    return json_response(job_view(c, job->id));
  }
  // The document depends on the route table alone, so it is built and written out once: each
  // request built some 100 kB of JSON afresh (http_request_fuzz, 150,000 executions from its
  // kept corpus with one seed: 137 s before, 108 s after).
  static Response openapi(const RouterContext&, const Call&) {
    static const std::string body = detail::dump(openapi_document());
    return Response{200, "application/json", body, {}};
  }
  static Response metrics(const RouterContext& c, const Call&) {
    return Response{200, "text/plain; version=0.0.4; charset=utf-8", c.metrics->prometheus_text(), {}};
  }

  static FitResult run_fit(const RouterContext& c, const Spectrum& spectrum, const FitOptions& options) {
    auto result = fitter_of(c).fit(spectrum, options);
    c.metrics->record_fit(result.has_value());
    if (!result) fail(ErrorKind::unprocessable, "fit_failed", result.error());
    return std::move(*result);
  }
  static Spectrum make_spectrum(std::vector<double> wl, std::vector<double> values, const std::string& name) {
    if (wl.size() != values.size())
      fail(ErrorKind::unprocessable, "unequal_lengths",
           "'" + name + "' has " + std::to_string(values.size()) + " values for " + std::to_string(wl.size()) +
               " wavelengths");
    auto spectrum = Spectrum::create(std::move(wl), std::move(values));
    if (!spectrum) fail(ErrorKind::unprocessable, "invalid_spectrum", name + ": " + spectrum.error());
    return std::move(*spectrum);
  }

  // POST /api/v1/fit
  static Response fit(const RouterContext& c, const Call& call) {
    const json body = detail::parse_object(call.request.body);
    detail::only_fields(body,
                        {"wavelength_nm", "reflectance", "spectra", "site", "name", "lateral_diffusion", "model"});
    FitOptions options;
    options.model = model_of(body);
    options.site = detail::optional_string(body, "site", 64).value_or("forearm");
    options.lateral_diffusion = detail::optional_bool(body, "lateral_diffusion").value_or(true);
    checked_site(c, options.site);
    if (!body.contains("wavelength_nm")) fail(ErrorKind::unprocessable, "missing_field", "'wavelength_nm' is required");
    const auto wl = detail::number_array(body["wavelength_nm"], "wavelength_nm", 1, 100000, c.max_spectrum_samples);
    const bool single = body.contains("reflectance"), several = body.contains("spectra");
    if (single == several)
      fail(ErrorKind::unprocessable, "missing_field", "give exactly one of 'reflectance' and 'spectra'");
    if (single) {
      const auto name = detail::optional_string(body, "name", 200).value_or("spectrum");
      auto values = detail::number_array(body["reflectance"], "reflectance", -10, 10, c.max_spectrum_samples);
      return json_response(fit_to_json(name, run_fit(c, make_spectrum(wl, std::move(values), "reflectance"), options)));
    }
    if (body.contains("name"))
      fail(ErrorKind::unprocessable, "unknown_field",
           "'name' goes with 'reflectance'; 'spectra' are named by their keys");
    const json& spectra = body["spectra"];
    if (!spectra.is_object() || spectra.empty() || spectra.size() > 100)
      fail(ErrorKind::unprocessable, "wrong_type", "'spectra' must be an object of 1 to 100 named arrays");
    std::vector<std::pair<std::string, Spectrum>> inputs;
    for (const auto& item : spectra.items()) {
      auto values = detail::number_array(item.value(), "spectra." + item.key(), -10, 10, c.max_spectrum_samples);
      inputs.emplace_back(item.key(), make_spectrum(wl, std::move(values), "spectra." + item.key()));
    }
    json fits = json::array();
    for (const auto& [name, spectrum] : inputs) fits.push_back(fit_to_json(name, run_fit(c, spectrum, options)));
    return json_response({{"fits", fits}});
  }

  // White standards
  static Response create_white_standard(const RouterContext& c, const Call& call) {
    const json body = detail::parse_object(call.request.body);
    detail::only_fields(body, {"name", "certificate", "wavelength_nm", "reflectance"});
    store::WhiteStandard s;
    s.name = detail::required_string(body, "name", 200);
    s.certificate = detail::optional_string(body, "certificate", 2000).value_or("");
    for (const char* key : {"wavelength_nm", "reflectance"})
      if (!body.contains(key))
        fail(ErrorKind::unprocessable, "missing_field", std::string("'") + key + "' is required");
    s.reflectance.wavelength_nm =
        detail::number_array(body["wavelength_nm"], "wavelength_nm", 1, 100000, c.max_spectrum_samples);
    s.reflectance.values = detail::number_array(body["reflectance"], "reflectance", 0, 2, c.max_spectrum_samples);
    make_spectrum(s.reflectance.wavelength_nm, s.reflectance.values, "reflectance");  // same checks as a fit's input
    store::Store& db = store_of(c);
    const store::Id id = value(db.add_white_standard(s));
    Response r = json_response(records::to_json(value(db.white_standard(id))), 201);
    r.headers.emplace_back("Location", "/api/v1/white-standards/" + std::to_string(id));
    return r;
  }
  static Response list_white_standards(const RouterContext& c, const Call& call) {
    no_query(call);
    json list = json::array();
    for (const auto& s : value(store_of(c).white_standards())) list.push_back(records::to_json(s));
    return json_response({{"white_standards", list}});
  }
  static Response get_white_standard(const RouterContext& c, const Call& call) {
    no_query(call);
    return json_response(records::to_json(value(store_of(c).white_standard(call.ids[0]))));
  }

  // Sessions
  static Response create_session(const RouterContext& c, const Call& call) {
    const json body = detail::parse_object(call.request.body);
    detail::only_fields(body, {"site", "subject", "operator", "white_standard_id", "notes", "model"});
    store::Session s;
    s.site = checked_site(c, detail::required_string(body, "site", 64));
    s.model = std::string(to_string(model_of(body)));
    s.subject = detail::required_string(body, "subject", 200);
    s.operator_name = detail::optional_string(body, "operator", 200).value_or("");
    s.notes = detail::optional_string(body, "notes", 20000).value_or("");
    s.white_standard_id = detail::optional_id(body, "white_standard_id");
    store::Store& db = store_of(c);
    if (s.white_standard_id) {
      if (auto ws = db.white_standard(*s.white_standard_id); !ws) {
        if (ws.error().kind == store::StoreError::Kind::not_found)
          fail(ErrorKind::unprocessable, "unknown_white_standard",
               "no white standard " + std::to_string(*s.white_standard_id));
        fail_store(ws.error());
      }
    }
    const store::Id id = value(db.create_session(s));
    Response r = json_response(records::to_json(value(db.session(id))), 201);
    r.headers.emplace_back("Location", "/api/v1/sessions/" + std::to_string(id));
    return r;
  }
  static store::Id parse_id(const std::string& text, const char* name) {
    store::Id id = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), id);
    if (ec != std::errc{} || end != text.data() + text.size() || id <= 0)
      fail(ErrorKind::bad_request, "invalid_parameter", std::string("'") + name + "' must be a positive integer");
    return id;
  }
  static store::Time parse_time_param(const std::string& text, const char* name) {
    auto t = detail::parse_time(text);
    if (!t)
      fail(ErrorKind::bad_request, "invalid_parameter",
           std::string("'") + name + "' must be an RFC 3339 UTC time like 2026-01-02T03:04:05Z");
    return *t;
  }
  static Response list_sessions(const RouterContext& c, const Call& call) {
    store::SessionFilter filter;
    for (const auto& [name, text] : call.query) {
      if (name == "site") filter.site = text;
      else if (name == "state") {
        filter.state = store::parse_session_state(text);
        if (!filter.state)
          fail(ErrorKind::bad_request, "invalid_parameter", "'state' must be open, complete, interrupted or aborted");
      } else if (name == "from") filter.created_from = parse_time_param(text, "from");
      else if (name == "to") filter.created_before = parse_time_param(text, "to");
      else if (name == "cursor") filter.cursor = parse_id(text, "cursor");
      else if (name == "limit") {
        const store::Id limit = parse_id(text, "limit");
        if (limit > 1000) fail(ErrorKind::bad_request, "invalid_parameter", "'limit' must be 1 to 1000");
        filter.limit = static_cast<int>(limit);
      } else fail(ErrorKind::bad_request, "unknown_parameter", "unknown query parameter '" + name + "'");
    }
    const auto page = value(store_of(c).sessions(filter));
    json list = json::array();
    for (const auto& s : page.sessions) list.push_back(records::to_json(s));
    return json_response(
        {{"sessions", list}, {"next_cursor", page.next_cursor ? json(*page.next_cursor) : json(nullptr)}});
  }
  // GET /api/v1/audit?before=&limit=: the changes recorded, newest first (docs/api.md, "Audit").
  static Response audit(const RouterContext& c, const Call& call) {
    std::optional<store::Id> before;
    store::Id limit = 100;
    for (const auto& [name, text] : call.query) {
      if (name == "before") before = parse_id(text, "before");
      else if (name == "limit") limit = parse_id(text, "limit");
      else fail(ErrorKind::bad_request, "unknown_parameter", "unknown query parameter '" + name + "'");
    }
    if (limit > 1000) fail(ErrorKind::bad_request, "invalid_parameter", "'limit' must be 1 to 1000");
    const auto entries = value(store_of(c).audit(before, static_cast<int>(limit)));
    json list = json::array();
    for (const auto& e : entries) list.push_back(records::to_json(e));
    const bool more = std::cmp_equal(entries.size(), limit);
    return json_response({{"entries", list}, {"next_before", more ? json(entries.back().id) : json(nullptr)}});
  }
  // GET /api/v1/audit/export.csv and .json: the whole trail, oldest first, as `skinspec export
  // --audit` writes it, for an inspection or an archive.
  static Response audit_file(const RouterContext& c, const Call& call, records::ExportFormat format,
                             const char* content_type, const char* extension) {
    no_query(call);
    std::ostringstream out;
    if (auto done = records::export_audit(store_of(c), format, out); !done) fail_store(done.error());
    return download(out.str(), content_type, std::string("audit.") + extension);
  }
  static Response export_audit_csv(const RouterContext& c, const Call& call) {
    return audit_file(c, call, records::ExportFormat::csv, "text/csv; charset=utf-8", "csv");
  }
  static Response export_audit_jsonl(const RouterContext& c, const Call& call) {
    return audit_file(c, call, records::ExportFormat::json, "application/jsonl; charset=utf-8", "jsonl");
  }
  // The detail always holds every measurement's and fit's spectra, so a notebook has a whole
  // session in one request; `include=spectra` says so explicitly and is the only include.
  static Response get_session(const RouterContext& c, const Call& call) {
    for (const auto& [name, text] : call.query) {
      if (name != "include")
        fail(ErrorKind::bad_request, "unknown_parameter", "unknown query parameter '" + name + "'");
      if (text != "spectra") fail(ErrorKind::bad_request, "invalid_parameter", "'include' can only be 'spectra'");
    }
    const auto detail_ = value(store_of(c).session_detail(call.ids[0]));
    json out = records::to_json(detail_.session);
    json measurements = json::array(), fits = json::array();
    for (const auto& m : detail_.measurements)
      measurements.push_back(records::to_json(m, records::latest_fit_of(m.id, detail_.fits)));
    for (const auto& f : detail_.fits) fits.push_back(records::to_json(f));
    json rejected = json::array();
    for (const auto& r : detail_.rejected_readings) rejected.push_back(records::to_json(r));
    out["measurements"] = measurements;
    out["fits"] = fits;
    out["rejected_readings"] = rejected;
    return json_response(out);
  }
  static Response patch_session(const RouterContext& c, const Call& call) {
    const json body = detail::parse_object(call.request.body);
    detail::only_fields(body, {"notes", "close", "state"});
    store::SessionUpdate update;
    update.notes = detail::optional_string(body, "notes", 20000);
    if (auto state = detail::optional_string(body, "state", 32)) {
      update.state = store::parse_session_state(*state);
      if (!update.state)
        fail(ErrorKind::unprocessable, "invalid_value", "'state' must be open, complete, interrupted or aborted");
    }
    if (auto close = detail::optional_bool(body, "close"); close && *close) {
      if (update.state && *update.state != store::SessionState::complete)
        fail(ErrorKind::unprocessable, "invalid_value", "'close' and 'state' disagree");
      update.state = store::SessionState::complete;
    }
    if (!update.notes && !update.state)
      fail(ErrorKind::unprocessable, "missing_field", "nothing to change: give 'notes', 'close' or 'state'");
    return json_response(records::to_json(value(store_of(c).update_session(call.ids[0], update))));
  }
  // A session's export as a file to save: session-ID.EXTENSION.
  static Response export_file(const RouterContext& c, const Call& call, records::ExportFormat format,
                              const char* content_type, const char* extension) {
    no_query(call);
    std::ostringstream out;
    if (format == records::ExportFormat::csv) records::write_csv_header(out);
    if (auto done = records::export_session(store_of(c), call.ids[0], format, out); !done) fail_store(done.error());
    return download(out.str(), content_type, "session-" + std::to_string(call.ids[0]) + "." + extension);
  }
  // A file to save rather than show: the browser offers `filename`.
  static Response download(std::string body, const char* content_type, const std::string& filename) {
    Response r{200, content_type, std::move(body), {}};
    r.headers.emplace_back("Content-Disposition", "attachment; filename=\"" + filename + "\"");
    return r;
  }
  static Response export_csv(const RouterContext& c, const Call& call) {
    return export_file(c, call, records::ExportFormat::csv, "text/csv; charset=utf-8", "csv");
  }
  static Response export_cgats(const RouterContext& c, const Call& call) {
    return export_file(c, call, records::ExportFormat::cgats, "text/plain; charset=utf-8", "ti3");
  }

  // Measurements and fits
  static Response get_measurement(const RouterContext& c, const Call& call) {
    no_query(call);
    store::Store& db = store_of(c);
    const auto m = value(db.measurement(call.ids[0]));
    const auto fits = value(db.fits_of_measurement(m.id));
    json body = records::to_json(m, records::latest_fit_of(m.id, fits));
    body["colour"] = colour_of(c, m);
    // Its latest fit can change (a refit): tagged, to be asked again each time.
    return detail::cached_response(call.request, detail::tagged(detail::dump(body)), detail::kRevalidate);
  }
  // A reflectance's colour under D65 and A: XYZ (Y = 1 for white), CIELAB against that
  // light's white, and the sRGB a display shows for it. Under A the XYZ are not adapted to the
  // display's D65 white, so the swatch looks as warm as the skin does under a lamp.
  static json colour_of(const RouterContext& c, const store::Measurement& m) {
    if (m.reflectance.empty() || c.fitter == nullptr) return nullptr;
    auto spectrum = Spectrum::create(m.reflectance.wavelength_nm, m.reflectance.values);
    if (!spectrum) return nullptr;
    const Colorimetry& colorimetry = c.fitter->colorimetry();
    json out = json::object();
    for (const char* name : {"D65", "A"}) {
      const auto light = colorimetry.illuminant(name);
      if (!light) continue;
      const Xyz xyz = colorimetry.xyz(*spectrum, *light);
      const Lab lab = xyz_to_lab(xyz, colorimetry.white(*light));
      const auto rgb = srgb_8bit(xyz_to_linear_srgb(xyz));
      out[name] = {{"xyz", {xyz.x, xyz.y, xyz.z}}, {"lab", {lab.l, lab.a, lab.b}}, {"srgb", {rgb[0], rgb[1], rgb[2]}}};
    }
    return out;
  }
  // GET /api/v1/sites
  static Response sites(const RouterContext& c, const Call& call) {
    no_query(call);
    json list = json::array();
    for (const auto& name : fitter_of(c).optics(kDefaultModel).site_names()) {
      const auto site = fitter_of(c).optics(kDefaultModel).site(name);
      if (site)
        list.push_back({{"name", site->name}, {"epidermis_mm", site->epidermis_mm}, {"dermis_mm", site->dermis_mm}});
    }
    return json_response({{"sites", list}});
  }
  // GET /api/v1/models: from the tables compiled in, so with or without a database or model tables
  static Response models(const RouterContext&, const Call& call) {
    no_query(call);
    return json_response(detail::models_json());
  }
  // A stored fit never changes: served from the cache of answers once made, with a tag that
  // lets a client that holds it skip the body (304).
  static Response get_fit(const RouterContext& c, const Call& call) {
    no_query(call);
    const std::string key = fit_cache_key(call.ids[0]);
    auto cached = c.body_cache->find(key);
    if (!cached && call.from_memory_only) throw NotInMemory{};
    if (!cached) {
      cached = std::make_shared<const CachedBody>(
          detail::cacheable(detail::dump(records::to_json(value(store_of(c).fit(call.ids[0]))))));
      c.body_cache->put(key, *cached);
    }
    return detail::cached_response(call.request, **cached, detail::kImmutable);
  }
  static Response refit(const RouterContext& c, const Call& call) {
    const json body = call.request.body.empty() ? json::object() : detail::parse_object(call.request.body);
    detail::only_fields(body, {"site", "lateral_diffusion", "model"});
    store::Store& db = store_of(c);
    const auto m = value(db.measurement(call.ids[0]));
    if (m.reflectance.empty())
      fail(ErrorKind::conflict, "no_reflectance", "measurement " + std::to_string(m.id) + " has no reflectance to fit");
    const auto session = value(db.session(m.session_id));
    FitOptions options;
    const auto session_model = parse_model_kind(session.model);
    if (!session_model && !body.contains("model"))
      fail(ErrorKind::unprocessable, "unknown_model",
           "session " + std::to_string(session.id) + "'s model '" + session.model +
               "' is not one this version knows; give \"model\"");
    options.model = model_of(body, session_model.value_or(kDefaultModel));
    options.site = detail::optional_string(body, "site", 64).value_or(session.site);
    checked_site(c, options.site);
    options.lateral_diffusion = detail::optional_bool(body, "lateral_diffusion").value_or(true);
    const auto result =
        run_fit(c, make_spectrum(m.reflectance.wavelength_nm, m.reflectance.values, "reflectance"), options);
    store::Fit f = records::to_store_fit(result, options, fitter_of(c).optics(options.model));
    f.measurement_id = m.id;
    const store::Id id = value(db.add_fit(f));
    Response r = json_response(records::to_json(value(db.fit(id))), 201);
    r.headers.emplace_back("Location", "/api/v1/fits/" + std::to_string(id));
    return r;
  }
  // GET /api/v1/fits/{id}/render.png
  static Response render_fit(const RouterContext& c, const Call& call) {
    auto image = detail::render_fit_png(fitter_of(c), value(store_of(c).fit(call.ids[0])), call.query, *c.render_cache);
    // An image of a stored fit by given parameters never changes either.
    const auto cached = detail::tagged(std::move(image.body));
    auto r = detail::cached_response(call.request, cached, detail::kImmutable, image.content_type);
    r.headers.insert(r.headers.end(), image.headers.begin(), image.headers.end());
    return r;
  }
  // POST /api/v1/maps: a cube named in the data directory (JSON), or uploaded (any other type)
  static Response post_map(const RouterContext& c, const Call& call) {
    const bool named = media_type(call.request) == "application/json";
    if (named) no_query(call);
    auto ask =
        named ? detail::map_ask_of_json(call.request.body) : detail::map_ask_of_upload(call.request.body, call.query);
    FitJobs& jobs = fit_jobs_of(c);
    auto request = prepare_map(std::move(ask), c.maps, fitter_of(c));
    if (!request) throw detail::HandlerError{request.error()};
    return accepted(c, jobs.submit_map(std::move(*request), idempotency_key(call)));
  }
  // GET /api/v1/maps
  static Response list_maps(const RouterContext& c, const Call& call) {
    return json_response(detail::map_list_json(store_of(c), call.query));
  }
  // GET /api/v1/maps/{id}
  static Response get_map(const RouterContext& c, const Call& call) {
    no_query(call);
    return json_response(detail::map_json(value(store_of(c).map(call.ids[0]))));
  }
  // GET /api/v1/maps/{id}/{parameter}.png
  static Response map_picture(const RouterContext& c, const Call& call) {
    no_query(call);
    return detail::map_picture_response(call.request, store_of(c), call.ids[0], call.names[0]);
  }
  // GET /api/v1/maps/{id}/cube.hdr
  static Response map_header(const RouterContext& c, const Call& call) {
    no_query(call);
    return detail::map_header_response(call.request, store_of(c), call.ids[0]);
  }
  // GET /api/v1/maps/{id}/pixel?x=&y=
  static Response map_pixel(const RouterContext& c, const Call& call) {
    return json_response(detail::map_pixel_json(store_of(c), fitter_of(c), call.ids[0], call.query));
  }
  // GET /api/v1/maps/{id}/cube
  static Response map_cube(const RouterContext& c, const Call& call) {
    no_query(call);
    return detail::map_cube_response(call.request, store_of(c), call.ids[0]);
  }
};

namespace {

struct Route {
  RouteInfo info;
  Router::Handlers::Fn handler;
  std::vector<std::string> segments;
};

std::vector<std::string> split_path(std::string_view path) {
  std::vector<std::string> out;
  std::size_t pos = 1;
  while (pos <= path.size()) {
    const auto slash = path.find('/', pos);
    const auto end = slash == std::string_view::npos ? path.size() : slash;
    out.emplace_back(path.substr(pos, end - pos));
    pos = end + 1;
  }
  return out;
}

const std::vector<Route>& route_table() {
  using H = Router::Handlers;
  static const std::vector<Route> table = [] {
    std::vector<Route> t = {
        {{.method = "GET",
          .path = "/healthz",
          .summary = "Liveness, database state and version",
          .scope = Scope::read,
          .request_schema = "",
          .response_schema = "Health",
          .success_status = 200,
          .needs_token = false},
         &H::healthz,
         {}},
        {{"GET", "/openapi.json", "This OpenAPI document", Scope::read, "", "OpenApi", 200}, &H::openapi, {}},
        {{"GET", "/metrics", "Prometheus metrics", Scope::read, "", "text/plain", 200}, &H::metrics, {}},
        {{"POST", "/api/v1/fit", "Fit the skin model to one or several reflectance spectra", Scope::measure,
          "FitRequest", "FitResponse", 200, true},
         &H::fit,
         {}},
        {{"GET", "/api/v1/sites", "The body sites the model knows, with their layer thicknesses", Scope::read, "",
          "SiteList", 200},
         &H::sites,
         {}},
        {{"GET", "/api/v1/models",
          "The skin models and their parameters: name, label, unit, bounds, default, domain; the derived quantities",
          Scope::read, "", "ModelList", 200},
         &H::models,
         {}},
        {{"POST", "/api/v1/white-standards", "Store a white standard", Scope::admin, "WhiteStandardCreate",
          "WhiteStandard", 201},
         &H::create_white_standard,
         {}},
        {{"GET", "/api/v1/white-standards", "List white standards", Scope::read, "", "WhiteStandardList", 200},
         &H::list_white_standards,
         {}},
        {{"GET", "/api/v1/white-standards/{id}", "One white standard", Scope::read, "", "WhiteStandard", 200},
         &H::get_white_standard,
         {}},
        {{"POST", "/api/v1/sessions", "Open a session", Scope::measure, "SessionCreate", "Session", 201},
         &H::create_session,
         {}},
        {{"GET", "/api/v1/sessions", "List sessions, newest first, with cursor pagination", Scope::read, "",
          "SessionPage", 200},
         &H::list_sessions,
         {}},
        {{"GET", "/api/v1/sessions/{id}", "One session with its measurements, fits and rejected readings", Scope::read,
          "", "SessionDetail", 200},
         &H::get_session,
         {}},
        {{"PATCH", "/api/v1/sessions/{id}", "Change a session's notes or close it", Scope::measure, "SessionUpdate",
          "Session", 200},
         &H::patch_session,
         {}},
        {{"GET", "/api/v1/sessions/{id}/export.csv", "A session as CSV", Scope::read, "", "text/csv", 200},
         &H::export_csv,
         {}},
        {{"GET", "/api/v1/sessions/{id}/export.cgats",
          "A session's reflectance spectra as CGATS (ArgyllCMS .ti3), one set per measurement", Scope::read, "",
          "text/plain", 200},
         &H::export_cgats,
         {}},
        {{"GET", "/api/v1/measurements/{id}", "One measurement: radiance, reflectance, quality, provenance, its fit id",
          Scope::read, "", "Measurement", 200},
         &H::get_measurement,
         {}},
        {{"POST", "/api/v1/measurements/{id}/fit", "Refit a stored measurement and store the new fit", Scope::measure,
          "RefitRequest", "Fit", 201, true},
         &H::refit,
         {}},
        {{.method = "GET",
          .path = "/api/v1/fits/{id}",
          .summary = "One stored fit, with the fields of `skinspec fit`",
          .scope = Scope::read,
          .request_schema = "",
          .response_schema = "Fit",
          .success_status = 200,
          .heavy = false,
          .upload = false,
          .from_memory = true},
         &H::get_fit,
         {}},
        {{"GET", "/api/v1/instrument",
          "The instrument's state (connected, measuring, lost ...), port, last error and reconnection", Scope::read, "",
          "Instrument", 200},
         &H::instrument,
         {}},
        {{"GET", "/api/v1/benches",
          "The benches writing this database: each one's program, heartbeat, state and instrument", Scope::read, "",
          "BenchList", 200},
         &H::benches,
         {}},
        {{"POST", "/api/v1/sessions/{id}/measurements", "Queue a white or sample measurement of a session",
          Scope::measure, "MeasureRequest", "Job", 202},
         &H::measure,
         {}},
        {{"POST", "/api/v1/sessions/{id}/imports",
          "Import a file of spectra (CSV or CGATS) into an open session, each spectrum fitted: a job", Scope::measure,
          "text/plain", "Job", 202, false, true},
         &H::import_spectra,
         {}},
        {{"POST", "/api/v1/refits",
          "Refit stored measurements (every session's, or one's) with the current model and constants: a job",
          Scope::measure, "RefitJobRequest", "Job", 202},
         &H::refits,
         {}},
        {{"GET", "/api/v1/jobs/{id}", "One job: state, queue position, progress, error, the ids it produced",
          Scope::read, "", "Job", 200},
         &H::get_job,
         {}},
        {{"DELETE", "/api/v1/jobs/{id}", "Cancel a queued or running job", Scope::measure, "", "Job", 200},
         &H::cancel_job,
         {}},
        {{"GET", "/api/v1/jobs/{id}/events", "The job's changes as Server-Sent Events, until it ends", Scope::read, "",
          "text/event-stream", 200},
         &H::job_events,
         {}},
        {{"GET", "/api/v1/ports",
          "Serial ports, Photo Research meters on USB and USB serial adapters present, with the --device URI of each",
          Scope::read, "", "PortList", 200},
         &H::ports,
         {}},
        {{"GET", "/api/v1/fits/{id}/render.png",
          "The fit's skin rendered on the procedural hand (cached by its parameters)", Scope::read, "", "image/png",
          200, true},
         &H::render_fit,
         {}},
        {{"POST", "/api/v1/maps",
          "Map a spectral image: a cube named in the data directory (JSON) or uploaded (a TIFF, HDF5 or netCDF "
          "file, or a tar of an ENVI header and data), every skin pixel fitted: a job",
          Scope::measure, "MapRequest", "Job", 202, false, true},
         &H::post_map,
         {}},
        {{"GET", "/api/v1/audit", "The changes made through the service, newest first: who, from where, what",
          Scope::admin, "", "AuditList", 200},
         &H::audit,
         {}},
        {{"GET", "/api/v1/audit/export.csv", "The whole audit trail as CSV, oldest first", Scope::admin, "", "text/csv",
          200},
         &H::export_audit_csv,
         {}},
        {{"GET", "/api/v1/audit/export.jsonl", "The whole audit trail as JSON lines, oldest first", Scope::admin, "",
          "application/jsonl", 200},
         &H::export_audit_jsonl,
         {}},
        {{"GET", "/api/v1/maps", "List skin maps, newest first; of one session with session_id", Scope::read, "",
          "MapList", 200},
         &H::list_maps,
         {}},
        {{"GET", "/api/v1/maps/{id}", "One skin map: its summary, bands and links", Scope::read, "", "Map", 200},
         &H::get_map,
         {}},
        {{"GET", "/api/v1/maps/{id}/{parameter}.png", "A skin map's picture of one parameter, with its colour bar",
          Scope::read, "", "image/png", 200},
         &H::map_picture,
         {}},
        {{"GET", "/api/v1/maps/{id}/cube.hdr", "A skin map's answer cube: its ENVI header", Scope::read, "",
          "text/plain", 200},
         &H::map_header,
         {}},
        {{"GET", "/api/v1/maps/{id}/pixel",
          "One pixel of a skin map: its answers, its measured reflectance and the fit of it (x, y from 0)", Scope::read,
          "", "MapPixel", 200, true},
         &H::map_pixel,
         {}},
        {{"GET", "/api/v1/maps/{id}/cube",
          "A skin map's answer cube: its ENVI data (float32, little-endian, band-interleaved by line)", Scope::read, "",
          "application/octet-stream", 200},
         &H::map_cube,
         {}},
    };
    for (auto& r : t) r.segments = split_path(r.info.path);
    return t;
  }();
  return table;
}

// A path segment against a route's: literally, or {id} (a positive integer, into `ids`), or
// {parameter}.png (a band's name: lower-case letters, digits and '_', into `names`).
bool segment_matches(const std::string& pattern, const std::string& segment, std::vector<store::Id>& ids,
                     std::vector<std::string>& names) {
  if (pattern == "{parameter}.png") {
    constexpr std::string_view kPng = ".png";
    if (!segment.ends_with(kPng) || segment.size() == kPng.size() || segment.size() > 64 + kPng.size()) return false;
    const std::string name = segment.substr(0, segment.size() - kPng.size());
    if (!std::ranges::all_of(name,
                             [](char ch) { return (ch >= 'a' && ch <= 'z') || (ch >= '0' && ch <= '9') || ch == '_'; }))
      return false;
    names.push_back(name);
    return true;
  }
  if (pattern != "{id}") return pattern == segment;
  if (segment.empty() || segment.size() > 18 ||
      !std::all_of(segment.begin(), segment.end(), [](char ch) { return ch >= '0' && ch <= '9'; }))
    return false;
  const store::Id id = std::stoll(segment);
  if (id <= 0) return false;
  ids.push_back(id);
  return true;
}

// The route for `method` on a path's segments, with the ids taken from them; nullptr when there
// is none, and then the methods the path has in `allow`.
const Route* find_route(const std::string& method, const std::vector<std::string>& segments,
                        std::vector<store::Id>& ids, std::vector<std::string>& names, std::string& allow) {
  for (const auto& route : route_table()) {
    if (route.segments.size() != segments.size()) continue;
    std::vector<store::Id> route_ids;
    std::vector<std::string> route_names;
    bool ok = true;
    for (std::size_t i = 0; ok && i < segments.size(); ++i)
      ok = segment_matches(route.segments[i], segments[i], route_ids, route_names);
    if (!ok) continue;
    if (route.info.method == method) {
      ids = std::move(route_ids);
      names = std::move(route_names);
      return &route;
    }
    allow += (allow.empty() ? "" : ", ") + route.info.method;
  }
  return nullptr;
}

// The token of `Authorization: Bearer TOKEN`; the scheme's name is case-insensitive (RFC 9110 §11.1).
std::optional<std::string_view> bearer_token(std::string_view credentials) {
  constexpr std::string_view kScheme = "bearer";
  const auto space = credentials.find(' ');
  if (space != kScheme.size()) return std::nullopt;
  for (std::size_t i = 0; i < kScheme.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(credentials[i])) != kScheme[i]) return std::nullopt;
  const auto start = credentials.find_first_not_of(' ', space);
  if (start == std::string_view::npos) return std::nullopt;
  return credentials.substr(start);
}

// Who is calling `route`, from the request's bearer token: 401 without a known token, 403 with
// one whose scope does not cover the route's. Nobody when no token is asked for.
std::optional<Caller> check_access(const Keyring* tokens, const Request& request, const RouteInfo& route) {
  if (tokens == nullptr || !route.needs_token) return std::nullopt;
  const auto it = request.headers.find("authorization");
  const auto token = it == request.headers.end() ? std::nullopt : bearer_token(it->second);
  if (!token) fail(ErrorKind::unauthorized, "unauthorized", "a bearer token is required");
  auto caller = tokens->identify(*token);
  if (!caller) fail(ErrorKind::unauthorized, "unauthorized", "unknown token");
  if (!allows(caller->scope, route.scope))
    fail(ErrorKind::forbidden, "forbidden",
         route.method + " " + route.path + " needs a token of scope " + std::string(to_string(route.scope)) + "; '" +
             caller->name + "' has scope " + std::string(to_string(caller->scope)));
  return caller;
}

// A route that reads JSON takes application/json (a refit of a measurement may have no body);
// one that reads a text file takes any text type, or none named; one that reads a file of
// another kind takes any type.
void check_content_type(const Request& request, const RouteInfo& route) {
  if (route.request_schema.empty()) return;
  const std::string type = media_type(request);
  if (route.request_schema == "text/plain") {
    if (!type.empty() && !type.starts_with("text/"))
      fail(ErrorKind::unsupported_media_type, "unsupported_media_type",
           "the body must be a text type such as text/csv, not " + type);
    return;
  }
  if (request.body.empty() && route.path == "/api/v1/measurements/{id}/fit") return;
  if (route.upload) return;  // a file of any type, or a JSON request (POST /api/v1/maps)
  if (type != "application/json")
    fail(ErrorKind::unsupported_media_type, "unsupported_media_type", "the body must be application/json");
}

}  // namespace

// A 503 is a condition that passes (a database server restarting, every compute slot taken):
// the client is told when to ask again.
constexpr int kRetryAfterSeconds = 1;

Response error_response(const ApiError& error) {
  Response response{http_status(error.kind), "application/json", error_body(error), {}};
  if (error.kind == ErrorKind::unavailable)
    response.headers.emplace_back("Retry-After", std::to_string(kRetryAfterSeconds));
  return response;
}

Router::Router(RouterContext context) : context_(std::move(context)) {
  if (!context_.metrics) context_.metrics = std::make_shared<Metrics>();
  if (!context_.render_cache) context_.render_cache = std::make_shared<RenderCache>();
  if (!context_.body_cache) context_.body_cache = std::make_shared<BodyCache>();
  if (!context_.job_board) context_.job_board = std::make_shared<JobBoard>();
  if (!context_.fit_jobs && context_.store && context_.fitter) {
    remove_abandoned_map_work(context_.maps);
    context_.fit_jobs = std::make_shared<FitJobs>(*context_.store, *context_.fitter, *context_.job_board);
  }
}
Router::~Router() = default;

const std::vector<RouteInfo>& Router::routes() {
  static const std::vector<RouteInfo> infos = [] {
    std::vector<RouteInfo> out;
    for (const auto& r : route_table()) out.push_back(r.info);
    return out;
  }();
  return infos;
}

const RouteInfo* Router::route_of(const std::string& method, const std::string& target) {
  const std::string_view path = std::string_view(target).substr(0, target.find('?'));
  if (path.empty() || path.front() != '/') return nullptr;
  const auto decoded = detail::percent_decode(path, false);
  if (!decoded) return nullptr;
  std::vector<store::Id> ids;
  std::vector<std::string> names;
  std::string allow;
  const Route* route = find_route(method, split_path(*decoded), ids, names, allow);
  return route != nullptr ? &route->info : nullptr;
}

bool Router::is_heavy(const std::string& method, const std::string& target) {
  const RouteInfo* route = route_of(method, target);
  return route != nullptr && route->heavy;
}

bool Router::is_upload(const std::string& method, const std::string& target) {
  const RouteInfo* route = route_of(method, target);
  return route != nullptr && route->upload;
}

std::optional<ApiError> Router::refuse_upload(const Request& header) const {
  const RouteInfo* route = route_of(header.method, header.target);
  if (route == nullptr || !route->upload) return std::nullopt;
  try {
    check_access(context_.tokens.get(), header, *route);
  } catch (const detail::HandlerError& e) {
    return e.error;
  }
  return std::nullopt;
}

Response Router::handle(const Request& request) const { return *answer(request, false); }

namespace {

// The fixed beginnings of the paths of the routes that may be answered from memory (up to their
// first {id}): every other request is spared the parsing on the thread that read it.
const std::vector<std::string>& from_memory_prefixes() {
  static const std::vector<std::string> prefixes = [] {
    std::vector<std::string> out;
    for (const Route& r : route_table())
      if (r.info.from_memory && r.info.method == "GET") out.push_back(r.info.path.substr(0, r.info.path.find('{')));
    return out;
  }();
  return prefixes;
}

}  // namespace

std::optional<Response> Router::answer_from_memory(const Request& request) const {
  if (request.method != "GET" ||
      std::ranges::none_of(from_memory_prefixes(), [&](const std::string& p) { return request.target.starts_with(p); }))
    return std::nullopt;
  return answer(request, true);
}

std::optional<Response> Router::answer(const Request& request, bool from_memory_only) const {
  const auto started = std::chrono::steady_clock::now();
  std::string route_label = "unmatched";
  Response response;
  try {
    const std::string_view target = request.target;
    const auto qmark = target.find('?');
    const std::string_view raw_path = target.substr(0, qmark);
    if (raw_path.empty() || raw_path.front() != '/')
      fail(ErrorKind::bad_request, "invalid_path", "the target must be an absolute path");
    const auto path = detail::percent_decode(raw_path, false);
    if (!path || !utf8::is_valid(*path) || path->find('\0') != std::string::npos ||
        path->find('\\') != std::string::npos)
      fail(ErrorKind::bad_request, "invalid_path", "the path is not valid percent-encoded UTF-8");
    const auto segments = split_path(*path);
    for (const auto& s : segments)
      if (s == ".." || s == ".") fail(ErrorKind::bad_request, "invalid_path", "'.' and '..' are not allowed in paths");
    if (auto page = console_file(request.method, *path)) {
      route_label = "GET /ui";
      response = std::move(*page);
      context_.metrics->record_request(route_label, response.status, std::chrono::steady_clock::now() - started);
      return response;
    }
    std::vector<store::Id> ids;
    std::vector<std::string> names;
    std::string allow;
    const Route* matched = find_route(request.method, segments, ids, names, allow);
    if (matched == nullptr) {
      if (allow.empty()) fail(ErrorKind::not_found, "not_found", "no route for " + *path);
      response = error_response(
          {ErrorKind::method_not_allowed, "", request.method + " is not allowed here; allowed: " + allow});
      response.headers.emplace_back("Allow", allow);
    } else {
      if (from_memory_only && !matched->info.from_memory) return std::nullopt;
      route_label = matched->info.method + " " + matched->info.path;
      auto caller = check_access(context_.tokens.get(), request, matched->info);
      // Every change this request makes is recorded with its caller, in the change's transaction.
      std::optional<store::AuditScope> audited;
      if (matched->info.method != "GET")
        audited.emplace(store::Actor{caller ? caller->name : "", request.peer, request.method + " " + request.target});
      check_content_type(request, matched->info);
      auto query = detail::parse_query(qmark == std::string_view::npos ? std::string_view{} : target.substr(qmark + 1));
      if (!query)
        fail(ErrorKind::bad_request, "invalid_query", "the query string is malformed, repeats a name or is not UTF-8");
      response = matched->handler(context_, Call{request, std::move(ids), std::move(names), std::move(*query),
                                                 from_memory_only, std::move(caller)});
    }
  } catch (const NotInMemory&) {
    return std::nullopt;
  } catch (const detail::HandlerError& e) {
    response = error_response(e.error);
    if (e.error.kind == ErrorKind::unauthorized) response.headers.emplace_back("WWW-Authenticate", "Bearer");
  } catch (const std::exception& e) {
    response = error_response({ErrorKind::internal, "", e.what()});
  }
  if (response.status >= 400) {
    const json body = json::parse(response.body, nullptr, false);
    context_.metrics->record_error(body.is_object() && body.contains("error") ? body["error"].value("code", "unknown")
                                                                              : "unknown");
  }
  try {
    detail::compress_if_accepted(request, response);
  } catch (const std::exception& e) {
    response = error_response({ErrorKind::internal, "", e.what()});
  }
  context_.metrics->record_request(route_label, response.status, std::chrono::steady_clock::now() - started);
  return response;
}

}  // namespace skinspec::api
