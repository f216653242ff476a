#include "skinspec/testkit/store_samples.hpp"

#include <sqlite3.h>
#include <stdlib.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>

namespace skinspec::testing {

using namespace skinspec::store;

ScratchDirectory::ScratchDirectory() {
  std::string pattern = (std::filesystem::temp_directory_path() / "skinspec-store-XXXXXX").string();
  if (!::mkdtemp(pattern.data())) throw std::runtime_error("mkdtemp failed for " + pattern);
  path_ = pattern;
}

ScratchDirectory::~ScratchDirectory() {
  std::error_code ignored;
  std::filesystem::remove_all(path_, ignored);
}

std::vector<double> native_grid() {
  std::vector<double> grid;
  for (int w = 380; w <= 780; w += 4) grid.push_back(w);
  return grid;
}

namespace {

Time at_second(long long s) { return Time(std::chrono::seconds(1'700'000'000 + s)) + std::chrono::microseconds(123); }

SpectralSamples spectrum_of(int n, double scale, double offset) {
  SpectralSamples s{native_grid(), {}};
  for (const double w : s.wavelength_nm) s.values.push_back(offset + scale * n + std::sin(w / 37.0 + n) / 3.0);
  return s;
}

}  // namespace

WhiteStandard sample_white_standard(int n) {
  WhiteStandard w;
  w.name = "Spectralon " + std::to_string(n);
  w.certificate = "cert-" + std::to_string(n) + ", NIST traceable";
  w.reflectance = {{380, 500.5, 780}, {0.98, 0.99 - n * 1e-3, 0.985}};
  return w;
}

Instrument sample_instrument(int n) {
  Instrument i;
  i.model = "PR-650";
  i.serial_number = "60950" + std::to_string(n);
  i.spectral_configuration = R"({"start_nm":380,"end_nm":780,"step_nm":4})";
  i.connection = "serial:/dev/ttyUSB" + std::to_string(n);
  return i;
}

Session sample_session(int n) {
  Session s;
  s.subject = "S-" + std::to_string(1000 + n);
  s.site = n % 2 == 0 ? "forearm" : "cheek";
  s.operator_name = "operator " + std::to_string(n);
  s.notes = "notes, with \"quotes\"\nand a line break";
  s.model = n % 2 == 0 ? "extended" : "paper";
  return s;
}

Measurement sample_measurement(Id session_id, int n) {
  Measurement m;
  m.session_id = session_id;
  m.kind = MeasurementKind::sample;
  m.label = "sample " + std::to_string(n);
  m.simulated = n % 2 == 1;
  m.quality_code = n % 3 == 0 ? 0 : 14;
  m.quality = m.quality_code == 0 ? "OK" : "Overexposed";
  m.units = "W/(sr m2 nm)";
  m.settings = R"({"integration_ms":)" + std::to_string(100 + n) + R"(,"averages":3,"sync":"off"})";
  m.reading_count = 3;
  m.radiance = spectrum_of(n, 1e-3, 0.5);
  m.radiance_sd = spectrum_of(n, 1e-5, 0.01);
  m.reflectance = spectrum_of(n, 1e-4, 0.4);
  m.warnings = {"white reference is " + std::to_string(n) + " s old"};
  m.raw_reply = "0000,0\r\n";
  for (int i = 0; i < 64; ++i) m.raw_reply += static_cast<char>((n + i * 7) & 0xff);
  m.started_at = at_second(n);
  m.finished_at = at_second(n) + std::chrono::milliseconds(1500);
  return m;
}

Fit sample_fit(int n) {
  Fit f;
  f.site = "forearm";
  f.model = "paper";
  f.params = {{"surface_reflectance", 0.05 + n * 1e-6, 0.001},
              {"melanin", 7.0 + n, 0.2},
              {"oxyhemoglobin", 3.0, 0.3},
              {"deoxyhemoglobin", 2.5, 0.25},
              {"bilirubin", 0.0, std::numeric_limits<double>::infinity()}};
  // The odd ones as fits stored before terminations were recorded: without one.
  f.assessment =
      R"({"note":"sample )" + std::to_string(n) + (n % 2 == 0 ? R"(","termination":"function_tolerance"})" : R"("})");
  f.rmse = 0.01 + n * 1e-7;
  f.max_abs_error = 0.03;
  f.delta_e00_d65 = 0.9;
  f.iterations = 12 + n % 5;
  f.converged = true;
  f.solver_summary = "CONVERGENCE: Function tolerance reached";
  f.options = R"({"site":"forearm","lateral_diffusion":true})";
  f.model_version = "skinspec 0.1.0";
  f.tables_digest = "3f2a9c0d";
  f.constants_digest = "77aa01be";
  const auto reflectance = spectrum_of(n, 1e-4, 0.4);
  f.wavelength_nm = reflectance.wavelength_nm;
  f.measured = reflectance.values;
  for (const double v : f.measured) f.fitted.push_back(v + 1e-3);
  return f;
}

std::string sample_map_bytes(std::int64_t size, unsigned seed) {
  std::string bytes(static_cast<std::size_t>(size), '\0');
  const auto half = bytes.size() / 2;
  std::mt19937 random(seed);
  std::generate_n(bytes.begin(), half, [&] { return static_cast<char>(random()); });
  for (std::size_t at = half; at + sizeof(float) <= bytes.size(); at += sizeof(float)) {
    const auto value = static_cast<float>(seed + (at - half) / 4096);
    std::memcpy(bytes.data() + at, &value, sizeof value);
  }
  return bytes;
}

MapData map_data_of(const std::string& bytes, std::vector<std::int64_t>* offsets) {
  return {static_cast<std::int64_t>(bytes.size()), [&bytes, offsets](std::int64_t offset, std::span<char> into) {
            if (offsets) offsets->push_back(offset);
            if (offset < 0 || static_cast<std::size_t>(offset) + into.size() > bytes.size())
              throw std::out_of_range("a read beyond the map's data");
            std::memcpy(into.data(), bytes.data() + offset, into.size());
          }};
}

Id running_job(Store& store, const std::string& kind, std::optional<Id> session) {
  Job job;
  job.kind = kind;
  job.session_id = session;
  const Id id = value_of(store.create_job(job)).job.id;
  value_of(store.update_job(id, {.state = JobState::running}));
  return id;
}

Id store_sample_map(Store& store, std::optional<Id> session, const std::string& name, const std::string& bytes) {
  Map map;
  map.session_id = session;
  map.name = name;
  map.summary = R"({"pixels":12})";
  map.header = "ENVI\n";
  const std::string reflectance = bytes.substr(0, bytes.size() / 3);
  value_of(store.complete_map_job(running_job(store, "map", session), map, map_data_of(bytes), map_data_of(reflectance),
                                  {{"melanin", "png 1"}, {"bilirubin", "png 2"}}, "{}"));
  return value_of(store.maps(std::nullopt, 1)).front().id;  // the newest: this one
}

std::string check_sample_measurement(const Measurement& stored) {
  int n = 0;
  if (std::sscanf(stored.label.c_str(), "sample %d", &n) != 1) return "label '" + stored.label + "' is not a sample's";
  auto expected = sample_measurement(stored.session_id, n);
  const auto same = [](const auto& a, const auto& b) { return a == b; };
  if (!same(stored.radiance, expected.radiance)) return "radiance differs";
  if (!same(stored.radiance_sd, expected.radiance_sd)) return "radiance_sd differs";
  if (!same(stored.reflectance, expected.reflectance)) return "reflectance differs";
  if (stored.raw_reply != expected.raw_reply) return "raw reply differs";
  if (stored.settings != expected.settings) return "settings differ";
  if (stored.warnings != expected.warnings) return "warnings differ";
  if (stored.started_at != expected.started_at || stored.finished_at != expected.finished_at) return "times differ";
  if (stored.quality_code != expected.quality_code || stored.quality != expected.quality) return "quality differs";
  return "";
}

std::string check_sample_fit(const Fit& stored, int n) {
  const auto expected = sample_fit(n);
  if (stored.params != expected.params) return "params differ";
  if (stored.model != expected.model || stored.assessment != expected.assessment) return "model or assessment differ";
  if (stored.rmse != expected.rmse || stored.iterations != expected.iterations) return "rmse or iterations differ";
  if (stored.wavelength_nm != expected.wavelength_nm || stored.measured != expected.measured ||
      stored.fitted != expected.fitted)
    return "fitted spectra differ";
  if (stored.model_version != expected.model_version || stored.tables_digest != expected.tables_digest ||
      stored.constants_digest != expected.constants_digest)
    return "provenance differs";
  return "";
}

std::string file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream out;
  out << in.rdbuf();
  return out.str();
}

namespace {

struct Db {
  sqlite3* db = nullptr;
  Db(const std::string& path, int flags) {
    if (sqlite3_open_v2(path.c_str(), &db, flags, nullptr) != SQLITE_OK) {
      const std::string message = db ? sqlite3_errmsg(db) : "out of memory";
      sqlite3_close(db);
      throw std::runtime_error("opening " + path + ": " + message);
    }
  }
  ~Db() { sqlite3_close(db); }
  Db(const Db&) = delete;
  Db& operator=(const Db&) = delete;
};

std::string first_text(const std::string& path, const std::string& sql) {
  Db db(path, SQLITE_OPEN_READONLY);
  sqlite3_stmt* stmt = nullptr;
  if (sqlite3_prepare_v2(db.db, sql.c_str(), -1, &stmt, nullptr) != SQLITE_OK)
    throw std::runtime_error(sql + ": " + sqlite3_errmsg(db.db));
  std::string out;
  const int rc = sqlite3_step(stmt);
  if (rc == SQLITE_ROW && sqlite3_column_text(stmt, 0))
    out = reinterpret_cast<const char*>(sqlite3_column_text(stmt, 0));
  const std::string error = rc == SQLITE_ROW || rc == SQLITE_DONE ? "" : sqlite3_errmsg(db.db);
  sqlite3_finalize(stmt);
  if (!error.empty()) throw std::runtime_error(sql + ": " + error);
  return out;
}

}  // namespace

std::string sqlite_text(const std::string& path, const std::string& sql) { return first_text(path, sql); }

long long sqlite_integer(const std::string& path, const std::string& sql) { return std::stoll(first_text(path, sql)); }

void sqlite_execute(const std::string& path, const std::string& sql) {
  Db db(path, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE);
  char* error = nullptr;
  if (sqlite3_exec(db.db, sql.c_str(), nullptr, nullptr, &error) != SQLITE_OK) {
    const std::string message = error ? error : "unknown error";
    sqlite3_free(error);
    throw std::runtime_error(sql + ": " + message);
  }
}

}  // namespace skinspec::testing
