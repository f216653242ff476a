// The measurement job's pure parts: the meter's values as store records (averaged readings,
// settings, the instrument, rejected readings), the band-integrated radiance, and when an old
// white, a changed lamp or a rejected reading draws a warning.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "measure_policy.hpp"
#include "skinspec/drivers/pr6xx_protocol.hpp"
#include "store_records.hpp"

namespace skinspec::daemon {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

drivers::Reading reading(std::vector<double> radiance, int second) {
  drivers::Reading r;
  r.wavelength_nm = {400, 500, 600};
  r.radiance = std::move(radiance);
  r.units = "W/(sr m2 nm)";
  r.quality = "OK";
  r.raw_reply = "r" + std::to_string(second);
  r.started = std::chrono::system_clock::time_point(std::chrono::seconds(second));
  r.finished = r.started + std::chrono::milliseconds(500);
  return r;
}

store::Measurement white(store::Id id, double level, int finished_s = 0) {
  store::Measurement m;
  m.id = id;
  m.radiance = {{400, 500, 600}, {level, level, level}};
  m.finished_at = store::Time(std::chrono::seconds(finished_s));
  return m;
}

TEST(StoreRecordsTest, ReadingsAreAveragedWithTheirStandardDeviation) {
  const auto m = averaged({reading({1, 2, 3}, 10), reading({3, 2, 5}, 11)});
  ASSERT_TRUE(m) << m.error();
  EXPECT_EQ(m->radiance.values, std::vector<double>({2, 2, 4}));
  ASSERT_EQ(m->radiance_sd.values.size(), 3u);
  EXPECT_DOUBLE_EQ(m->radiance_sd.values[0], std::sqrt(2.0));
  EXPECT_DOUBLE_EQ(m->radiance_sd.values[1], 0);
  EXPECT_EQ(m->reading_count, 2);
  EXPECT_EQ(m->raw_reply, "r10r11");
  EXPECT_EQ(m->started_at, store::Time(std::chrono::seconds(10)));
  EXPECT_EQ(m->finished_at, store::Time(std::chrono::milliseconds(11500)));
  EXPECT_TRUE(averaged({reading({1, 2, 3}, 1)})->radiance_sd.empty());
  auto other_grid = reading({1, 2, 3}, 2);
  other_grid.wavelength_nm = {404, 500, 600};
  EXPECT_FALSE(averaged({reading({1, 2, 3}, 1), other_grid}));
  EXPECT_FALSE(averaged({}));
}

TEST(StoreRecordsTest, SettingsNameWhatWasAskedAndWhatTheMeterDid) {
  auto first = reading({1, 2, 3}, 1);
  first.averages = 3;
  first.sync = "off";
  first.exposure_used_ms = 16500;  // D13 after an adaptive measurement
  const auto settings =
      nlohmann::json::parse(measurement_settings({first, reading({1, 2, 3}, 2)}, drivers::MeasureOptions{}, 2, 1));
  EXPECT_EQ(settings, (nlohmann::json{{"integration_ms", 0},
                                      {"count", 2},
                                      {"rejected_readings", 1},
                                      {"averages", 3},
                                      {"sync", "off"},
                                      {"extended_sensitivity", false},
                                      {"aperture", nullptr},
                                      {"exposure_used_ms", {16500, nullptr}}}));
}

// A fixed exposure is the one used (after any doubling or halving); the newer meters' settings
// are kept as asked.
TEST(StoreRecordsTest, SettingsKeepTheNewerMetersSettingsAndAFixedExposure) {
  auto fixed = reading({1, 2, 3}, 1);
  fixed.integration_ms = 200;
  const drivers::MeasureOptions asked{.integration_ms = 100,
                                      .averages = 2,
                                      .adjust_integration = true,
                                      .extended_sensitivity = true,
                                      .aperture = "1/2 deg"};
  const auto settings = nlohmann::json::parse(measurement_settings({fixed}, asked, 1, 0));
  EXPECT_EQ(settings["integration_ms"], 100);
  EXPECT_EQ(settings["exposure_used_ms"], nlohmann::json::array({200}));
  EXPECT_EQ(settings["extended_sensitivity"], true);
  EXPECT_EQ(settings["aperture"], "1/2 deg");
}

TEST(StoreRecordsTest, TheInstrumentKeepsTheModelAndConfigurationTheMeterReported) {
  drivers::Identity identity;
  identity.model = drivers::Model::pr730;
  identity.family = drivers::Family::pr7xx;
  identity.reported_model = "PR-730/735";
  identity.serial_number = "73000001";
  identity.firmware = "2.22D";
  identity.grid = {380, 780, 1, 401};
  identity.configuration = {401, 0.5, 380, 780, 1};
  const auto record = instrument_record(identity, "usb:0403:6001");
  EXPECT_EQ(record.model, "PR-730/735");  // as the meter names itself
  EXPECT_EQ(record.serial_number, "73000001");
  EXPECT_EQ(record.connection, "usb:0403:6001");
  EXPECT_EQ(nlohmann::json::parse(record.spectral_configuration), (nlohmann::json{{"model", "pr730"},
                                                                                  {"reported_model", "PR-730/735"},
                                                                                  {"family", "pr7xx"},
                                                                                  {"firmware", "2.22D"},
                                                                                  {"points", 401},
                                                                                  {"first_nm", 380},
                                                                                  {"last_nm", 780},
                                                                                  {"step_nm", 1},
                                                                                  {"bandwidth_nm", 0.5}}));
}

// A PR-650 has no firmware report, and a model skinspec does not know has no model id.
TEST(StoreRecordsTest, WhatTheMeterDidNotSayIsStoredAsNull) {
  drivers::Identity identity;
  identity.reported_model = "PR-650";
  identity.serial_number = "60912345";
  identity.grid = {380, 780, 4, 101};
  identity.configuration = {101, 8, 380, 780, 4};
  const auto configuration = nlohmann::json::parse(instrument_record(identity, "tcp:h:1").spectral_configuration);
  EXPECT_TRUE(configuration["model"].is_null()) << configuration;
  EXPECT_TRUE(configuration["firmware"].is_null()) << configuration;
  EXPECT_EQ(configuration["family"], "pr650");
  EXPECT_EQ(configuration["points"], 101);
  EXPECT_EQ(configuration["bandwidth_nm"], 8.0);
}

TEST(StoreRecordsTest, ARejectedReadingKeepsItsCodeReasonAndRawReply) {
  const drivers::InstrumentError error{drivers::InstrumentError::Kind::bad_reading, "quality 19: overload", 19,
                                       "19,0\r\n"};
  const store::Time at(std::chrono::seconds(5));
  const auto r = rejected_reading_record(error, drivers::Family::pr650, 3, at);
  EXPECT_EQ(r.attempt, 3);
  EXPECT_EQ(r.quality_code, 19);
  EXPECT_EQ(r.quality, drivers::pr650::quality_message(19));
  EXPECT_EQ(r.reason, "bad_reading: quality 19: overload");
  EXPECT_EQ(r.raw_reply, "19,0\r\n");
  EXPECT_EQ(r.measured_at, at);
}

// A newer meter's negative status is worded by its own table, not the PR-650's quality codes.
TEST(StoreRecordsTest, ARejectedReadingOfANewerMeterIsWordedByItsFamilysTable) {
  const drivers::InstrumentError error{drivers::InstrumentError::Kind::bad_reading, "too dark: weak light signal (-8)",
                                       -8, "-8\r\n"};
  const auto r = rejected_reading_record(error, drivers::Family::pr6xx, 1, store::Time{});
  EXPECT_EQ(r.quality_code, -8);
  EXPECT_EQ(r.quality, drivers::pr6xx::error_message(-8));
  EXPECT_NE(r.quality, drivers::pr650::quality_message(-8));
}

TEST(MeasurePolicyTest, BandIntegratedRadianceIsTheTrapezoidSum) {
  EXPECT_DOUBLE_EQ(band_integrated({{400, 500, 600}, {1, 3, 1}}), 100 * 2 + 100 * 2);
  EXPECT_EQ(band_integrated({}), 0);
}

TEST(MeasurePolicyTest, ALampChangeBeyondTheToleranceWarnsEitherWay) {
  const MeasurePolicy policy;  // 5 %
  EXPECT_FALSE(lamp_change_warning(white(0, 1.04), white(3, 1.0), policy));
  EXPECT_FALSE(lamp_change_warning(white(0, 0.96), white(3, 1.0), policy));
  const auto brighter = lamp_change_warning(white(0, 1.2), white(3, 1.0), policy);
  ASSERT_TRUE(brighter);
  EXPECT_THAT(*brighter, StartsWith("lamp_changed:"));
  EXPECT_THAT(*brighter, HasSubstr("+20.0 %"));
  EXPECT_THAT(*brighter, HasSubstr("measurement 3"));
  EXPECT_THAT(*lamp_change_warning(white(0, 0.5), white(3, 1.0), policy), HasSubstr("-50.0 %"));
  // A dark earlier white says nothing about the lamp.
  EXPECT_FALSE(lamp_change_warning(white(0, 1.0), white(3, 0.0), policy));

  auto warned = white(4, 1.2);
  warned.warnings = {*brighter};
  EXPECT_THAT(*inherited_lamp_warning(warned), HasSubstr("white 4"));
  EXPECT_FALSE(inherited_lamp_warning(white(5, 1.0)));
}

TEST(MeasurePolicyTest, AWhiteOlderThanTheLimitWarns) {
  MeasurePolicy policy;
  policy.white_max_age_s = 60;
  const auto w = white(7, 1.0, 1000);
  EXPECT_FALSE(white_age_warning(w, store::Time(std::chrono::seconds(1060)), policy));
  const auto stale = white_age_warning(w, store::Time(std::chrono::seconds(1061)), policy);
  ASSERT_TRUE(stale);
  EXPECT_THAT(*stale, StartsWith("white_stale:"));
  EXPECT_THAT(*stale, HasSubstr("61.0 s"));
  EXPECT_THAT(*stale, HasSubstr("measurement 7"));
}

TEST(MeasurePolicyTest, SettingsOutOfRangeAreExplained) {
  EXPECT_FALSE(check(MeasurePolicy{}));
  EXPECT_THAT(*check(MeasurePolicy{.max_rejected_readings = -1}), HasSubstr("max_rejected_readings"));
  EXPECT_THAT(*check(MeasurePolicy{.white_max_age_s = 0}), HasSubstr("white_max_age_s"));
  EXPECT_THAT(*check(MeasurePolicy{.lamp_change_tolerance = std::nan("")}), HasSubstr("lamp_change_tolerance"));
}

TEST(MeasurePolicyTest, ARejectionNamesItsAttemptReasonAndStoredRow) {
  const drivers::InstrumentError error{drivers::InstrumentError::Kind::bad_reading, "quality 19: overload", 19, "19,0"};
  EXPECT_EQ(rejection_warning(2, error, 12),
            "rejected_reading: reading attempt 2 rejected (bad_reading: quality 19: overload); its raw reply is "
            "rejected reading 12");
}

TEST(MeasurePolicyTest, EachDriverFailureEndsAJobWithItsOwnCode) {
  using Kind = drivers::InstrumentError::Kind;
  using Code = store::JobErrorCode;
  const std::vector<std::pair<Kind, Code>> expected = {
      {Kind::no_contact, Code::no_contact},   {Kind::lost, Code::lost},         {Kind::protocol, Code::protocol},
      {Kind::bad_reading, Code::bad_reading}, {Kind::rejected, Code::rejected}, {Kind::cancelled, Code::cancelled},
      {Kind::transport, Code::transport}};
  for (const auto& [kind, code] : expected) {
    const auto error = job_error({kind, "what the driver said", -1, {}});
    EXPECT_EQ(error.code, code) << drivers::to_string(kind);
    EXPECT_EQ(error.message, "what the driver said");
    EXPECT_EQ(store::to_string(error.code), drivers::to_string(kind));  // the same word on both sides
  }
}

TEST(MeasurePolicyTest, ACancelledJobIsKnownByItsCode) {
  EXPECT_EQ(cancellation(store::JobErrorCode::cancelled),
            (store::JobError{store::JobErrorCode::cancelled, "cancelled by request"}));
  EXPECT_EQ(cancellation(store::JobErrorCode::stopped),
            (store::JobError{store::JobErrorCode::stopped, "the service stopped"}));
  EXPECT_EQ(ended_state(cancellation(store::JobErrorCode::cancelled)), store::JobState::cancelled);
  EXPECT_EQ(ended_state(cancellation(store::JobErrorCode::stopped)), store::JobState::cancelled);
  // Its words do not make a job cancelled.
  EXPECT_EQ(ended_state({store::JobErrorCode::lost, "cancelled by request"}), store::JobState::failed);
  EXPECT_EQ(ended_state({store::JobErrorCode::store, "disk full"}), store::JobState::failed);
}

}  // namespace
}  // namespace skinspec::daemon
