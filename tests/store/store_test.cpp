// The store's records, queries and rules: every entity round trips bit for bit, the one
// transaction of a measurement and its fit, session and job life cycles, listing with filters
// and cursors, recovery after a writer died, and the one-writer lock.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <functional>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <future>
#include <set>

#include "each_backend.hpp"
#include "skinspec/store/store.hpp"
#include "skinspec/testkit/postgres_cluster.hpp"
#include "skinspec/testkit/raw_database.hpp"
#include "skinspec/testkit/store_samples.hpp"

namespace skinspec {
namespace {

using namespace skinspec::store;
using testing::check_sample_fit;
using testing::check_sample_measurement;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using testing::sample_fit;
using testing::sample_measurement;
using testing::sample_session;
using Kind = StoreError::Kind;

// A clock a test moves by hand, one second per reading unless set.
struct ManualClock {
  std::shared_ptr<Time> now = std::make_shared<Time>(Time(std::chrono::seconds(1'700'000'000)));
  std::function<Time()> function() const {
    auto shared = now;
    return [shared] {
      *shared += std::chrono::seconds(1);
      return *shared;
    };
  }
};

// Each test on a new SQLite file and on a new PostgreSQL database of the test program's
// throwaway cluster (skinspec/testkit/postgres_cluster.hpp).
class StoreTest : public ::testing::TestWithParam<Backend> {
 protected:
  StoreTest()
      : path_(GetParam() == Backend::sqlite
                  ? dir_.file("skinspec.db")
                  : testing::postgres_cluster().uri(testing::postgres_cluster().create_database())) {}

  Store open(OpenOptions options = {}) {
    if (!options.clock) options.clock = clock_.function();
    auto store = Store::open(path_, options);
    if (!store) throw std::runtime_error(store.error().message);
    return std::move(*store);
  }

  // Queries beside the store, in the dialect of the backend.
  testing::RawDatabase& raw() {
    if (!raw_) raw_ = testing::raw_database(path_);
    return *raw_;
  }
  bool on_sqlite() const { return GetParam() == Backend::sqlite; }

  testing::ScratchDirectory dir_;
  std::string path_;  // the SQLite file, or the PostgreSQL URI
  ManualClock clock_;
  std::unique_ptr<testing::RawDatabase> raw_;
};

// What only a SQLite file has: its pragmas, and a file read without a writer.
class SqliteStoreTest : public StoreTest {};

INSTANTIATE_TEST_SUITE_P(EachBackend, StoreTest, ::testing::Values(Backend::sqlite, Backend::postgresql),
                         testing::backend_name);
INSTANTIATE_TEST_SUITE_P(Sqlite, SqliteStoreTest, ::testing::Values(Backend::sqlite), testing::backend_name);

template <typename T>
T value_of(Result<T> result) {
  if (!result) throw std::runtime_error(result.error().message);
  return std::move(*result);
}

TEST_P(SqliteStoreTest, NewDatabaseHasTheCurrentSchemaInWalModeWithForeignKeys) {
  {
    auto store = open();
    EXPECT_EQ(store.schema_version(), current_schema_version());
    EXPECT_GE(current_schema_version(), 2);
  }
  EXPECT_EQ(testing::sqlite_integer(path_, "PRAGMA user_version"), current_schema_version());
  EXPECT_EQ(testing::sqlite_text(path_, "PRAGMA journal_mode"), "wal");
  EXPECT_EQ(testing::sqlite_integer(path_, "PRAGMA application_id"), 0x534B5350);
  EXPECT_EQ(testing::sqlite_text(path_, "PRAGMA integrity_check"), "ok");
}

TEST_P(StoreTest, InstrumentsAreKnownByModelAndSerialNumber) {
  auto store = open();
  const Id first = value_of(store.ensure_instrument(testing::sample_instrument(1)));
  auto moved = testing::sample_instrument(1);
  moved.connection = "usb:0403:6001:A1";
  EXPECT_EQ(value_of(store.ensure_instrument(moved)), first);
  const Id second = value_of(store.ensure_instrument(testing::sample_instrument(2)));
  EXPECT_NE(second, first);

  const auto read = value_of(store.instrument(first));
  EXPECT_EQ(read.model, "PR-650");
  EXPECT_EQ(read.serial_number, "609501");
  EXPECT_EQ(read.connection, "usb:0403:6001:A1");
  EXPECT_EQ(read.spectral_configuration, testing::sample_instrument(1).spectral_configuration);
  EXPECT_LT(read.created_at, read.last_seen_at);
  EXPECT_EQ(value_of(store.instruments()).size(), 2u);
  EXPECT_EQ(store.instrument(99).error().kind, Kind::not_found);
}

TEST_P(StoreTest, WhiteStandardRoundTripsItsTableBitForBit) {
  auto store = open();
  auto standard = testing::sample_white_standard(1);
  standard.reflectance.values[1] = std::nextafter(0.99, 1.0);  // the last bit must survive
  const Id id = value_of(store.add_white_standard(standard));
  const auto read = value_of(store.white_standard(id));
  EXPECT_EQ(read.name, standard.name);
  EXPECT_EQ(read.certificate, standard.certificate);
  EXPECT_EQ(read.reflectance, standard.reflectance);
  EXPECT_EQ(read.created_at, *clock_.now);
  EXPECT_EQ(value_of(store.white_standards()).size(), 1u);
}

TEST_P(StoreTest, SpectraAreStoredAsLittleEndianFloat64Pairs) {
  {
    auto store = open();
    WhiteStandard standard{0, "w", "", {{400, 700}, {0.5, -1.25}}, {}};
    value_of(store.add_white_standard(standard));
  }
  const auto hex = raw().text(on_sqlite() ? "SELECT hex(reflectance) FROM white_standards"
                                          : "SELECT upper(encode(reflectance, 'hex')) FROM white_standards");
  // 400.0 = 0x4079000000000000, 0.5 = 0x3FE0..., 700.0 = 0x4085E00000000000, -1.25 = 0xBFF4...
  EXPECT_EQ(hex,
            "0000000000007940"
            "000000000000E03F"
            "0000000000E08540"
            "000000000000F4BF");
}

TEST_P(StoreTest, SessionRoundTripsAndFollowsItsStates) {
  auto store = open();
  const Id white = value_of(store.add_white_standard(testing::sample_white_standard(1)));
  auto session = sample_session(2);
  session.white_standard_id = white;
  session.state = SessionState::complete;  // ignored: new sessions are open
  const Id id = value_of(store.create_session(session));

  auto read = value_of(store.session(id));
  EXPECT_EQ(read.subject, session.subject);
  EXPECT_EQ(read.site, session.site);
  EXPECT_EQ(read.operator_name, session.operator_name);
  EXPECT_EQ(read.notes, session.notes);
  EXPECT_EQ(read.white_standard_id, white);
  EXPECT_EQ(read.state, SessionState::open);
  EXPECT_EQ(read.created_at, read.updated_at);
  EXPECT_FALSE(read.ended_at);

  read = value_of(store.update_session(id, {.notes = "left arm", .state = SessionState::interrupted}));
  EXPECT_EQ(read.notes, "left arm");
  EXPECT_EQ(read.state, SessionState::interrupted);
  EXPECT_TRUE(read.ended_at);
  read = value_of(store.update_session(id, {.state = SessionState::open}));
  EXPECT_FALSE(read.ended_at);
  read = value_of(store.update_session(id, {.state = SessionState::complete}));
  EXPECT_EQ(read.state, SessionState::complete);
  EXPECT_EQ(read.ended_at, read.updated_at);

  const auto reopened = store.update_session(id, {.state = SessionState::open});
  ASSERT_FALSE(reopened);
  EXPECT_EQ(reopened.error().kind, Kind::conflict);
  EXPECT_THAT(reopened.error().message, HasSubstr("complete cannot become open"));
  EXPECT_TRUE(store.update_session(id, {.notes = "annotated afterwards"}));
  EXPECT_EQ(store.update_session(77, {.notes = "x"}).error().kind, Kind::not_found);

  auto unknown_white = sample_session(3);
  unknown_white.white_standard_id = 42;
  EXPECT_EQ(store.create_session(unknown_white).error().kind, Kind::not_found);
  EXPECT_EQ(store.create_session(Session{}).error().kind, Kind::invalid_argument);
}

// An imported reflectance has no radiance of its own; a measured one must have it, and an
// import must bring its reflectance.
TEST_P(StoreTest, AnImportedMeasurementHasAReflectanceAndNoRadiance) {
  auto store = open();
  const Id session = value_of(store.create_session(sample_session(1)));
  auto imported = sample_measurement(session, 3);
  imported.kind = MeasurementKind::imported;
  imported.radiance = {};
  imported.radiance_sd = {};
  imported.settings = R"({"source":{"file":"cm700d.csv","sample_id":"P-1","line":4}})";
  const auto ids = value_of(store.record_measurement(imported, sample_fit(3)));
  const auto back = value_of(store.measurement(ids.measurement_id));
  EXPECT_EQ(back.kind, MeasurementKind::imported);
  EXPECT_TRUE(back.radiance.empty());
  EXPECT_EQ(back.reflectance, imported.reflectance);
  EXPECT_EQ(back.settings, imported.settings);
  EXPECT_EQ(to_string(MeasurementKind::imported), "imported");
  EXPECT_EQ(parse_measurement_kind("imported"), MeasurementKind::imported);

  auto no_reflectance = imported;
  no_reflectance.reflectance = {};
  EXPECT_EQ(store.record_measurement(no_reflectance, std::nullopt).error().kind, Kind::invalid_argument);
  auto sample_without_radiance = imported;
  sample_without_radiance.kind = MeasurementKind::sample;
  EXPECT_EQ(store.record_measurement(sample_without_radiance, std::nullopt).error().kind, Kind::invalid_argument);
}

// A refit's work list: measurements with a reflectance holding no fit by the maker, by id, of one
// session or all; and its fits stored a batch at a time, all or none.
TEST_P(StoreTest, MeasurementsToRefitAreThoseWithoutAFitByTheMaker) {
  auto store = open();
  const Id first = value_of(store.create_session(sample_session(1)));
  const Id second = value_of(store.create_session(sample_session(2)));
  auto white = sample_measurement(first, 0);
  white.kind = MeasurementKind::white;
  white.reflectance = {};
  value_of(store.record_measurement(white, std::nullopt));
  std::vector<Id> samples;
  for (int n = 1; n <= 5; ++n)
    samples.push_back(value_of(store.record_measurement(sample_measurement(n % 2 ? first : second, n), sample_fit(n)))
                          .measurement_id);
  auto maker = FitMaker{"paper", "skinspec 0.1.0", "3f2a9c0d", "77aa01be"};  // sample_fit's
  RefitQuery query{maker, std::nullopt, 0, 256};
  EXPECT_TRUE(value_of(store.measurements_to_refit(query)).empty());
  EXPECT_EQ(value_of(store.count_measurements_to_refit(query)), 0);

  query.made_by.constants_digest = "newer";
  query.limit = 2;
  const auto page = value_of(store.measurements_to_refit(query));
  ASSERT_EQ(page.size(), 2u);
  EXPECT_EQ(page[0].id, samples[0]);
  EXPECT_EQ(check_sample_measurement(page[1]), "");
  EXPECT_EQ(value_of(store.count_measurements_to_refit(query)), 5);
  query.after_id = page[1].id;
  EXPECT_EQ(value_of(store.measurements_to_refit(query)).front().id, samples[2]);
  query.session_id = second;
  query.after_id = 0;
  query.limit = 256;
  EXPECT_EQ(value_of(store.count_measurements_to_refit(query)), 2);

  // Fits of the newer maker, two at once: those two are done.
  std::vector<Fit> fits;
  for (const Id id : {samples[1], samples[3]}) {
    auto f = sample_fit(9);
    f.measurement_id = id;
    f.constants_digest = "newer";
    fits.push_back(f);
  }
  const auto ids = value_of(store.add_fits(fits));
  ASSERT_EQ(ids.size(), 2u);
  EXPECT_EQ(value_of(store.fit(ids[1])).measurement_id, samples[3]);
  EXPECT_EQ(value_of(store.count_measurements_to_refit(query)), 0);
  query.session_id = std::nullopt;
  EXPECT_EQ(value_of(store.count_measurements_to_refit(query)), 3);

  // A batch with one fit of a measurement that does not exist stores none of them.
  fits[0].measurement_id = samples[0];
  fits[1].measurement_id = 999;
  EXPECT_EQ(store.add_fits(fits).error().kind, Kind::not_found);
  EXPECT_EQ(value_of(store.fits_of_measurement(samples[0])).size(), 1u);
  query.limit = 0;
  EXPECT_EQ(store.measurements_to_refit(query).error().kind, Kind::invalid_argument);
}

TEST_P(StoreTest, MeasurementAndFitRoundTripInOneTransaction) {
  auto store = open();
  const Id instrument = value_of(store.ensure_instrument(testing::sample_instrument(1)));
  const Id session = value_of(store.create_session(sample_session(1)));
  auto white = sample_measurement(session, 0);
  white.kind = MeasurementKind::white;
  white.reflectance = {};
  white.instrument_id = instrument;
  const auto white_ids = value_of(store.record_measurement(white, std::nullopt));
  EXPECT_FALSE(white_ids.fit_id);

  auto sample = sample_measurement(session, 5);
  sample.instrument_id = instrument;
  sample.white_measurement_id = white_ids.measurement_id;
  const auto ids = value_of(store.record_measurement(sample, sample_fit(5)));
  ASSERT_TRUE(ids.fit_id);

  const auto m = value_of(store.measurement(ids.measurement_id));
  EXPECT_EQ(check_sample_measurement(m), "");
  EXPECT_EQ(m.kind, MeasurementKind::sample);
  EXPECT_EQ(m.label, "sample 5");
  EXPECT_EQ(m.session_id, session);
  EXPECT_EQ(m.instrument_id, instrument);
  EXPECT_EQ(m.white_measurement_id, white_ids.measurement_id);
  EXPECT_TRUE(m.simulated);
  EXPECT_EQ(m.units, "W/(sr m2 nm)");
  EXPECT_EQ(m.reading_count, 3);
  EXPECT_EQ(m.created_at, *clock_.now);

  const auto stored_white = value_of(store.measurement(white_ids.measurement_id));
  EXPECT_EQ(stored_white.kind, MeasurementKind::white);
  EXPECT_TRUE(stored_white.reflectance.empty());

  const auto f = value_of(store.fit(*ids.fit_id));
  EXPECT_EQ(check_sample_fit(f, 5), "");
  EXPECT_EQ(f.measurement_id, ids.measurement_id);
  EXPECT_TRUE(std::isinf(f.params[4].standard_error));
  EXPECT_EQ(f.site, "forearm");
  EXPECT_EQ(f.solver_summary, sample_fit(5).solver_summary);
  EXPECT_EQ(f.options, sample_fit(5).options);
  EXPECT_EQ(f.delta_e00_d65, 0.9);
  EXPECT_TRUE(f.converged);

  // A refit of the same measurement, then the whole session from one snapshot.
  auto refit = sample_fit(5);
  refit.measurement_id = ids.measurement_id;
  refit.options = R"({"site":"forearm","lateral_diffusion":false})";
  refit.params[0].standard_error = std::numeric_limits<double>::quiet_NaN();
  const Id refit_id = value_of(store.add_fit(refit));
  // Any standard error that is not finite is one the fit could not bound.
  EXPECT_TRUE(std::isinf(value_of(store.fit(refit_id)).params[0].standard_error));
  EXPECT_EQ(value_of(store.fits_of_measurement(ids.measurement_id)).size(), 2u);

  EXPECT_EQ(value_of(store.latest_measurement(session, MeasurementKind::white))->id, white_ids.measurement_id);
  EXPECT_EQ(value_of(store.latest_measurement(session, MeasurementKind::sample))->id, ids.measurement_id);
  EXPECT_FALSE(value_of(store.latest_measurement(session, MeasurementKind::dark)));
  EXPECT_EQ(store.latest_measurement(999, MeasurementKind::white).error().kind, Kind::not_found);

  const auto detail = value_of(store.session_detail(session));
  EXPECT_EQ(detail.session.id, session);
  ASSERT_EQ(detail.measurements.size(), 2u);
  EXPECT_EQ(detail.measurements[0].id, white_ids.measurement_id);
  ASSERT_EQ(detail.fits.size(), 2u);
  EXPECT_EQ(detail.fits[1].id, refit_id);
}

TEST_P(StoreTest, RejectedReadingsKeepTheirRawBytesInAnySessionState) {
  auto store = open();
  const Id instrument = value_of(store.ensure_instrument(testing::sample_instrument(1)));
  const Id session = value_of(store.create_session(sample_session(1)));
  Job job;
  job.kind = "measure";
  job.session_id = session;
  const Id job_id = value_of(store.create_job(job)).job.id;
  RejectedReading r;
  r.session_id = session;
  r.job_id = job_id;
  r.instrument_id = instrument;
  r.attempt = 2;
  r.quality_code = 18;
  r.quality = "low light";
  r.reason = "bad_reading: quality 18: low light";
  static constexpr char kReply[] = "18,0\r\n\x00\xff 380.,1.0E-3\r\n";  // a NUL and a high byte on the line
  r.raw_reply = std::string(kReply, sizeof kReply - 1);
  r.measured_at = Time(std::chrono::microseconds(1700000000123456));
  const Id id = value_of(store.record_rejected_reading(r));

  const auto back = value_of(store.rejected_reading(id));
  EXPECT_EQ(back.session_id, session);
  EXPECT_EQ(back.job_id, job_id);
  EXPECT_EQ(back.instrument_id, instrument);
  EXPECT_EQ(back.attempt, 2);
  EXPECT_EQ(back.quality_code, 18);
  EXPECT_EQ(back.quality, "low light");
  EXPECT_EQ(back.reason, r.reason);
  EXPECT_EQ(back.raw_reply, r.raw_reply);
  EXPECT_EQ(back.measured_at, r.measured_at);
  EXPECT_EQ(back.created_at, *clock_.now);

  // Raw data is kept whatever became of the session, and it is never a measurement.
  value_of(store.update_session(session, {.state = SessionState::aborted}));
  const Id later = value_of(store.record_rejected_reading(r));
  const auto detail = value_of(store.session_detail(session));
  EXPECT_TRUE(detail.measurements.empty());
  ASSERT_EQ(detail.rejected_readings.size(), 2u);
  EXPECT_EQ(detail.rejected_readings[0].id, id);
  EXPECT_EQ(detail.rejected_readings[1].id, later);

  r.session_id = 999;
  EXPECT_EQ(store.record_rejected_reading(r).error().kind, StoreError::Kind::not_found);
  r.session_id = session;
  r.attempt = 0;
  EXPECT_EQ(store.record_rejected_reading(r).error().kind, StoreError::Kind::invalid_argument);
  EXPECT_EQ(store.rejected_reading(12345).error().kind, StoreError::Kind::not_found);
}

TEST_P(StoreTest, AMeasurementWhoseFitIsRefusedLeavesNoRow) {
  auto store = open();
  const Id session = value_of(store.create_session(sample_session(1)));
  auto bad_fit = sample_fit(1);
  bad_fit.params[1].value = std::numeric_limits<double>::quiet_NaN();
  const auto refused = store.record_measurement(sample_measurement(session, 1), bad_fit);
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().kind, Kind::invalid_argument);
  EXPECT_THAT(refused.error().message, HasSubstr("melanin"));

  bad_fit = sample_fit(1);
  bad_fit.tables_digest.clear();
  EXPECT_EQ(store.record_measurement(sample_measurement(session, 1), bad_fit).error().kind, Kind::invalid_argument);
  EXPECT_TRUE(value_of(store.session_detail(session)).measurements.empty());

  auto bad_options = sample_fit(1);
  bad_options.options = "{";
  EXPECT_EQ(store.record_measurement(sample_measurement(session, 1), bad_options).error().kind, Kind::invalid_argument);
  // A fit names its model and at least one parameter, each named; its judgement is a JSON object.
  for (const auto& spoil : std::vector<std::function<void(Fit&)>>{
           [](Fit& f) { f.model.clear(); }, [](Fit& f) { f.params.clear(); }, [](Fit& f) { f.params[2].name.clear(); },
           [](Fit& f) { f.assessment = "[]"; }, [](Fit& f) { f.assessment = "{\"note\":"; }}) {
    auto bad = sample_fit(1);
    spoil(bad);
    EXPECT_EQ(store.record_measurement(sample_measurement(session, 1), bad).error().kind, Kind::invalid_argument);
  }
  EXPECT_EQ(raw().integer("SELECT count(*) FROM measurements"), 0);
  EXPECT_EQ(raw().integer("SELECT count(*) FROM fits"), 0);
}

// Any model's fit comes back as it was given: its model, its parameters by name in order, its
// judgement and its constants digest.
TEST_P(StoreTest, AFitOfAnyModelReadsBackAsStored) {
  auto store = open();
  const Id session = value_of(store.create_session(sample_session(2)));
  EXPECT_EQ(value_of(store.session(session)).model, "extended");
  Fit fit = sample_fit(2);
  fit.model = "extended";
  fit.params = {{"surface_reflectance", 0.05, 0.003},
                {"melanin", 4.25, 0.1},
                {"total_hemoglobin", 11.5, 1.0},
                {"oxygen_saturation", 0.4, std::numeric_limits<double>::infinity()},
                {"bilirubin", 0, std::numeric_limits<double>::infinity()},
                {"dermis_scattering", 36.2, 3.2},
                {"dermis_scattering_power", 1.0 / 3.0, 0.125}};
  fit.assessment = R"({"determination":{"bilirubin":{"determined":false,"reason":"at_bound"}},"note":"ünïcode"})";
  fit.constants_digest = "0123456789abcdef";
  const auto ids = value_of(store.record_measurement(sample_measurement(session, 2), fit));
  const Fit stored = value_of(store.fit(*ids.fit_id));
  EXPECT_EQ(stored.model, fit.model);
  EXPECT_EQ(stored.params, fit.params);
  EXPECT_EQ(stored.assessment, fit.assessment);
  EXPECT_EQ(stored.constants_digest, fit.constants_digest);
  EXPECT_EQ(raw().integer(on_sqlite() ? "SELECT json_extract(parameters, '$[3].standard_error') IS NULL FROM fits"
                                      : "SELECT ((parameters -> 3 ->> 'standard_error') IS NULL)::int FROM fits"),
            1);
}

TEST_P(StoreTest, MeasurementsAreCheckedBeforeTheyAreStored) {
  auto store = open();
  const Id session = value_of(store.create_session(sample_session(1)));
  auto m = sample_measurement(session, 1);
  m.radiance.values.pop_back();
  EXPECT_THAT(store.record_measurement(m, std::nullopt).error().message, HasSubstr("101 wavelengths but 100 values"));
  m = sample_measurement(session, 1);
  std::swap(m.radiance.wavelength_nm[3], m.radiance.wavelength_nm[4]);
  EXPECT_THAT(store.record_measurement(m, std::nullopt).error().message, HasSubstr("strictly increase"));
  m = sample_measurement(session, 1);
  m.settings = "[1]";
  EXPECT_EQ(store.record_measurement(m, std::nullopt).error().kind, Kind::invalid_argument);
  m = sample_measurement(session, 1);
  m.white_measurement_id = 555;
  EXPECT_EQ(store.record_measurement(m, std::nullopt).error().kind, Kind::not_found);
  m = sample_measurement(session, 1);
  m.instrument_id = 556;
  EXPECT_EQ(store.record_measurement(m, std::nullopt).error().kind, Kind::not_found);
  EXPECT_EQ(store.record_measurement(sample_measurement(999, 1), std::nullopt).error().kind, Kind::not_found);

  const Id sample = value_of(store.record_measurement(sample_measurement(session, 2), std::nullopt)).measurement_id;
  m = sample_measurement(session, 3);
  m.white_measurement_id = sample;  // not a white reading
  EXPECT_EQ(store.record_measurement(m, std::nullopt).error().kind, Kind::conflict);

  value_of(store.update_session(session, {.state = SessionState::aborted}));
  const auto closed = store.record_measurement(sample_measurement(session, 4), std::nullopt);
  EXPECT_EQ(closed.error().kind, Kind::conflict);
  EXPECT_THAT(closed.error().message, HasSubstr("aborted, not open"));
  EXPECT_TRUE(store.add_fit([&] {
    auto f = sample_fit(2);
    f.measurement_id = sample;
    return f;
  }()));  // refits are allowed after a session ends
  EXPECT_EQ(value_of(store.session_detail(session)).measurements.size(), 1u);
}

TEST_P(StoreTest, SessionsAreListedNewestFirstWithFiltersAndCursor) {
  auto store = open();
  std::vector<Id> ids;
  for (int n = 0; n < 7; ++n) ids.push_back(value_of(store.create_session(sample_session(n))));
  value_of(store.update_session(ids[2], {.state = SessionState::complete}));
  const auto created = [&](int n) { return value_of(store.session(ids[static_cast<std::size_t>(n)])).created_at; };

  std::vector<Id> seen;
  SessionFilter filter;
  filter.limit = 3;
  for (int pages = 0;; ++pages) {
    ASSERT_LT(pages, 5);
    const auto page = value_of(store.sessions(filter));
    for (const auto& s : page.sessions) seen.push_back(s.id);
    if (!page.next_cursor) break;
    filter.cursor = page.next_cursor;
  }
  EXPECT_EQ(seen, std::vector<Id>(ids.rbegin(), ids.rend()));

  const auto ids_of = [](const SessionPage& page) {
    std::vector<Id> out;
    for (const auto& s : page.sessions) out.push_back(s.id);
    return out;
  };
  EXPECT_THAT(ids_of(value_of(store.sessions({.site = "cheek"}))), ElementsAre(ids[5], ids[3], ids[1]));
  EXPECT_THAT(ids_of(value_of(store.sessions({.state = SessionState::complete}))), ElementsAre(ids[2]));
  EXPECT_THAT(ids_of(value_of(store.sessions({.created_from = created(2), .created_before = created(5)}))),
              ElementsAre(ids[4], ids[3], ids[2]));
  EXPECT_THAT(ids_of(value_of(store.sessions({.site = "forearm", .state = SessionState::open, .limit = 1}))),
              ElementsAre(ids[6]));
  EXPECT_EQ(store.sessions({.limit = 0}).error().kind, Kind::invalid_argument);
}

TEST_P(StoreTest, JobsFollowTheirStatesAndIdempotencyKeys) {
  auto store = open();
  const Id session = value_of(store.create_session(sample_session(1)));
  Job asked;
  asked.kind = "measure";
  asked.request = R"({"kind":"sample","count":3})";
  asked.requested_by = "operator-token";
  asked.session_id = session;
  asked.idempotency_key = "key-1";
  const auto created = value_of(store.create_job(asked));
  EXPECT_TRUE(created.created);
  EXPECT_EQ(created.job.state, JobState::queued);
  EXPECT_EQ(created.job.request, asked.request);
  EXPECT_EQ(created.job.requested_by, "operator-token");

  const auto again = value_of(store.create_job(asked));
  EXPECT_FALSE(again.created);
  EXPECT_EQ(again.job.id, created.job.id);
  EXPECT_EQ(value_of(store.job_by_idempotency_key("key-1"))->id, created.job.id);
  EXPECT_FALSE(value_of(store.job_by_idempotency_key("key-2")));

  auto running = value_of(store.update_job(created.job.id, {.state = JobState::running}));
  EXPECT_TRUE(running.started_at);
  EXPECT_FALSE(running.finished_at);
  auto m = sample_measurement(session, 1);
  m.job_id = created.job.id;
  // A job's measurement is stored only with the job's end.
  EXPECT_EQ(store.record_measurement(m, sample_fit(1)).error().kind, Kind::invalid_argument);
  const auto done = value_of(store.complete_measurement_job(created.job.id, m, sample_fit(1), R"({"readings":1})"));
  EXPECT_EQ(done.job.state, JobState::succeeded);
  EXPECT_TRUE(done.job.finished_at);
  EXPECT_FALSE(done.job.error);
  EXPECT_EQ(value_of(store.measurement(done.ids.measurement_id)).job_id, created.job.id);
  EXPECT_EQ(value_of(store.fit(*done.ids.fit_id)).measurement_id, done.ids.measurement_id);
  EXPECT_EQ(done.job.result, R"({"readings":1,"measurement_id":)" + std::to_string(done.ids.measurement_id) +
                                 R"(,"fit_id":)" + std::to_string(*done.ids.fit_id) + "}");
  EXPECT_EQ(value_of(store.job(created.job.id)).result, done.job.result);
  EXPECT_EQ(store.update_job(created.job.id, {.state = JobState::running}).error().kind, Kind::conflict);
  // Only a running job ends with its measurement.
  EXPECT_EQ(store.complete_measurement_job(created.job.id, m, std::nullopt, "{}").error().kind, Kind::conflict);

  Job other;
  other.kind = "refit";
  const Id unattached = value_of(store.create_job(other)).job.id;
  // Failed and cancelled jobs say why, the others do not.
  EXPECT_EQ(store.update_job(unattached, {.state = JobState::cancelled}).error().kind, Kind::invalid_argument);
  EXPECT_EQ(store.update_job(unattached, {.state = JobState::running, .error = JobError{JobErrorCode::lost, "gone"}})
                .error()
                .kind,
            Kind::invalid_argument);
  const JobError why{JobErrorCode::cancelled, "by the operator, \"at once\""};
  const auto cancelled = value_of(store.update_job(unattached, {.state = JobState::cancelled, .error = why}));
  EXPECT_EQ(cancelled.error, why);
  EXPECT_EQ(value_of(store.job(unattached)).error, cancelled.error);
  EXPECT_EQ(raw().text("SELECT error FROM jobs WHERE id = " + std::to_string(unattached)),
            R"({"code":"cancelled","message":"by the operator, \"at once\""})");
  EXPECT_EQ(value_of(store.jobs()).size(), 2u);
  EXPECT_EQ(value_of(store.jobs(session)).size(), 1u);
  EXPECT_EQ(store.update_job(1234, {.state = JobState::running}).error().kind, Kind::not_found);
  other.request = "not json";
  EXPECT_EQ(store.create_job(other).error().kind, Kind::invalid_argument);
}

// A writer that died with a job running: on the next open its session is interrupted and the
// job failed; what it had committed is all there.
TEST_P(StoreTest, OpeningAfterAWriterDiedInterruptsItsRunningSessions) {
  Id busy_session = 0, idle_session = 0, finished_session = 0, job_id = 0, measurement_id = 0;
  {
    auto store = open();
    busy_session = value_of(store.create_session(sample_session(1)));
    idle_session = value_of(store.create_session(sample_session(2)));
    finished_session = value_of(store.create_session(sample_session(3)));
    value_of(store.update_session(finished_session, {.state = SessionState::complete}));
    Job job;
    job.kind = "measure";
    job.session_id = busy_session;
    job_id = value_of(store.create_job(job)).job.id;
    value_of(store.update_job(job_id, {.state = JobState::running}));
    measurement_id =
        value_of(store.record_measurement(sample_measurement(busy_session, 1), sample_fit(1))).measurement_id;
    EXPECT_TRUE(store.recovery().interrupted_sessions.empty());
  }
  auto store = open();
  EXPECT_THAT(store.recovery().interrupted_sessions, ElementsAre(busy_session));
  EXPECT_THAT(store.recovery().failed_jobs, ElementsAre(job_id));
  EXPECT_EQ(value_of(store.session(busy_session)).state, SessionState::interrupted);
  EXPECT_EQ(value_of(store.session(idle_session)).state, SessionState::open);
  EXPECT_EQ(value_of(store.session(finished_session)).state, SessionState::complete);
  const auto job = value_of(store.job(job_id));
  EXPECT_EQ(job.state, JobState::failed);
  ASSERT_TRUE(job.error);
  EXPECT_EQ(job.error->code, JobErrorCode::interrupted);
  EXPECT_THAT(job.error->message, HasSubstr("stopped before it finished"));
  EXPECT_EQ(check_sample_measurement(value_of(store.measurement(measurement_id))), "");
}

// The measurement, its fit and the job's end are one transaction: a refusal of any part leaves
// the job running and nothing of it stored.
TEST_P(StoreTest, AJobEndsWithItsMeasurementOrNotAtAll) {
  auto store = open();
  const Id session = value_of(store.create_session(sample_session(1)));
  const Id other_session = value_of(store.create_session(sample_session(2)));
  Job job;
  job.kind = "measure";
  job.session_id = session;
  const Id job_id = value_of(store.create_job(job)).job.id;
  const auto m = sample_measurement(session, 1);
  EXPECT_EQ(store.complete_measurement_job(job_id, m, sample_fit(1), "{}").error().kind,
            Kind::conflict);  // still queued
  value_of(store.update_job(job_id, {.state = JobState::running}));

  auto bad_fit = sample_fit(1);
  bad_fit.params[1].value = std::nan("");
  EXPECT_EQ(store.complete_measurement_job(job_id, m, bad_fit, "{}").error().kind, Kind::invalid_argument);
  EXPECT_EQ(store.complete_measurement_job(job_id, m, sample_fit(1), "[]").error().kind, Kind::invalid_argument);
  EXPECT_EQ(
      store.complete_measurement_job(job_id, sample_measurement(other_session, 1), std::nullopt, "{}").error().kind,
      Kind::invalid_argument);
  auto of_another_job = m;
  of_another_job.job_id = job_id + 1;
  EXPECT_EQ(store.complete_measurement_job(job_id, of_another_job, std::nullopt, "{}").error().kind,
            Kind::invalid_argument);
  EXPECT_EQ(store.complete_measurement_job(job_id + 1, m, sample_fit(1), "{}").error().kind, Kind::not_found);
  const auto refused = [&](const Measurement& of_job) {
    return store.complete_measurement_job(job_id, of_job, sample_fit(1), "{}").error().message;
  };
  auto no_such_white = m;
  no_such_white.white_measurement_id = 555;
  EXPECT_THAT(refused(no_such_white), HasSubstr("measurement 555 does not exist"));
  auto no_such_instrument = m;
  no_such_instrument.instrument_id = 556;
  EXPECT_THAT(refused(no_such_instrument), HasSubstr("instrument 556 does not exist"));
  const Id other_sample =
      value_of(store.record_measurement(sample_measurement(other_session, 2), std::nullopt)).measurement_id;
  auto not_white = m;
  not_white.white_measurement_id = other_sample;
  EXPECT_THAT(refused(not_white), HasSubstr("is not a white reading"));
  value_of(store.update_session(session, {.state = SessionState::complete}));
  EXPECT_EQ(store.complete_measurement_job(job_id, m, sample_fit(1), "{}").error().kind, Kind::conflict);
  EXPECT_EQ(store.complete_measurement_job(job_id, m, std::nullopt, "{}").error().kind, Kind::conflict);

  EXPECT_EQ(value_of(store.job(job_id)).state, JobState::running);
  EXPECT_EQ(value_of(store.job(job_id)).result, "{}");
  EXPECT_EQ(raw().integer("SELECT count(*) FROM measurements"), 1);  // other_sample
  EXPECT_EQ(raw().integer("SELECT count(*) FROM fits"), 0);
}

// The job's result is the caller's object (its members sorted by name, any ids it had left out)
// with the ids of the measurement and fit stored after them: the same text whatever the engine.
TEST_P(StoreTest, AJobsResultEndsWithTheIdsOfWhatItStored) {
  auto store = open();
  const Id session = value_of(store.create_session(sample_session(1)));
  const auto run_job = [&] {
    Job job;
    job.kind = "measure";
    job.session_id = session;
    const Id id = value_of(store.create_job(job)).job.id;
    value_of(store.update_job(id, {.state = JobState::running}));
    return id;
  };
  const Id with_fit = run_job();
  const auto done =
      value_of(store.complete_measurement_job(with_fit, sample_measurement(session, 1), sample_fit(1),
                                              R"({"b": [1, 2], "a": "x", "fit_id": 99, "measurement_id": -1})"));
  EXPECT_EQ(done.job.result, R"({"a":"x","b":[1,2],"measurement_id":)" + std::to_string(done.ids.measurement_id) +
                                 R"(,"fit_id":)" + std::to_string(*done.ids.fit_id) + "}");
  EXPECT_EQ(value_of(store.job(with_fit)).result, done.job.result);

  const Id without_fit = run_job();
  const auto bare =
      value_of(store.complete_measurement_job(without_fit, sample_measurement(session, 2), std::nullopt, "{}"));
  EXPECT_FALSE(bare.ids.fit_id);
  EXPECT_EQ(bare.job.result, R"({"measurement_id":)" + std::to_string(bare.ids.measurement_id) + R"(,"fit_id":null})");
  EXPECT_EQ(value_of(store.job(without_fit)).result, bare.job.result);
  EXPECT_EQ(bare.job.state, JobState::succeeded);
  EXPECT_TRUE(bare.job.finished_at);
  EXPECT_EQ(value_of(store.measurement(bare.ids.measurement_id)).job_id, without_fit);
}

TEST_P(StoreTest, RecoveryCanTreatEveryOpenSessionAsRunning) {
  Id idle = 0;
  {
    auto store = open();
    idle = value_of(store.create_session(sample_session(1)));
  }
  OpenOptions options;
  options.recovery = RecoveryPolicy::all_open_sessions;
  auto store = open(options);
  EXPECT_THAT(store.recovery().interrupted_sessions, ElementsAre(idle));
  EXPECT_EQ(value_of(store.session(idle)).state, SessionState::interrupted);
}

TEST_P(StoreTest, OnlyOneWriterAtATimeButReadersMayJoin) {
  auto writer = open();
  const Id session = value_of(writer.create_session(sample_session(1)));
  const auto second = Store::open(path_);
  ASSERT_FALSE(second);
  EXPECT_EQ(second.error().kind, Kind::busy);
  EXPECT_THAT(second.error().message, HasSubstr("another program has it open for writing"));

  OpenOptions read_only;
  read_only.mode = OpenMode::read_only;
  auto reader = Store::open(path_, read_only);
  ASSERT_TRUE(reader) << reader.error().message;
  EXPECT_EQ(value_of(reader->session(session)).subject, sample_session(1).subject);
  const auto refused = reader->create_session(sample_session(2));
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().kind, Kind::read_only);
  EXPECT_TRUE(reader->recovery().interrupted_sessions.empty());
}

// The write-ahead log is copied back into the file while the store stays open, and written
// from its start again, even behind a writer that never pauses: it stays a few megabytes long
// however much is written (it would hold everything, were nothing copied back; it would grow
// without end, were it never caught up with).
TEST_P(SqliteStoreTest, TheLogStaysShortBehindAWriterThatNeverPauses) {
  auto store = open();
  const Id session = value_of(store.create_session(sample_session(1)));
  const std::string log = path_ + "-wal";
  std::uintmax_t longest = 0;
  int written = 0;
  while (std::filesystem::file_size(path_) < 48'000'000) {
    std::vector<std::pair<Measurement, std::optional<Fit>>> batch;
    for (int i = 0; i < 10; ++i, ++written)
      batch.emplace_back(sample_measurement(session, written), sample_fit(written));
    ASSERT_TRUE(store.record_measurements(batch).has_value());
    longest = std::max(longest, std::filesystem::file_size(log));
    ASSERT_LT(written, 40'000) << "the file stays at " << std::filesystem::file_size(path_)
                               << " bytes: the log is not copied into it";
  }
  EXPECT_LT(longest, 24'000'000u) << "after " << written << " measurements";
  EXPECT_EQ(testing::sqlite_integer(path_, "SELECT count(*) FROM measurements"), written);
}

OpenOptions batches_of(int rows) {
  OpenOptions options;
  options.import_batch = rows;
  return options;
}

using ImportRow = std::pair<Measurement, std::optional<Fit>>;

// `count` sample measurements of `session`, each with its fit.
std::vector<ImportRow> import_rows(Id session, int count) {
  std::vector<ImportRow> rows;
  for (int i = 0; i < count; ++i) rows.emplace_back(sample_measurement(session, i), sample_fit(i));
  return rows;
}

// An import larger than a batch: the batches are committed as they come (on SQLite), yet no read
// sees any of it, through this Store or another program's, until the whole of it is published
// with its job's end; then all of it at once.
TEST_P(StoreTest, AnImportIsSeenWholeWithItsJobsEndOrNotAtAll) {
  auto store = open(batches_of(50));
  OpenOptions read_only;
  read_only.mode = OpenMode::read_only;
  const Id session = value_of(store.create_session(sample_session(1)));
  Job job;
  job.kind = "import";
  job.session_id = session;
  const Id job_id = value_of(store.create_job(job)).job.id;
  value_of(store.update_job(job_id, {.state = JobState::running}));
  const auto rows = import_rows(session, 400);
  std::size_t given = 0;
  long long staged = 0;
  const auto stored = value_of(store.record_measurements_as_ready(
      [&]() -> const ImportRow* {
        if (given == 300) {
          EXPECT_TRUE(value_of(store.session_detail(session)).measurements.empty());
          EXPECT_TRUE(value_of(store.session_detail(session)).fits.empty());
          EXPECT_EQ(value_of(store.count_measurements_to_refit({.made_by = {"paper", "x", "y", "z"}})), 0);
          EXPECT_EQ(value_of(store.job(job_id)).state, JobState::running);
          const auto reader = value_of(Store::open(path_, read_only));
          EXPECT_TRUE(value_of(reader.session_detail(session)).measurements.empty());
          staged = raw().integer("SELECT count(*) FROM measurements");
        }
        return given < rows.size() ? &rows[given++] : nullptr;
      },
      JobCompletion{job_id, R"({"imported":400})"}));
  ASSERT_EQ(stored.size(), 400u);
  // Batches of 50 before the 300th row was asked for: committed, and passed over by every read.
  EXPECT_GE(staged, 250);
  EXPECT_EQ(value_of(store.measurement(stored[0].measurement_id)).label, rows[0].first.label);
  const auto detail = value_of(store.session_detail(session));
  EXPECT_EQ(detail.measurements.size(), 400u);
  EXPECT_EQ(detail.fits.size(), 400u);
  EXPECT_EQ(detail.measurements.back().job_id, job_id);
  EXPECT_EQ(value_of(store.job(job_id)).state, JobState::succeeded);
}

// An import that fails after some of its batches were committed (its file refused part way, or
// its session closed meanwhile) leaves nothing, seen or not, and its job running.
TEST_P(StoreTest, AnImportThatFailsPartWayLeavesNothing) {
  auto store = open(batches_of(50));
  const Id session = value_of(store.create_session(sample_session(1)));
  const auto rows = import_rows(session, 400);
  std::size_t given = 0;
  struct Refused {};
  EXPECT_THROW((void)store.record_measurements_as_ready([&]() -> const ImportRow* {
    if (given == 300) throw Refused{};
    return &rows[given++];
  }),
               Refused);
  // Other writes go on between an import's batches: a session closed meanwhile fails the import
  // at its publication.
  given = 0;
  const auto closed = store.record_measurements_as_ready([&]() -> const ImportRow* {
    if (given == 380) value_of(store.update_session(session, {.state = SessionState::complete}));
    return given < rows.size() ? &rows[given++] : nullptr;
  });
  ASSERT_FALSE(closed);
  EXPECT_EQ(closed.error().kind, Kind::conflict);
  EXPECT_TRUE(value_of(store.session_detail(session)).measurements.empty());
  EXPECT_EQ(raw().integer("SELECT count(*) FROM measurements"), 0);
  EXPECT_EQ(raw().integer("SELECT count(*) FROM fits"), 0);
  EXPECT_EQ(raw().integer("SELECT count(*) FROM imports"), 0);
}

// The Store's other writes (a bench's heartbeat, a new session) go on while an import waits for its
// next spectra (fitted, for a file): the import holds the writer only while it writes a batch.
// Here the import's source waits, two batches in, until the other writes are done or have waited
// long; the import is then published whole.
TEST_P(StoreTest, OtherWritesGoOnWhileAnImportWaitsForItsSpectra) {
  auto store = open(batches_of(50));
  const Id session = value_of(store.create_session(sample_session(1)));
  const auto rows = import_rows(session, 400);
  std::promise<void> waiting, released;
  auto waiting_future = waiting.get_future();
  auto released_future = released.get_future();
  std::size_t given = 0;
  auto import = std::async(std::launch::async, [&] {
    return store.record_measurements_as_ready([&]() -> const ImportRow* {
      if (given == 120) {
        waiting.set_value();
        released_future.wait();
      }
      return given < rows.size() ? &rows[given++] : nullptr;
    });
  });
  waiting_future.wait();
  auto others = std::async(std::launch::async, [&] {
    Bench bench;
    bench.host = "bench-pc";
    const bool beaten = store.beat(bench).has_value();
    return std::pair{beaten, value_of(store.create_session(sample_session(2)))};
  });
  const bool prompt = others.wait_for(std::chrono::seconds(10)) == std::future_status::ready;
  const auto staged = raw().integer("SELECT count(*) FROM measurements");
  released.set_value();
  EXPECT_TRUE(prompt) << "the other writes waited for the import";
  EXPECT_EQ(staged, 100) << "two batches committed, unseen";
  const auto [beaten, second] = others.get();
  EXPECT_TRUE(beaten);
  EXPECT_EQ(value_of(store.session(second)).subject, sample_session(2).subject);
  EXPECT_EQ(value_of(import.get()).size(), 400u);
  EXPECT_EQ(value_of(store.session_detail(session)).measurements.size(), 400u);
  EXPECT_EQ(value_of(store.session_detail(session)).fits.size(), 400u);
}

// An import of a thousand times the batch: the write-ahead log stays a small part of the file
// while it is stored, where one transaction would spill the whole import into it (and more: its
// pages again and again past the page cache), and the checkpoints could copy none of it back.
TEST_P(SqliteStoreTest, ALargeImportKeepsTheLogShort) {
  auto store = open(batches_of(32));
  const Id session = value_of(store.create_session(sample_session(1)));
  const std::string log = path_ + "-wal";
  // Past the writer's 16 MB page cache, and small enough to run in seconds under the sanitizers:
  // stored in one transaction, the log would hold the whole import at its commit.
  constexpr int kRows = 6000;
  std::pair<Measurement, std::optional<Fit>> row;
  int given = 0;
  std::uintmax_t longest = 0, database = 0;
  const auto stored = value_of(store.record_measurements_as_ready([&]() -> const decltype(row)* {
    if (given % 500 == 0 && std::filesystem::exists(log)) {
      longest = std::max(longest, std::filesystem::file_size(log));
      database = std::filesystem::file_size(path_);
    }
    if (given == kRows) return nullptr;
    row = {sample_measurement(session, given), sample_fit(given)};
    ++given;
    return &row;
  }));
  ASSERT_EQ(stored.size(), static_cast<std::size_t>(kRows));
  longest = std::max(longest, std::filesystem::file_size(log));
  database = std::max(database, std::filesystem::file_size(path_));
  EXPECT_GT(database, 12'000'000u) << "the import is not larger than the log's bound";
  EXPECT_LT(longest, database / 2) << "the log reached " << longest << " bytes beside " << database;
  EXPECT_EQ(value_of(store.session_detail(session)).measurements.size(), static_cast<std::size_t>(kRows));
}

TEST_P(SqliteStoreTest, ReadOnlyOpeningNeedsAnExistingFile) {
  OpenOptions read_only;
  read_only.mode = OpenMode::read_only;
  const auto missing = Store::open(path_, read_only);
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().kind, Kind::not_found);
  EXPECT_FALSE(std::filesystem::exists(path_));
  EXPECT_EQ(Store::open(":memory:").error().kind, Kind::invalid_argument);
  EXPECT_EQ(Store::open(dir_.path().string()).error().kind, Kind::invalid_argument);
}

// Names of the files in `dir`.
std::vector<std::string> files_in(const std::filesystem::path& dir) {
  std::vector<std::string> names;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) names.push_back(entry.path().filename().string());
  std::ranges::sort(names);
  return names;
}

// With no writer (no -wal), a read-only store reads the file as it is, creating no -wal or
// -shm beside it; when a writer then changes the file, its reads fail rather than mix states.
TEST_P(SqliteStoreTest, ReadOnlyWithoutAWriterCreatesNothingAndNoticesOneThatStarts) {
  Id first = 0;
  {
    auto writer = open();
    first = value_of(writer.create_session(sample_session(1)));
  }
  const auto files = files_in(dir_.path());
  ASSERT_THAT(files, ElementsAre("skinspec.db", "skinspec.db-lock"));
  const auto bytes = testing::file_bytes(path_);

  OpenOptions read_only;
  read_only.mode = OpenMode::read_only;
  auto reader = value_of(Store::open(path_, read_only));
  EXPECT_EQ(value_of(reader.session(first)).subject, sample_session(1).subject);
  EXPECT_EQ(files_in(dir_.path()), files);
  EXPECT_TRUE(testing::file_bytes(path_) == bytes);

  {
    auto writer = open();  // closing it checkpoints the new session into the file
    value_of(writer.create_session(sample_session(2)));
  }
  ASSERT_FALSE(testing::file_bytes(path_) == bytes);
  const auto stale = reader.session(first);
  ASSERT_FALSE(stale);
  EXPECT_EQ(stale.error().kind, Kind::busy);
  EXPECT_THAT(stale.error().message, HasSubstr("changed while it was read"));

  // Opened again, it reads the file as it is now.
  auto again = value_of(Store::open(path_, read_only));
  EXPECT_EQ(value_of(again.sessions({})).sessions.size(), 2u);
}

// While a writer has the file open, a read-only store reads through its log: it sees what the
// writer committed and not yet copied into the file.
TEST_P(StoreTest, ReadOnlyBesideAWriterSeesItsCommits) {
  auto writer = open();
  OpenOptions read_only;
  read_only.mode = OpenMode::read_only;
  auto reader = value_of(Store::open(path_, read_only));
  const Id later = value_of(writer.create_session(sample_session(3)));
  EXPECT_EQ(value_of(reader.session(later)).subject, sample_session(3).subject);
}

// Read as a URI, the path keeps every byte: '?', '#', '%', blanks and non-ASCII are escaped.
TEST_P(SqliteStoreTest, ReadOnlyOpensAPathThatLooksLikeAUri) {
  const auto odd = dir_.file("a?b #%20\xc3\xa9.db");
  {
    auto writer = value_of(Store::open(odd));
    value_of(writer.create_session(sample_session(1)));
  }
  OpenOptions read_only;
  read_only.mode = OpenMode::read_only;
  auto reader = value_of(Store::open(odd, read_only));
  EXPECT_EQ(value_of(reader.session(1)).subject, sample_session(1).subject);
  EXPECT_FALSE(std::filesystem::exists(dir_.file("a")));
}

TEST_P(SqliteStoreTest, ReadOnlyRefusesAnEmptySqliteDatabaseAndAnOlderSchema) {
  OpenOptions read_only;
  read_only.mode = OpenMode::read_only;
  testing::sqlite_execute(path_, "CREATE TABLE t (x); DROP TABLE t;");
  const auto empty = Store::open(path_, read_only);
  ASSERT_FALSE(empty);
  EXPECT_EQ(empty.error().kind, Kind::corrupt);
  EXPECT_THAT(empty.error().message, HasSubstr("an empty SQLite database"));

  const auto older = dir_.file("older.db");
  ASSERT_TRUE(create_database_at_version(older, 1));
  const auto refused = Store::open(older, read_only);
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().kind, Kind::older_schema);
  EXPECT_EQ(testing::sqlite_integer(older, "PRAGMA user_version"), 1);
}

TEST_P(SqliteStoreTest, ErrorKindsHaveNames) {
  EXPECT_EQ(to_string(Kind::newer_schema), "newer_schema");
  EXPECT_EQ(to_string(SessionState::interrupted), "interrupted");
  EXPECT_EQ(parse_session_state("aborted"), SessionState::aborted);
  EXPECT_FALSE(parse_session_state("Aborted"));
  EXPECT_EQ(parse_measurement_kind("dark"), MeasurementKind::dark);
  EXPECT_EQ(parse_job_state("cancelled"), JobState::cancelled);
  // Every job error code reads back from its name, and no two share one.
  std::set<std::string_view> seen;
  for (const auto& [code, name] : job_error_code_names()) {
    EXPECT_EQ(to_string(code), name);
    EXPECT_EQ(parse_job_error_code(name), code);
    EXPECT_TRUE(seen.insert(name).second) << name;
  }
  EXPECT_EQ(seen.size(), static_cast<std::size_t>(JobErrorCode::internal) + 1);
  EXPECT_FALSE(parse_job_error_code("database"));
}

}  // namespace
}  // namespace skinspec
