// GET /openapi.json: generated from the route table, so that every route is documented and
// nothing is documented that is not a route.

#include "maps_route.hpp"
#include "models_route.hpp"
#include "render_route.hpp"
#include "skinspec/api/acquisition.hpp"
#include "skinspec/api/router.hpp"
#include "skinspec/fit/model_spec.hpp"
#include "skinspec/fit/termination.hpp"
#include "skinspec/spectral/skin_tone.hpp"
#include "skinspec/version.hpp"

namespace skinspec::api {

using nlohmann::json;

namespace {

// The token a route needs, when the service asks for tokens at all (off loopback, or with
// --token-file).
std::string bearer_description() {
  std::string scopes;
  for (const Scope scope : kScopes) scopes += std::string(scopes.empty() ? "" : " < ") + std::string(to_string(scope));
  return "A named token of skinspecd's token file (docs/security.md), of one scope (" + scopes +
         ": each may do what the ones before it may). An operation's x-skinspec-scope names the least scope "
         "that may call it: 401 without a known token, 403 with a token of a lesser scope.";
}

json ref(const std::string& name) { return {{"$ref", "#/components/schemas/" + name}}; }
json numbers() { return {{"type", "array"}, {"items", {{"type", "number"}}}}; }
json nullable(json type) { return {{"type", json::array({type, "null"})}}; }
json samples() {
  return {{"type", json::array({"object", "null"})},
          {"properties", {{"wavelength_nm", numbers()}, {"values", numbers()}}}};
}

// The names of an enumeration, from its one mapping.
template <typename E>
json names(std::span<const std::pair<E, std::string_view>> mapping) {
  json out = json::array();
  for (const auto& [value, name] : mapping) out.push_back(std::string(name));
  return out;
}

json measurement_job_kind_names() {
  json out = json::array();
  for (const auto kind : kMeasurementJobKinds) out.push_back(std::string(store::to_string(kind)));
  return out;
}

// The parameters of every model: a fit has those of its own.
json params_schema() {
  json props = json::object();
  for (const auto model : kModelKinds)
    for (const auto& spec : model_spec(model).params) props[std::string(spec.name)] = nullable("number");
  return {{"type", "object"}, {"properties", props}};
}

// A skin model's name; `with_default` false where the default is not the service's but the
// session's (a refit).
json model_schema(bool with_default = true) {
  json models = json::array();
  for (const auto model : kModelKinds) models.push_back(std::string(to_string(model)));
  json schema = {{"type", "string"}, {"enum", models}};
  if (with_default) schema["default"] = std::string(to_string(kDefaultModel));
  return schema;
}

// What the spectrum determined (docs/model.md, "What the spectrum determines").
json assessment_fields() {
  const json derived = {{"type", "object"},
                        {"properties",
                         {{"value", nullable("number")},
                          {"stderr", nullable("number")},
                          {"determined", {{"type", "boolean"}}},
                          {"reason", {{"type", "string"}}}}}};
  const json determination = {{"type", "object"},
                              {"properties",
                               {{"determined", {{"type", "boolean"}}},
                                {"reason", {{"type", "string"}}},
                                {"correlated_with", {{"type", "string"}}}}}};
  return {{"determination", {{"type", "object"}, {"additionalProperties", determination}}},
          {"derived",
           {{"type", "object"}, {"properties", {{"oxygen_saturation", derived}, {"blood_volume_fraction", derived}}}}},
          {"correlation",
           {{"type", "object"},
            {"properties",
             {{"params", {{"type", "array"}, {"items", {{"type", "string"}}}}},
              {"matrix", {{"type", "array"}, {"items", {{"type", "array"}, {"items", nullable("number")}}}}}}}}},
          {"note", {{"type", "string"}}},
          {"skin_tone",
           {{"type", "object"},
            {"description", "the measured spectrum's skin tone (docs/model.md, \"Skin tone\")"},
            {"properties",
             {{"ita_deg", {{"type", "number"}}},
              {"ita_class", {{"type", "string"}, {"enum", names(ita_class_names())}}},
              {"melanin_index", nullable("number")},
              {"erythema_index", nullable("number")}}}}},
          {"termination", {{"type", "string"}, {"enum", names(termination_names())}}}};
}

json range_schema(const std::string& description) {
  return {{"type", "object"},
          {"description", description},
          {"properties", {{"min", {{"type", "number"}}}, {"max", {{"type", "number"}}}}}};
}

// What a measurement job may ask of the meter: MeasureRequest's settings, as the meter takes them.
json capabilities_schema() {
  json exposure = range_schema("ms; 0 (adaptive) is always taken");
  exposure["properties"]["max_extended"] = {{"type", json::array({"integer", "null"})},
                                            {"description", "the longest with extended_sensitivity; null: none"}};
  json sync = range_schema("min_hz to max_hz for a frequency");
  // The named modes as a request spells them (sync_json), and "frequency" for a number of hertz.
  const json modes = {sync_json({SyncRequest::Mode::off, 0}), sync_json({SyncRequest::Mode::automatic, 0}),
                      "frequency"};
  sync["properties"]["modes"] = {{"type", "array"}, {"items", {{"type", "string"}, {"enum", modes}}}};
  sync["properties"]["whole_hz"] = {{"type", "boolean"}};
  return {{"type", json::array({"object", "null"})},
          {"description",
           "the settings the identified meter (or the --model) takes; null before a model is known. A job asking "
           "for anything else is refused with 422 naming what is taken"},
          {"properties",
           {{"model", {{"type", "string"}, {"description", "the model whose settings these are"}}},
            {"integration_ms", exposure},
            {"averages", range_schema("measurements the meter averages into each reading")},
            {"sync", sync},
            {"extended_sensitivity", {{"type", "boolean"}}},
            {"apertures",
             {{"type", json::array({"array", "null"})},
              {"items", {{"type", "string"}}},
              {"description", "the names the meter lists (D117); empty: none to choose; null: not read yet"}}}}}};
}

json instrument_schema() {
  json states = names(instrument_state_names());
  states.insert(states.begin(), "none");  // skinspecd started without --device
  return {{"type", "object"},
          {"properties",
           {{"device", nullable("string")},
            {"port", nullable("string")},
            {"state", {{"type", "string"}, {"enum", states}}},
            {"since", {{"type", "string"}, {"format", "date-time"}}},
            {"last_error", nullable("string")},
            {"model",
             {{"type", json::array({"string", "null"})},
              {"description",
               "the model's profile id (pr670, ...); null when not reached yet or a model "
               "skinspec does not know"}}},
            {"reported_model",
             {{"type", json::array({"string", "null"})},
              {"description", "the model as the meter names itself (D111), e.g. PR-730/735"}}},
            {"family", {{"type", json::array({"string", "null"})}, {"description", "pr650, pr6xx or pr7xx"}}},
            {"serial_number", nullable("string")},
            {"firmware", nullable("string")},
            {"grid",
             {{"type", json::array({"object", "null"})},
              {"description", "the meter's native wavelength grid (D120)"},
              {"properties",
               {{"first_nm", {{"type", "integer"}}},
                {"last_nm", {{"type", "integer"}}},
                {"step_nm", {{"type", "integer"}}},
                {"points", {{"type", "integer"}}}}}}},
            {"warnings",
             {{"type", "array"},
              {"items", {{"type", "string"}}},
              {"description", "how the meter was found, where that matters (a forced model, a glued banner ...)"}}},
            {"attempts", {{"type", "integer"}, {"description", "failed connection attempts in a row"}}},
            {"next_attempt_in_ms", nullable("integer")},
            {"running_job", nullable("integer")},
            {"queued", {{"type", "integer"}}},
            {"capabilities", capabilities_schema()}}}};
}

json port_list_schema() {
  const json usb = {
      {"type", json::array({"object", "null"})},
      {"properties",
       {{"vid", {{"type", "string"}}},
        {"pid", {{"type", "string"}}},
        {"serial", {{"type", "string"}}},
        {"manufacturer", {{"type", "string"}}},
        {"product", {{"type", "string"}}},
        {"device_kind",
         {{"type", json::array({"string", "null"})},
          {"description", "photo-research-meter, rs232-adapter, or null for a device skinspec does not know"}}},
        {"device_description", {{"type", json::array({"string", "null"})}}}}}};
  const json port = {{"type", "object"},
                     {"properties",
                      {{"uri", {{"type", "string"}}},
                       {"name", {{"type", "string"}}},
                       {"description", {{"type", "string"}}},
                       {"transport", {{"type", "string"}}},
                       {"usb", usb}}}};
  return {{"type", "object"}, {"properties", {{"ports", {{"type", "array"}, {"items", port}}}}}};
}

json schemas() {
  json fit_fields = {{"name", {{"type", "string"}}},
                     {"model", model_schema()},
                     {"site", {{"type", "string"}}},
                     {"params", params_schema()},
                     {"stderr", params_schema()},
                     {"rmse", {{"type", "number"}}},
                     {"max_abs_error", {{"type", "number"}}},
                     {"delta_e00_d65", {{"type", "number"}}},
                     {"iterations", {{"type", "integer"}}},
                     {"converged", {{"type", "boolean"}}},
                     {"samples_ignored", {{"type", "integer"}}},
                     {"wavelength_nm", numbers()},
                     {"measured", numbers()},
                     {"fitted", numbers()}};
  fit_fields.update(assessment_fields());
  json stored_fit = fit_fields;
  stored_fit["id"] = {{"type", "integer"}};
  stored_fit["measurement_id"] = {{"type", "integer"}};
  stored_fit["options"] = {{"type", "object"}};
  stored_fit["model_version"] = {{"type", "string"}};
  stored_fit["tables_digest"] = {{"type", "string"}};
  stored_fit["constants_digest"] = {{"type", "string"}};
  stored_fit["solver_summary"] = {{"type", "string"}};
  stored_fit["created_at"] = {{"type", "string"}, {"format", "date-time"}};
  const json session_props = {
      {"id", {{"type", "integer"}}},
      {"subject", {{"type", "string"}}},
      {"site", {{"type", "string"}}},
      {"operator", {{"type", "string"}}},
      {"notes", {{"type", "string"}}},
      {"model", model_schema()},
      {"bench",
       {{"type", "string"}, {"description", "the bench it was opened on; empty for sessions from before benches"}}},
      {"white_standard_id", nullable("integer")},
      {"state", {{"type", "string"}, {"enum", names(store::session_state_names())}}},
      {"created_at", {{"type", "string"}, {"format", "date-time"}}},
      {"updated_at", {{"type", "string"}, {"format", "date-time"}}},
      {"ended_at", nullable("string")}};
  json fit_list = {{"type", "object"}, {"properties", {{"fits", {{"type", "array"}, {"items", ref("FitResult")}}}}}};
  json fit_response = {{"oneOf", json::array({ref("FitResult"), fit_list})}};
  json detail_props = session_props;
  detail_props["measurements"] = {{"type", "array"}, {"items", ref("Measurement")}};
  detail_props["fits"] = {{"type", "array"}, {"items", ref("Fit")}};
  detail_props["rejected_readings"] = {{"type", "array"}, {"items", ref("RejectedReading")}};
  const json site = {
      {"type", "object"},
      {"properties",
       {{"name", {{"type", "string"}}}, {"epidermis_mm", {{"type", "number"}}}, {"dermis_mm", {{"type", "number"}}}}}};
  const json site_list = {{"type", "object"}, {"properties", {{"sites", {{"type", "array"}, {"items", site}}}}}};
  return {
      {"Error",
       {{"type", "object"},
        {"required", {"error"}},
        {"properties",
         {{"error",
           {{"type", "object"},
            {"required", {"code", "message"}},
            {"properties", {{"code", {{"type", "string"}}}, {"message", {{"type", "string"}}}}}}}}}}},
      {"Health",
       {{"type", "object"},
        {"properties",
         {{"status", {{"type", "string"}}},
          {"version", {{"type", "string"}}},
          {"database", {{"type", "object"}}},
          {"model", {{"type", "object"}}},
          {"instrument", ref("Instrument")}}}}},
      {"SiteList", site_list},
      {"MapRequest",
       {{"type", "object"},
        {"required", {"path"}},
        {"additionalProperties", false},
        {"properties",
         {{"path", {{"type", "string"}, {"description", "the cube, relative to skinspecd's --data-dir"}}},
          {"name", {{"type", "string"}, {"maxLength", 100}}},
          {"model", model_schema()},
          {"site", {{"type", "string"}, {"default", "forearm"}}},
          {"session_id", {{"type", "integer"}, {"minimum", 1}}},
          {"white_roi", {{"type", "array"}, {"items", {{"type", "integer"}}}, {"minItems", 4}, {"maxItems", 4}}},
          {"white", {{"type", "string"}, {"description", "a white panel's cube in the data directory"}}},
          {"dark", {{"type", "string"}, {"description", "a dark cube in the data directory"}}},
          {"white_reflectance", {{"type", "number"}, {"default", 0.99}}}}}}},
      {"Map",
       {{"type", "object"},
        {"properties",
         {{"id", {{"type", "integer"}}},
          {"job_id", {{"type", "integer"}}},
          {"session_id", nullable("integer")},
          {"name", {{"type", "string"}}},
          {"created_at", {{"type", "string"}}},
          {"summary", {{"type", "object"}, {"description", "summary.json of `skinspec map` (docs/maps.md)"}}},
          {"bands",
           {{"type", "array"},
            {"items",
             {{"type", "object"}, {"properties", {{"name", {{"type", "string"}}}, {"unit", {{"type", "string"}}}}}}}}},
          {"interleave", {{"type", "string"}}},
          {"data_type", {{"type", "string"}}},
          {"byte_order", {{"type", "string"}}},
          {"data_bytes", {{"type", "integer"}}},
          {"links", {{"type", "object"}}}}}}},
      {"MapPixel",
       {{"type", "object"},
        {"properties",
         {{"x", {{"type", "integer"}}},
          {"y", {{"type", "integer"}}},
          {"mask", {{"type", "string"}}},
          {"values", {{"type", "object"}, {"description", "each answer band's value, null where not determined"}}},
          {"wavelength_nm", numbers()},
          {"measured", {{"type", "array"}, {"items", nullable("number")}}},
          {"fit",
           {{"type", json::array({"object", "null"})}, {"description", "the fit of a skin pixel's spectrum"}}}}}}},
      {"MapList", {{"type", "object"}, {"properties", {{"maps", {{"type", "array"}, {"items", ref("Map")}}}}}}},
      {"AuditEntry",
       {{"type", "object"},
        {"properties",
         {{"id", {{"type", "integer"}}},
          {"at", {{"type", "string"}, {"format", "date-time"}}},
          {"token",
           {{"type", json::array({"string", "null"})},
            {"description", "the token's name; null: no token was asked for"}}},
          {"address", {{"type", "string"}}},
          {"request", {{"type", "string"}, {"description", "method and target"}}},
          {"change", {{"type", "string"}, {"description", "the change the store made"}}}}}}},
      {"AuditList",
       {{"type", "object"},
        {"properties",
         {{"entries", {{"type", "array"}, {"items", ref("AuditEntry")}}},
          {"next_before",
           {{"type", json::array({"integer", "null"})},
            {"description", "the before= of the next page; null: none"}}}}}}},
      {"ModelList", detail::model_list_schema()},
      {"OpenApi", {{"type", "object"}}},
      {"FitRequest",
       {{"type", "object"},
        {"required", {"wavelength_nm"}},
        {"additionalProperties", false},
        {"properties",
         {{"wavelength_nm", numbers()},
          {"reflectance", numbers()},
          {"spectra", {{"type", "object"}, {"additionalProperties", numbers()}}},
          {"site", {{"type", "string"}, {"default", "forearm"}}},
          {"name", {{"type", "string"}}},
          {"model", model_schema()},
          {"lateral_diffusion", {{"type", "boolean"}, {"default", true}}}}}}},
      {"FitResult", {{"type", "object"}, {"properties", fit_fields}}},
      {"FitResponse", fit_response},
      {"Fit", {{"type", "object"}, {"properties", stored_fit}}},
      {"RefitRequest",
       {{"type", "object"},
        {"additionalProperties", false},
        {"properties",
         {{"site", {{"type", "string"}}},
          {"model", model_schema(false)},
          {"lateral_diffusion", {{"type", "boolean"}}}}}}},
      {"WhiteStandardCreate",
       {{"type", "object"},
        {"required", {"name", "wavelength_nm", "reflectance"}},
        {"additionalProperties", false},
        {"properties",
         {{"name", {{"type", "string"}}},
          {"certificate", {{"type", "string"}}},
          {"wavelength_nm", numbers()},
          {"reflectance", numbers()}}}}},
      {"WhiteStandard",
       {{"type", "object"},
        {"properties",
         {{"id", {{"type", "integer"}}},
          {"name", {{"type", "string"}}},
          {"certificate", {{"type", "string"}}},
          {"wavelength_nm", numbers()},
          {"reflectance", numbers()},
          {"created_at", {{"type", "string"}}}}}}},
      {"WhiteStandardList",
       {{"type", "object"},
        {"properties", {{"white_standards", {{"type", "array"}, {"items", ref("WhiteStandard")}}}}}}},
      {"SessionCreate",
       {{"type", "object"},
        {"required", {"site", "subject"}},
        {"additionalProperties", false},
        {"properties",
         {{"site", {{"type", "string"}}},
          {"subject", {{"type", "string"}}},
          {"operator", {{"type", "string"}}},
          {"white_standard_id", {{"type", "integer"}}},
          {"notes", {{"type", "string"}}},
          {"model", model_schema()}}}}},
      {"SessionUpdate",
       {{"type", "object"},
        {"additionalProperties", false},
        {"properties",
         {{"notes", {{"type", "string"}}},
          {"close", {{"type", "boolean"}}},
          {"state", {{"type", "string"}, {"enum", names(store::session_state_names())}}}}}}},
      {"Session", {{"type", "object"}, {"properties", session_props}}},
      {"SessionDetail", {{"type", "object"}, {"properties", detail_props}}},
      {"SessionPage",
       {{"type", "object"},
        {"properties",
         {{"sessions", {{"type", "array"}, {"items", ref("Session")}}}, {"next_cursor", nullable("integer")}}}}},
      {"Instrument", instrument_schema()},
      {"PortList", port_list_schema()},
      {"BenchList",
       {{"type", "object"},
        {"properties",
         {{"bench", {{"type", "string"}, {"description", "the bench of the skinspecd answering"}}},
          {"benches",
           {{"type", "array"},
            {"items",
             {{"type", "object"},
              {"properties",
               {{"name", {{"type", "string"}}},
                {"host", {{"type", "string"}}},
                {"pid", {{"type", "integer"}}},
                {"started_at", {{"type", "string"}, {"format", "date-time"}}},
                {"heartbeat_at", {{"type", "string"}, {"format", "date-time"}}},
                {"lease_s",
                 {{"type", "number"},
                  {"description", "silent longer than this after its heartbeat, a bench counts as gone"}}},
                {"state",
                 {{"type", "string"},
                  {"enum", names(store::bench_state_names())},
                  {"description", "stopped: it stopped cleanly; silent: not heard within its lease"}}},
                {"this", {{"type", "boolean"}}},
                {"instrument", ref("Instrument")}}}}}}}}}}},
      {"MeasureRequest",
       {{"type", "object"},
        {"required", {"kind"}},
        {"additionalProperties", false},
        {"properties",
         {{"kind", {{"type", "string"}, {"enum", measurement_job_kind_names()}}},
          {"count", {{"type", "integer"}, {"minimum", 1}, {"maximum", 100}, {"default", 1}}},
          {"label", {{"type", "string"}}},
          {"integration_ms",
           {{"type", "integer"},
            {"minimum", 0},
            {"maximum", 3600000},
            {"default", 0},
            {"description",
             "0: adaptive; otherwise within the meter's exposure range (PR-650 10-6000 ms, PR-7xx 12-120000 ms), "
             "refused with 422 out_of_range"}}},
          // Each held to the Instrument's capabilities: 422 naming what the meter takes.
          {"averages",
           {{"type", "integer"},
            {"default", 1},
            {"description", "measurements the meter averages into each reading (1-99)"}}},
          {"sync",
           {{"type", json::array({"string", "number"})},
            {"default", "off"},
            {"description", "off, auto (the meter measures the flicker and syncs to it), or a frequency in Hz"}}},
          {"extended_sensitivity",
           {{"type", "boolean"},
            {"default", false},
            {"description", "the longer exposure range (PR-670, PR-680, PR-7xx)"}}},
          {"aperture",
           {{"type", "string"},
            {"description", "an aperture by the name the meter lists (capabilities.apertures); absent: as set"}}}}}}},
      {"Job",
       {{"type", "object"},
        {"properties",
         {{"id", {{"type", "integer"}}},
          {"job_id", {{"type", "integer"}}},
          {"kind", {{"type", "string"}, {"enum", names(job_kind_names())}}},
          {"session_id", nullable("integer")},
          {"bench", {{"type", "string"}, {"description", "the bench that runs it"}}},
          {"state", {{"type", "string"}, {"enum", names(store::job_state_names())}}},
          {"position",
           {{"type", json::array({"integer", "null"})},
            {"minimum", 0},
            {"description", "place in the queue: 1 is next, 0 is running; null once finished"}}},
          {"progress", ref("JobProgress")},
          {"error",
           {{"oneOf", {ref("JobError"), {{"type", "null"}}}},
            {"description", "why it failed or was cancelled; null otherwise"}}},
          {"request", {{"type", "object"}}},
          {"result", {{"type", "object"}}},
          {"idempotency_key", nullable("string")},
          {"created_at", {{"type", "string"}}},
          {"started_at", nullable("string")},
          {"finished_at", nullable("string")}}}}},
      {"JobError",
       {{"type", "object"},
        {"required", {"code", "message"}},
        {"properties",
         {{"code", {{"type", "string"}, {"enum", names(store::job_error_code_names())}}},
          {"message", {{"type", "string"}}}}}}},
      {"JobProgress",
       {{"type", "object"},
        {"required", {"phase", "fraction"}},
        {"description",
         "a measurement counts readings (readings_done, readings_total) and, while it measures, gives the "
         "seconds left at the meter's longest exposure, an upper bound (remaining_s); an import or a refit "
         "counts spectra (spectra_done, spectra_total) and gives the seconds left at the rate so far "
         "(remaining_s)"},
        {"properties",
         {{"phase", {{"type", "string"}, {"enum", names(job_phase_names())}}},
          {"readings_done", {{"type", "integer"}, {"minimum", 0}}},
          {"readings_total", {{"type", "integer"}, {"minimum", 1}}},
          {"spectra_done", {{"type", "integer"}, {"minimum", 0}}},
          {"spectra_total", {{"type", "integer"}, {"minimum", 0}}},
          {"remaining_s", nullable("number")},
          {"fraction", {{"type", "number"}, {"minimum", 0}, {"maximum", 1}}}}}}},
      {"RefitJobRequest",
       {{"type", "object"},
        {"additionalProperties", false},
        {"properties",
         {{"model", model_schema()},
          {"session_id",
           {{"type", "integer"},
            {"minimum", 1},
            {"description", "only this session's measurements; every session's when absent"}}}}}}},
      {"RejectedReading",
       {{"type", "object"},
        {"properties",
         {{"id", {{"type", "integer"}}},
          {"session_id", {{"type", "integer"}}},
          {"job_id", nullable("integer")},
          {"instrument_id", nullable("integer")},
          {"attempt", {{"type", "integer"}}},
          {"quality", {{"type", "object"}}},
          {"reason", {{"type", "string"}}},
          {"raw_reply_base64", {{"type", "string"}, {"contentEncoding", "base64"}}},
          {"measured_at", {{"type", "string"}}},
          {"created_at", {{"type", "string"}}}}}}},
      {"Measurement",
       {{"type", "object"},
        {"properties",
         {{"id", {{"type", "integer"}}},
          {"session_id", {{"type", "integer"}}},
          {"kind", {{"type", "string"}}},
          {"label", {{"type", "string"}}},
          {"quality", {{"type", "object"}}},
          {"units", {{"type", "string"}}},
          {"reading_count", {{"type", "integer"}}},
          {"radiance", samples()},
          {"radiance_sd", samples()},
          {"reflectance", samples()},
          {"warnings", {{"type", "array"}, {"items", {{"type", "string"}}}}},
          {"provenance",
           {{"type", "object"},
            {"description",
             "settings: for a measured one integration_ms (0 adaptive), count, averages, sync (as the meter "
             "did it), extended_sensitivity, aperture, exposure_used_ms (per reading: the exposure used, from D13 "
             "under adaptive exposure; null where the meter does not say), rejected_readings"}}},
          {"created_at", {{"type", "string"}}},
          {"fit_id", nullable("integer")},
          {"colour",
           {{"type", json::array({"object", "null"})},
            {"description", "GET of one measurement only: xyz, lab and 8-bit srgb under D65 and A"}}}}}}},
  };
}

json list_parameters() {
  auto q = [](const char* name, json schema, const char* description) {
    return json{{"name", name}, {"in", "query"}, {"required", false}, {"schema", schema}, {"description", description}};
  };
  return json::array(
      {q("site", {{"type", "string"}}, "body site"),
       q("state", {{"type", "string"}, {"enum", names(store::session_state_names())}}, "session state"),
       q("from", {{"type", "string"}, {"format", "date-time"}}, "created at or after (UTC)"),
       q("to", {{"type", "string"}, {"format", "date-time"}}, "created before (UTC)"),
       q("cursor", {{"type", "integer"}}, "next_cursor of the previous page"),
       q("limit", {{"type", "integer"}, {"minimum", 1}, {"maximum", 1000}, {"default", 50}}, "page size")});
}

json import_parameters() {
  return json::array(
      {{{"name", "format"},
        {"in", "query"},
        {"required", false},
        {"schema", {{"type", "string"}, {"enum", {"csv", "cgats"}}}},
        {"description", "recognised from the content when absent: CGATS when it starts with a CGATS file type"}},
       {{"name", "scale"},
        {"in", "query"},
        {"required", false},
        {"schema", {{"type", "string"}, {"enum", {"auto", "fraction", "percent"}}, {"default", "auto"}}},
        {"description",
         "how a CSV file writes reflectance; auto: percent when at least half its values exceed 1.5 "
         "(docs/store.md, \"Imports\"); a CGATS file gives its own (SPECTRAL_NORM)"}},
       {{"name", "name"},
        {"in", "query"},
        {"required", false},
        {"schema", {{"type", "string"}, {"maxLength", 255}}},
        {"description", "the file's name, kept with each spectrum as provenance (default: upload)"}}});
}

json error_reply(const char* description) {
  return {{"description", description}, {"content", {{"application/json", {{"schema", ref("Error")}}}}}};
}

}  // namespace

json Router::openapi_document() {
  json paths = json::object();
  for (const RouteInfo& r : routes()) {
    json op = {{"summary", r.summary}, {"operationId", r.method + " " + r.path}};
    json content;
    if (r.response_schema == "text/csv" || r.response_schema == "text/plain" ||
        r.response_schema == "text/event-stream" || r.response_schema == "application/jsonl")
      content = {{r.response_schema, {{"schema", {{"type", "string"}}}}}};
    else if (r.response_schema == "image/png" || r.response_schema == "application/octet-stream")
      content = {{r.response_schema, {{"schema", {{"type", "string"}, {"contentMediaType", r.response_schema}}}}}};
    else content = {{"application/json", {{"schema", ref(r.response_schema)}}}};
    op["responses"] = {{std::to_string(r.success_status), {{"description", "success"}, {"content", content}}},
                       {"4XX", error_reply("the request was refused")},
                       {"5XX", error_reply("the service could not answer")}};
    if (r.request_schema == "text/plain")
      op["requestBody"] = {{"required", true},
                           {"description", "the file's bytes, with any text/* content type"},
                           {"content", {{"text/plain", {{"schema", {{"type", "string"}}}}}}}};
    else if (r.upload)
      op["requestBody"] = {{"required", true},
                           {"description", "a cube named in the data directory (JSON), or the cube's file"},
                           {"content",
                            {{"application/json", {{"schema", ref(r.request_schema)}}},
                             {"application/octet-stream", {{"schema", {{"type", "string"}, {"format", "binary"}}}}}}}};
    else if (!r.request_schema.empty())
      op["requestBody"] = {{"required", r.path != "/api/v1/measurements/{id}/fit"},
                           {"content", {{"application/json", {{"schema", ref(r.request_schema)}}}}}};
    json params = json::array();
    if (r.path.find("{id}") != std::string::npos)
      params.push_back(
          {{"name", "id"}, {"in", "path"}, {"required", true}, {"schema", {{"type", "integer"}, {"minimum", 1}}}});
    if (r.method == "GET" && r.path == "/api/v1/sessions") params = list_parameters();
    if (r.path == "/api/v1/fits/{id}/render.png")
      for (const auto& p : detail::render_query_parameters()) params.push_back(p);
    if (r.path == "/api/v1/sessions/{id}/imports")
      for (const auto& p : import_parameters()) params.push_back(p);
    if (r.method == "POST" && r.path == "/api/v1/maps")
      for (const auto& p : detail::map_upload_parameters()) params.push_back(p);
    if (r.path == "/api/v1/maps/{id}/pixel")
      for (const char* axis : {"x", "y"})
        params.push_back(
            {{"name", axis}, {"in", "query"}, {"required", true}, {"schema", {{"type", "integer"}, {"minimum", 0}}}});
    if (r.method == "GET" && r.path == "/api/v1/maps")
      params = json::array(
          {{{"name", "session_id"}, {"in", "query"}, {"required", false}, {"schema", {{"type", "integer"}}}},
           {{"name", "limit"},
            {"in", "query"},
            {"required", false},
            {"schema", {{"type", "integer"}, {"minimum", 1}, {"maximum", 1000}, {"default", 100}}}}});
    if (r.path == "/api/v1/audit")
      params =
          json::array({{{"name", "before"}, {"in", "query"}, {"required", false}, {"schema", {{"type", "integer"}}}},
                       {{"name", "limit"},
                        {"in", "query"},
                        {"required", false},
                        {"schema", {{"type", "integer"}, {"minimum", 1}, {"maximum", 1000}, {"default", 100}}}}});
    if (r.path.find("{parameter}") != std::string::npos)
      params.push_back({{"name", "parameter"},
                        {"in", "path"},
                        {"required", true},
                        {"schema", {{"type", "string"}}},
                        {"description", "a parameter of the map's model"}});
    if (!params.empty()) op["parameters"] = params;
    // OpenAPI's own scopes are OAuth's; a bearer scheme has none, so the scope a token needs is
    // told by an extension of each operation.
    if (r.needs_token) {
      op["security"] = json::array({{{"bearer", json::array()}}});
      op["x-skinspec-scope"] = to_string(r.scope);
    } else {
      op["security"] = json::array();
    }
    std::string method = r.method;
    for (char& ch : method) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    paths[r.path][method] = op;
  }
  return {{"openapi", "3.1.0"},
          {"info",
           {{"title", "skinspecd"},
            {"version", kVersion},
            {"description", "Stored skin spectra, sessions and fits of the two-layer skin model"}}},
          {"paths", paths},
          {"components",
           {{"schemas", schemas()},
            {"securitySchemes",
             {{"bearer", {{"type", "http"}, {"scheme", "bearer"}, {"description", bearer_description()}}}}}}}};
}

}  // namespace skinspec::api
