// The store's reads, each on a pooled read connection: a read of one statement on its own (its
// own snapshot), a read of several in one read transaction, so that a session and its
// measurements and fits come from the same snapshot.

#include <fmt/format.h>

#include <algorithm>
#include <map>
#include <vector>

#include "codec.hpp"
#include "map_pieces.hpp"
#include "rows.hpp"
#include "store_impl.hpp"

namespace skinspec::store {

using detail::all;
using detail::Connection;
using detail::fail;
using Kind = StoreError::Kind;

namespace {

// The one record `sql` selects by id, or not_found naming `what`.
template <typename Read>
auto one(Connection& c, const std::string& sql, Id id, std::string_view what, Read read) {
  auto row = c.prepare(sql);
  row.bind(id);
  if (!row.step()) fail(Kind::not_found, fmt::format("{} {} does not exist", what, id));
  return read(row);
}

std::string select_by_id(std::string_view columns, std::string_view table) {
  return fmt::format("SELECT {} FROM {} WHERE id = ?1", columns, table);
}

Session session_in(Connection& c, Id id) {
  static const std::string sql = select_by_id(detail::kSessionColumns, "sessions");
  return one(c, sql, id, "session", detail::read_session);
}

}  // namespace

Result<Instrument> Store::instrument(Id id) const {
  return impl_->read_one("reading an instrument", [&](Connection& c) {
    static const std::string sql = select_by_id(detail::kInstrumentColumns, "instruments");
    return one(c, sql, id, "instrument", detail::read_instrument);
  });
}

Result<std::vector<Instrument>> Store::instruments() const {
  return impl_->read_one("listing instruments", [&](Connection& c) {
    static const std::string sql = fmt::format("SELECT {} FROM instruments ORDER BY id", detail::kInstrumentColumns);
    return all(c, sql, detail::read_instrument);
  });
}

Result<WhiteStandard> Store::white_standard(Id id) const {
  return impl_->read_one("reading a white standard", [&](Connection& c) {
    static const std::string sql = select_by_id(detail::kWhiteStandardColumns, "white_standards");
    return one(c, sql, id, "white standard", detail::read_white_standard);
  });
}

Result<std::vector<WhiteStandard>> Store::white_standards() const {
  return impl_->read_one("listing white standards", [&](Connection& c) {
    static const std::string sql =
        fmt::format("SELECT {} FROM white_standards ORDER BY id", detail::kWhiteStandardColumns);
    return all(c, sql, detail::read_white_standard);
  });
}

Result<Session> Store::session(Id id) const {
  return impl_->read_one("reading a session", [&](Connection& c) { return session_in(c, id); });
}

Result<SessionDetail> Store::session_detail(Id id) const {
  return impl_->read(fmt::format("reading session {}", id), [&](Connection& c) {
    static const std::string measurements =
        fmt::format("SELECT {} FROM measurements WHERE session_id = ?1 AND {} ORDER BY id", detail::kMeasurementColumns,
                    detail::kPublished);
    static const std::string fits = fmt::format(
        "SELECT {} FROM fits WHERE measurement_id IN (SELECT id FROM measurements WHERE session_id = ?1 AND {}) "
        "ORDER BY id",
        detail::kFitColumns, detail::kPublished);
    static const std::string rejected = fmt::format(
        "SELECT {} FROM rejected_readings WHERE session_id = ?1 ORDER BY id", detail::kRejectedReadingColumns);
    SessionDetail detail;
    detail.session = session_in(c, id);
    detail.measurements = all(c, measurements, detail::read_measurement, id);
    detail.fits = all(c, fits, detail::read_fit, id);
    detail.rejected_readings = all(c, rejected, detail::read_rejected_reading, id);
    return detail;
  });
}

Result<SessionPage> Store::sessions(const SessionFilter& filter) const {
  return impl_->read_one("listing sessions", [&](Connection& c) {
    if (filter.limit < 1 || filter.limit > 1000)
      fail(Kind::invalid_argument, fmt::format("limit {} is outside 1-1000", filter.limit));
    // Each filter is off when its parameter is NULL (named first in each, so that its column
    // gives the parameter its type). One row beyond the page says whether there is a next one.
    static const std::string sql = fmt::format(
        "SELECT {} FROM sessions WHERE (site = ?1 OR ?1 IS NULL) AND (state = ?2 OR ?2 IS NULL) "
        "AND (created_at >= ?3 OR ?3 IS NULL) AND (created_at < ?4 OR ?4 IS NULL) AND (id < ?5 OR ?5 IS NULL) "
        "ORDER BY id DESC LIMIT ?6",
        detail::kSessionColumns);
    const auto state = filter.state ? std::optional<std::string_view>(to_string(*filter.state)) : std::nullopt;
    SessionPage page;
    page.sessions = all(c, sql, detail::read_session, filter.site, state, filter.created_from, filter.created_before,
                        filter.cursor, filter.limit + 1);
    if (page.sessions.size() > static_cast<std::size_t>(filter.limit)) {
      page.sessions.pop_back();
      page.next_cursor = page.sessions.back().id;
    }
    return page;
  });
}

Result<Measurement> Store::measurement(Id id) const {
  return impl_->read_one("reading a measurement", [&](Connection& c) {
    static const std::string sql =
        fmt::format("{} AND {}", select_by_id(detail::kMeasurementColumns, "measurements"), detail::kPublished);
    return one(c, sql, id, "measurement", detail::read_measurement);
  });
}

Result<std::optional<Measurement>> Store::latest_measurement(Id session_id, MeasurementKind kind) const {
  return impl_->read("reading the latest measurement", [&](Connection& c) {
    session_in(c, session_id);
    static const std::string sql =
        fmt::format("SELECT {} FROM measurements WHERE session_id = ?1 AND kind = ?2 AND {} ORDER BY id DESC LIMIT 1",
                    detail::kMeasurementColumns, detail::kPublished);
    auto row = c.prepare(sql);
    row.bind(session_id, to_string(kind));
    return row.step() ? std::optional<Measurement>(detail::read_measurement(row)) : std::nullopt;
  });
}

Result<Fit> Store::fit(Id id) const {
  return impl_->read_one("reading a fit", [&](Connection& c) {
    static const std::string sql =
        fmt::format("{} AND EXISTS (SELECT 1 FROM measurements WHERE id = fits.measurement_id AND {})",
                    select_by_id(detail::kFitColumns, "fits"), detail::kPublished);
    return one(c, sql, id, "fit", detail::read_fit);
  });
}

Result<std::vector<Fit>> Store::fits_of_measurement(Id measurement_id) const {
  return impl_->read("listing fits", [&](Connection& c) {
    static const std::string exists =
        fmt::format("SELECT 1 FROM measurements WHERE id = ?1 AND {}", detail::kPublished);
    one(c, exists, measurement_id, "measurement", [](const detail::Statement&) { return 0; });
    static const std::string sql =
        fmt::format("SELECT {} FROM fits WHERE measurement_id = ?1 ORDER BY id", detail::kFitColumns);
    return all(c, sql, detail::read_fit, measurement_id);
  });
}

namespace {

// The measurements of a RefitQuery: ?1-?4 the maker, ?5 the session or NULL. (Unqualified
// columns of the outer SELECT are the measurement's.)
const std::string kToRefit = fmt::format(
    "FROM measurements m WHERE m.reflectance IS NOT NULL AND (m.session_id = ?5 OR ?5 IS NULL) AND {} AND NOT EXISTS "
    "(SELECT 1 FROM fits f WHERE f.measurement_id = m.id AND f.model = ?1 AND f.model_version = ?2 AND "
    "f.tables_digest = ?3 AND f.constants_digest = ?4)",
    detail::kPublished);

void check_refit_query(const RefitQuery& query) {
  if (query.limit < 1 || query.limit > 10000)
    fail(Kind::invalid_argument, fmt::format("a refit's page of {} measurements is not 1 to 10000", query.limit));
}

}  // namespace

Result<std::vector<Measurement>> Store::measurements_to_refit(const RefitQuery& query) const {
  return impl_->read_one("listing measurements to refit", [&](Connection& c) {
    check_refit_query(query);
    static const std::string sql =
        fmt::format("SELECT {} {} AND m.id > ?6 ORDER BY m.id LIMIT ?7", detail::kMeasurementColumns, kToRefit);
    const auto& by = query.made_by;
    return all(c, sql, detail::read_measurement, by.model, by.model_version, by.tables_digest, by.constants_digest,
               query.session_id, query.after_id, query.limit);
  });
}

Result<std::int64_t> Store::count_measurements_to_refit(const RefitQuery& query) const {
  return impl_->read_one("counting measurements to refit", [&](Connection& c) {
    static const std::string sql = fmt::format("SELECT count(*) {}", kToRefit);
    const auto& by = query.made_by;
    auto row = c.prepare(sql);
    row.bind(by.model, by.model_version, by.tables_digest, by.constants_digest, query.session_id);
    row.step();
    return row.integer(0);
  });
}

Result<RejectedReading> Store::rejected_reading(Id id) const {
  return impl_->read_one("reading a rejected reading", [&](Connection& c) {
    static const std::string sql = select_by_id(detail::kRejectedReadingColumns, "rejected_readings");
    return one(c, sql, id, "rejected reading", detail::read_rejected_reading);
  });
}

Result<Job> Store::job(Id id) const {
  return impl_->read_one("reading a job", [&](Connection& c) {
    static const std::string sql = select_by_id(detail::kJobColumns, "jobs");
    return one(c, sql, id, "job", detail::read_job);
  });
}

Result<std::optional<Job>> Store::job_by_idempotency_key(const std::string& key) const {
  return impl_->read_one("finding a job", [&](Connection& c) {
    static const std::string sql = fmt::format("SELECT {} FROM jobs WHERE idempotency_key = ?1", detail::kJobColumns);
    auto row = c.prepare(sql);
    row.bind(key);
    return row.step() ? std::optional<Job>(detail::read_job(row)) : std::nullopt;
  });
}

Result<std::vector<Job>> Store::jobs(std::optional<Id> session_id, int limit) const {
  return impl_->read_one("listing jobs", [&](Connection& c) {
    if (limit < 1 || limit > 1000) fail(Kind::invalid_argument, fmt::format("limit {} is outside 1-1000", limit));
    static const std::string sql = fmt::format(
        "SELECT {} FROM jobs WHERE (session_id = ?1 OR ?1 IS NULL) ORDER BY id DESC LIMIT ?2", detail::kJobColumns);
    return all(c, sql, detail::read_job, session_id, limit);
  });
}

namespace {

// The maps `sql` selects with `args`, and the names of their pictures, which `pictures` selects
// as (map_id, parameter) in the order stored, with the same `args`.
template <typename... Args>
std::vector<Map> maps_in(Connection& c, const std::string& sql, const std::string& pictures, const Args&... args) {
  auto maps = all(c, sql, detail::read_map, args...);
  std::map<Id, Map*> by_id;
  for (auto& map : maps) by_id[map.id] = &map;
  auto rows = c.prepare(pictures);
  rows.bind(args...);
  while (rows.step())
    if (const auto found = by_id.find(rows.integer(0)); found != by_id.end())
      found->second->pictures.push_back(rows.text(1));
  return maps;
}

}  // namespace

Result<Map> Store::map(Id id) const {
  return impl_->read("reading a map", [&](Connection& c) {
    static const std::string sql = select_by_id(detail::kMapColumns, "maps");
    static const std::string pictures = "SELECT map_id, parameter FROM map_pictures WHERE map_id = ?1 ORDER BY ordinal";
    auto maps = maps_in(c, sql, pictures, id);
    if (maps.empty()) fail(Kind::not_found, fmt::format("map {} does not exist", id));
    return std::move(maps.front());
  });
}

Result<std::vector<Map>> Store::maps(std::optional<Id> session_id, int limit) const {
  return impl_->read("listing maps", [&](Connection& c) {
    if (limit < 1 || limit > 1000) fail(Kind::invalid_argument, fmt::format("limit {} is outside 1-1000", limit));
    static const std::string page = "FROM maps WHERE (session_id = ?1 OR ?1 IS NULL) ORDER BY id DESC LIMIT ?2";
    static const std::string sql = fmt::format("SELECT {} {}", detail::kMapColumns, page);
    static const std::string pictures = fmt::format(
        "SELECT map_id, parameter FROM map_pictures WHERE map_id IN (SELECT id {}) ORDER BY map_id, ordinal", page);
    return maps_in(c, sql, pictures, session_id, limit);
  });
}

Result<std::string> Store::map_picture(Id id, std::string_view parameter) const {
  return impl_->read_one("reading a map's picture", [&](Connection& c) {
    // No row: no such map; a NULL: no such picture of it.
    auto row = c.prepare(
        "SELECT p.png FROM maps m LEFT JOIN map_pictures p ON p.map_id = m.id AND p.parameter = ?2 WHERE m.id = ?1");
    row.bind(id, parameter);
    if (!row.step()) fail(Kind::not_found, fmt::format("map {} does not exist", id));
    if (row.is_null(0)) fail(Kind::not_found, fmt::format("map {} has no picture of '{}'", id, parameter));
    return row.blob(0);
  });
}

namespace {

// The size of a part of map `id`'s data; its pieces must be those the size makes: corrupt
// otherwise.
std::int64_t part_size(Connection& c, Id id, MapPart part) {
  const auto size = one(c, "SELECT data_bytes, reflectance_bytes FROM maps WHERE id = ?1", id, "map",
                        [part](const detail::Statement& row) { return row.integer(part == MapPart::answers ? 0 : 1); });
  const auto count = detail::map_piece_count(size);
  auto counted = c.prepare("SELECT count(*) FROM map_data WHERE map_id = ?1 AND part = ?2");
  counted.bind(id, static_cast<std::int64_t>(part));
  counted.step();
  if (counted.integer(0) != count)
    fail(Kind::corrupt,
         fmt::format("map {}: {} pieces of data where its {} bytes make {}", id, counted.integer(0), size, count));
  return size;
}

// Pieces `first` to `last` (inclusive) of a part, each inflated and handed to `sink` until it
// returns false, inside the caller's read transaction; whether `sink` had all. Each must
// inflate to its length: corrupt otherwise.
bool read_pieces(Connection& c, Id id, MapPart part, std::int64_t size, std::int64_t first, std::int64_t last,
                 const std::function<bool(std::string_view)>& sink) {
  std::string raw;
  for (std::int64_t piece = first; piece <= last; ++piece) {
    auto row = c.prepare("SELECT bytes FROM map_data WHERE map_id = ?1 AND part = ?2 AND piece = ?3");
    row.bind(id, static_cast<std::int64_t>(part), piece);
    if (!row.step()) fail(Kind::corrupt, fmt::format("map {} has no piece {} of its data", id, piece));
    raw.resize(static_cast<std::size_t>(detail::map_piece_length(size, piece)));
    detail::inflate_piece(row.blob(0), raw, fmt::format("map {}, piece {}", id, piece));
    if (!sink(raw)) return false;
  }
  return true;
}

}  // namespace

Result<void> Store::read_map_data(Id id, const std::function<bool(std::string_view piece)>& sink, MapPart part) const {
  const auto read = impl_->read(fmt::format("reading map {}'s data", id), [&](Connection& c) {
    bool handed = false;  // once `sink` has had a piece, the read must not start again
    try {
      const auto size = part_size(c, id, part);
      return read_pieces(c, id, part, size, 0, detail::map_piece_count(size) - 1, [&](std::string_view piece) {
        handed = true;
        return sink(piece);
      });
    } catch (detail::Failure& failure) {
      if (handed) failure.retryable = false;
      throw;
    }
  });
  if (!read) return std::unexpected(read.error());
  return {};
}

Result<std::string> Store::read_map_bytes(Id id, MapPart part, std::int64_t offset, std::int64_t length) const {
  return impl_->read(fmt::format("reading map {}'s data", id), [&](Connection& c) {
    if (offset < 0 || length < 0) fail(Kind::invalid_argument, "a map's data is read from a place within it");
    const auto size = part_size(c, id, part);
    const auto end = std::min(size, offset + std::min(length, size));
    std::string out;
    if (offset >= end) return out;
    const auto first = offset / detail::kMapPieceBytes, last = (end - 1) / detail::kMapPieceBytes;
    std::int64_t at = first * detail::kMapPieceBytes;  // where the piece handed next starts
    read_pieces(c, id, part, size, first, last, [&](std::string_view piece) {
      const auto from = std::max(offset, at) - at,
                 to = std::min(end, at + static_cast<std::int64_t>(piece.size())) - at;
      out.append(piece.substr(static_cast<std::size_t>(from), static_cast<std::size_t>(to - from)));
      at += static_cast<std::int64_t>(piece.size());
      return true;
    });
    return out;
  });
}

}  // namespace skinspec::store
