// Maps in the store, on both engines: a map stored with its job's end round trips its data
// (pieces deflated and inflated again), pictures and summary; a map is stored whole or not at
// all (a data source that fails part way, a job that is not running, a session that does not
// exist); maps are listed newest first; damaged data is reported as corrupt.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <stdexcept>

#include "each_backend.hpp"
#include "skinspec/store/store.hpp"
#include "skinspec/testkit/postgres_cluster.hpp"
#include "skinspec/testkit/raw_database.hpp"
#include "skinspec/testkit/store_samples.hpp"

namespace skinspec {
namespace {

using namespace skinspec::store;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using testing::map_data_of;
using testing::sample_map_bytes;
using testing::sample_session;
using testing::value_of;
using Kind = StoreError::Kind;

constexpr std::int64_t kMiB = std::int64_t{1} << 20;

// A map of `session` named `name`, the rest as given after.
Map map_of(std::optional<Id> session, const std::string& name) {
  Map map;
  map.session_id = session;
  map.name = name;
  return map;
}

void expect_done(const Result<void>& result) { EXPECT_TRUE(result) << result.error().message; }

// Each test on a new SQLite file and on a new database of the test program's PostgreSQL cluster.
class StoreMapsTest : public ::testing::TestWithParam<Backend> {
 protected:
  StoreMapsTest()
      : path_(GetParam() == Backend::sqlite
                  ? dir_.file("skinspec.db")
                  : testing::postgres_cluster().uri(testing::postgres_cluster().create_database())),
        store_(value_of(Store::open(path_))),
        raw_(testing::raw_database(path_)) {}

  Id running_job(std::optional<Id> session = std::nullopt) { return testing::running_job(store_, "map", session); }
  Id store_map(std::optional<Id> session, const std::string& name, const std::string& bytes) {
    return testing::store_sample_map(store_, session, name, bytes);
  }

  std::string data_of(Id map) {
    std::string out;
    expect_done(store_.read_map_data(map, [&](std::string_view piece) {
      out += piece;
      return true;
    }));
    return out;
  }

  long long rows_in(const std::string& table) { return raw_->integer("SELECT count(*) FROM " + table); }

