#pragma once
// The routes of skin maps (docs/api.md, "Maps"): POST /api/v1/maps reads what is asked here and
// queues a job (map_jobs.*); the GETs serve a stored map's summary, pictures and answer cube,
// each of which never changes once stored.

#include <map>
#include <string>

#include <nlohmann/json.hpp>

#include "map_jobs.hpp"
#include "skinspec/api/router.hpp"
#include "skinspec/fit/fitter.hpp"
#include "skinspec/store/store.hpp"

namespace skinspec::api::detail {

// What POST /api/v1/maps asks: a JSON body naming a cube in the data directory ({"path": ...}),
// or an uploaded file with the same fields in the query. Malformed fields throw HandlerError.
MapAsk map_ask_of_json(const std::string& body);
MapAsk map_ask_of_upload(std::string body, const std::map<std::string, std::string>& query);

nlohmann::json map_json(const store::Map& map);
// GET /api/v1/maps?session_id=&limit=
nlohmann::json map_list_json(const store::Store& store, const std::map<std::string, std::string>& query);

// A stored map's parts, tagged by the map (they never change): its picture of a parameter, its
// answer cube's ENVI header and data.
Response map_picture_response(const Request& request, const store::Store& store, store::Id id,
                              const std::string& parameter);
Response map_header_response(const Request& request, const store::Store& store, store::Id id);
Response map_cube_response(const Request& request, const store::Store& store, store::Id id);

// GET /api/v1/maps/{id}/pixel?x=&y=: the pixel's answers, its measured reflectance as the map
// kept it, and, for a skin pixel, the fit of that spectrum (fit_to_json's fields) with the map's
// model and site, which gives the fitted spectrum.
nlohmann::json map_pixel_json(const store::Store& store, const Fitter& fitter, store::Id id,
                              const std::map<std::string, std::string>& query);

// The query parameters of an upload, as OpenAPI parameter objects.
nlohmann::json map_upload_parameters();

}  // namespace skinspec::api::detail