  testing::ScratchDirectory dir_;
  std::string path_;
  Store store_;
  std::unique_ptr<testing::RawDatabase> raw_;
};

INSTANTIATE_TEST_SUITE_P(EachBackend, StoreMapsTest, ::testing::Values(Backend::sqlite, Backend::postgresql),
                         testing::backend_name);

// 3.5 MiB: four pieces, two of them random, two compressible, the last one short.
TEST_P(StoreMapsTest, AMapRoundTripsItsDataPicturesAndSummaryWithItsJobsEnd) {
  const Id session = value_of(store_.create_session(sample_session(1)));
  const Id job_id = running_job(session);
  const auto bytes = sample_map_bytes(7 * kMiB / 2, 9);
  std::vector<std::int64_t> offsets;
  auto map = map_of(session, "arm");
  map.job_id = 999;
  map.summary = R"({"pixels":12,"bands":[1,2]})";
  map.header = "ENVI\nsamples = 3\n";
  map.pictures = {"ignored"};
  const std::vector<MapPicture> pictures{{"oxyhemoglobin", std::string("\x89PNG\0\x01", 6)}, {"melanin", "png"}};
  const auto reflectance = sample_map_bytes(3 * kMiB / 2, 4);
  const auto job = value_of(store_.complete_map_job(job_id, map, map_data_of(bytes, &offsets), map_data_of(reflectance),
                                                    pictures, R"({"map_id":5,"z":1})"));
  EXPECT_THAT(offsets, ElementsAre(0, kMiB, 2 * kMiB, 3 * kMiB));

  EXPECT_EQ(job.state, JobState::succeeded);
  EXPECT_TRUE(job.finished_at);
  const auto result = nlohmann::json::parse(job.result);
  EXPECT_EQ(result.at("z"), 1);
  const Id id = result.at("map_id").get<Id>();
  EXPECT_EQ(value_of(store_.job(job_id)).result, job.result);

  const auto stored = value_of(store_.map(id));
  EXPECT_EQ(stored.id, id);
  EXPECT_EQ(stored.job_id, job_id);
  EXPECT_EQ(stored.session_id, session);
  EXPECT_EQ(stored.name, "arm");
  EXPECT_EQ(stored.summary, map.summary);
  EXPECT_EQ(stored.header, map.header);
  EXPECT_EQ(stored.data_bytes, static_cast<std::int64_t>(bytes.size()));
  EXPECT_THAT(stored.pictures, ElementsAre("oxyhemoglobin", "melanin"));
  EXPECT_EQ(stored.created_at, job.finished_at);
  EXPECT_EQ(value_of(store_.map_picture(id, "oxyhemoglobin")), pictures[0].png);
  EXPECT_EQ(value_of(store_.map_picture(id, "melanin")), "png");

  EXPECT_TRUE(data_of(id) == bytes);
  EXPECT_EQ(stored.reflectance_bytes, static_cast<std::int64_t>(reflectance.size()));
  std::string reflectance_read;
  expect_done(store_.read_map_data(
      id,
      [&](std::string_view piece) {
        reflectance_read += piece;
        return true;
      },
      MapPart::reflectance));
  EXPECT_TRUE(reflectance_read == reflectance);
  EXPECT_EQ(rows_in("map_data"), 4 + 2);
  // A run of bytes across a piece's end, one inside a piece, and one running past the end.
  EXPECT_EQ(value_of(store_.read_map_bytes(id, MapPart::answers, kMiB - 10, 30)), bytes.substr(kMiB - 10, 30));
  EXPECT_EQ(value_of(store_.read_map_bytes(id, MapPart::reflectance, 17, 8)), reflectance.substr(17, 8));
  EXPECT_EQ(value_of(store_.read_map_bytes(id, MapPart::reflectance, 3 * kMiB / 2 - 4, 100)),
            reflectance.substr(3 * kMiB / 2 - 4));
  EXPECT_EQ(value_of(store_.read_map_bytes(id, MapPart::answers, 7 * kMiB, 4)), "");
  EXPECT_EQ(store_.read_map_bytes(id + 1, MapPart::answers, 0, 4).error().kind, Kind::not_found);
  // The random half is stored about as large as it is, the rest far smaller.
  const auto deflated = raw_->integer("SELECT sum(length(bytes)) FROM map_data WHERE part = 0");
  EXPECT_GT(deflated, static_cast<long long>(bytes.size()) / 2);
  EXPECT_LT(deflated, static_cast<long long>(bytes.size()) * 2 / 3);
}

TEST_P(StoreMapsTest, ADataSourceThatFailsPartWayStoresNothingAndTheJobRunsOn) {
  const Id session = value_of(store_.create_session(sample_session(1)));
  const Id job_id = running_job(session);
  const auto bytes = sample_map_bytes(3 * kMiB, 2);
  auto data = map_data_of(bytes);
  data.read = [&](std::int64_t offset, std::span<char> into) {
    if (offset >= 2 * kMiB) throw std::runtime_error("the cube's file went away");
    map_data_of(bytes).read(offset, into);
  };
  const auto map = map_of(session, "arm");
  EXPECT_THROW((void)store_.complete_map_job(job_id, map, map_data_of(bytes), data, {{"melanin", "png"}}, "{}"),
               std::runtime_error);
  EXPECT_EQ(rows_in("maps"), 0);
  EXPECT_EQ(rows_in("map_data"), 0);
  EXPECT_EQ(rows_in("map_pictures"), 0);
  EXPECT_EQ(value_of(store_.job(job_id)).state, JobState::running);
  EXPECT_TRUE(value_of(store_.maps()).empty());

  // The store goes on: the same job ends with its map.
  const auto job = value_of(store_.complete_map_job(job_id, map, map_data_of(bytes), {}, {}, "{}"));
  EXPECT_EQ(job.state, JobState::succeeded);
  EXPECT_EQ(rows_in("map_data"), 3);
}

TEST_P(StoreMapsTest, AMapNeedsItsJobRunningItsSessionAndValuesThatCanBeStored) {
  const Id session = value_of(store_.create_session(sample_session(1)));
  const auto bytes = sample_map_bytes(100, 1);
  const auto refusal = [&](Id job, const Map& map, const std::vector<MapPicture>& pictures = {},
                           const std::string& result = "{}", std::int64_t size = 100) {
    auto data = map_data_of(bytes);
    data.size = size;
    const auto refused = store_.complete_map_job(job, map, data, {}, pictures, result);
    return refused ? std::optional<Kind>() : std::optional(refused.error().kind);
  };
  const auto map = map_of(session, "arm");

  Job queued;
  queued.kind = "map";
  const Id waiting = value_of(store_.create_job(queued)).job.id;
  EXPECT_EQ(refusal(waiting, map), Kind::conflict);
  EXPECT_EQ(refusal(9999, map), Kind::not_found);
  const Id job = running_job(session);
  EXPECT_EQ(refusal(job, map_of(9999, "arm")), Kind::not_found);
  EXPECT_EQ(refusal(job, map_of(session, "")), Kind::invalid_argument);
  auto listed = map;
  listed.summary = "[1]";
  EXPECT_EQ(refusal(job, listed), Kind::invalid_argument);
  EXPECT_EQ(refusal(job, map, {}, "[]"), Kind::invalid_argument);
  EXPECT_EQ(refusal(job, map, {}, "{}", -1), Kind::invalid_argument);
  EXPECT_EQ(refusal(job, map, {{"", "png"}}), Kind::invalid_argument);
  EXPECT_EQ(refusal(job, map, {{"melanin", "1"}, {"melanin", "2"}}), Kind::invalid_argument);
  EXPECT_EQ(rows_in("maps"), 0);
  EXPECT_EQ(value_of(store_.job(job)).state, JobState::running);

  // A session that is no longer open still takes a map; a job that ended takes no other.
  value_of(store_.update_session(session, {.state = SessionState::complete}));
  EXPECT_EQ(refusal(job, map), std::nullopt);
  EXPECT_EQ(refusal(job, map), Kind::conflict);
  EXPECT_EQ(rows_in("maps"), 1);
}

TEST_P(StoreMapsTest, MapsAreListedNewestFirstAndBySession) {
  const Id first = value_of(store_.create_session(sample_session(1)));
  const Id second = value_of(store_.create_session(sample_session(2)));
  const auto bytes = sample_map_bytes(1000, 3);
  const Id a = store_map(first, "a", bytes);
  const Id b = store_map(std::nullopt, "b", bytes);
  const Id c = store_map(second, "c", bytes);
  const Id d = store_map(first, "d", bytes);
  const auto ids = [](const std::vector<Map>& maps) {
    std::vector<Id> out;
    for (const auto& map : maps) out.push_back(map.id);
    return out;
  };
  EXPECT_THAT(ids(value_of(store_.maps())), ElementsAre(d, c, b, a));
  EXPECT_THAT(ids(value_of(store_.maps(first))), ElementsAre(d, a));
  EXPECT_THAT(ids(value_of(store_.maps(second, 1))), ElementsAre(c));
  EXPECT_THAT(ids(value_of(store_.maps(std::nullopt, 2))), ElementsAre(d, c));
  EXPECT_TRUE(value_of(store_.maps(9999)).empty());
  for (const auto& map : value_of(store_.maps())) EXPECT_THAT(map.pictures, ElementsAre("melanin", "bilirubin"));
  EXPECT_FALSE(value_of(store_.map(b)).session_id);
  EXPECT_EQ(store_.maps(std::nullopt, 0).error().kind, Kind::invalid_argument);
  EXPECT_EQ(store_.maps(std::nullopt, 1001).error().kind, Kind::invalid_argument);
}

TEST_P(StoreMapsTest, WhatDoesNotExistIsNotFound) {
  const Id id = store_map(std::nullopt, "a", sample_map_bytes(10, 1));
  EXPECT_EQ(store_.map(id + 1).error().kind, Kind::not_found);
  const auto no_picture = store_.map_picture(id, "haemoglobin");
  ASSERT_FALSE(no_picture);
  EXPECT_EQ(no_picture.error().kind, Kind::not_found);
  EXPECT_THAT(no_picture.error().message, HasSubstr("no picture of 'haemoglobin'"));
  EXPECT_EQ(store_.map_picture(id + 1, "melanin").error().kind, Kind::not_found);
  EXPECT_EQ(store_.read_map_data(id + 1, [](std::string_view) { return true; }).error().kind, Kind::not_found);
}

TEST_P(StoreMapsTest, ReadingTheDataStopsWhenTheSinkSaysSo) {
  const auto bytes = sample_map_bytes(5 * kMiB / 2, 4);
  const Id id = store_map(std::nullopt, "a", bytes);
  std::vector<std::string> pieces;
  expect_done(store_.read_map_data(id, [&](std::string_view piece) {
    pieces.emplace_back(piece);
    return false;
  }));
  ASSERT_EQ(pieces.size(), 1u);
  EXPECT_TRUE(pieces[0] == bytes.substr(0, kMiB));

  pieces.clear();
  expect_done(store_.read_map_data(id, [&](std::string_view piece) {
    pieces.emplace_back(piece);
    return true;
  }));
  ASSERT_EQ(pieces.size(), 3u);
  EXPECT_EQ(pieces[2].size(), static_cast<std::size_t>(kMiB / 2));

  const Id empty = store_map(std::nullopt, "empty", "");
  EXPECT_EQ(value_of(store_.map(empty)).data_bytes, 0);
  EXPECT_EQ(data_of(empty), "");
}

TEST_P(StoreMapsTest, DataThatDoesNotInflateToItsSizeIsCorrupt) {
  const auto bytes = sample_map_bytes(2 * kMiB + 10, 5);
  const Id id = store_map(std::nullopt, "a", bytes);
  const auto expect_corrupt = [&](const std::string& what) {
    const auto read = store_.read_map_data(id, [](std::string_view) { return true; });
    ASSERT_FALSE(read) << what;
    EXPECT_EQ(read.error().kind, Kind::corrupt) << what << ": " << read.error().message;
  };
  const std::string garbage = GetParam() == Backend::sqlite ? "X'00010203'" : "'\\x00010203'::bytea";
  raw_->execute("UPDATE maps SET data_bytes = data_bytes + 1");
  expect_corrupt("a size one byte longer");
  raw_->execute("UPDATE maps SET data_bytes = data_bytes - 1");
  EXPECT_TRUE(data_of(id) == bytes);
  raw_->execute("UPDATE map_data SET bytes = " + garbage + " WHERE piece = 1");
  expect_corrupt("a piece that is not deflated data");
  raw_->execute("DELETE FROM map_data WHERE piece = 2");
  expect_corrupt("a piece missing");
}

}  // namespace
}  // namespace skinspec
