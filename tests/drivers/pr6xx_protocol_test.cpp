// The PR-655/670/680 and PR-7xx protocol: the model table, the commands byte for byte, every
// reply of the manuals' example exchanges (tests/data/pr6xx/), every variant the sources
// disagree on, and damaged replies, each refused with its kind of error.

#include "skinspec/drivers/pr6xx_protocol.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "skinspec/drivers/meter_profile.hpp"
#include "skinspec/drivers/pr7xx_protocol.hpp"
#include "support/protocol_checks.hpp"

namespace skinspec::drivers::pr6xx {
namespace {

using testing::duplicate_line;
using ::testing::ElementsAre;
using testing::error_of;
using ::testing::HasSubstr;
using testing::printable;
using testing::remove_line;
using testing::replace_all;
using testing::replace_line;
using Kind = ProtocolError::Kind;
using namespace std::string_view_literals;

std::string reply(const std::string& name) { return testing::file_bytes(PR6XX_TEST_DATA_DIR, name); }

constexpr Grid kGrid4nm{380, 780, 4, 101};
constexpr Grid kGrid2nm{380, 780, 2, 201};
constexpr Grid kGrid1nm{380, 780, 1, 401};
constexpr Grid kGridTo1080{380, 1080, 2, 351};
constexpr Grid kGridTo1100{380, 1100, 2, 361};

// The sum of the values times the step: the meter's integrated value (M655 p.116).
double integral(const SpectralReport& report, int step_nm) {
  return step_nm * std::accumulate(report.values.begin(), report.values.end(), 0.0);
}

std::vector<int> wavelengths(const Grid& grid) {
  std::vector<int> out;
  for (int nm = grid.first_nm; nm <= grid.last_nm; nm += grid.step_nm) out.push_back(nm);
  return out;
}

SpectralReport parsed(const std::string& name, const Grid& grid) {
  const auto report = parse_spectral(reply(name), grid);
  if (!report) {
    ADD_FAILURE() << name << ": " << report.error().message;
    return {};
  }
  return *report;
}

// ---- The model table ----------------------------------------------------------------------

struct ModelRow {
  Model model;
  Family family;
  std::string_view id, d111;
  std::optional<Grid> grid;
  Grid simulator_grid;
  ExposureRange exposure;
  bool sensitivity, aperture, trigger_poll_abort;
  bool padded_errors;
  int exponent_digits;
};

// The design's table of models (docs/pr6xx-protocol.md, "Models"), written out again here.
const std::vector<ModelRow>& expected_models() {
  static const std::vector<ModelRow> rows = {
      {Model::pr650, Family::pr650, "pr650", "", kGrid4nm, kGrid4nm, {10, 6000, 0}, false, false, false, false, 2},
      {Model::pr655, Family::pr6xx, "pr655", "PR-655", kGrid4nm, kGrid4nm, {3, 6000, 0}, false, false, false, false, 3},
      {Model::pr670,
       Family::pr6xx,
       "pr670",
       "PR-670",
       kGrid2nm,
       kGrid2nm,
       {6, 6000, 30000},
       true,
       true,
       false,
       false,
       2},
      {Model::pr680,
       Family::pr6xx,
       "pr680",
       "PR-680",
       std::nullopt,
       kGrid2nm,
       {6, 6000, 30000},
       true,
       true,
       false,
       false,
       2},
      {Model::pr730,
       Family::pr7xx,
       "pr730",
       "PR-730/735",
       kGrid1nm,
       kGrid1nm,
       {12, 120000, 300000},
       true,
       true,
       true,
       false,
       2},
      {Model::pr735,
       Family::pr7xx,
       "pr735",
       "PR-730/735",
       kGridTo1080,
       kGridTo1080,
       {12, 120000, 300000},
       true,
       true,
       true,
       false,
       2},
      {Model::pr740,
       Family::pr7xx,
       "pr740",
       "PR-740",
       kGrid1nm,
       kGrid1nm,
       {12, 120000, 300000},
       true,
       true,
       true,
       true,
       2},
      {Model::pr745,
       Family::pr7xx,
       "pr745",
       "PR-745",
       kGridTo1080,
       kGridTo1080,
       {12, 120000, 300000},
       true,
       true,
       true,
       true,
       2},
      {Model::pr788,
       Family::pr7xx,
       "pr788",
       "PR-788",
       kGrid1nm,
       kGrid1nm,
       {12, 120000, 300000},
       true,
       true,
       true,
       true,
       2},
  };
  return rows;
}

TEST(MeterProfiles, EveryModelHasItsRowInEnumOrder) {
  const auto profiles = all_profiles();
  ASSERT_EQ(profiles.size(), expected_models().size());
  for (std::size_t i = 0; i < profiles.size(); ++i) {
    const MeterProfile& p = profiles[i];
    const ModelRow& row = expected_models()[i];
    SCOPED_TRACE(std::string(row.id));
    EXPECT_EQ(p.model, row.model);
    EXPECT_EQ(&profile(row.model), &p);
    EXPECT_EQ(p.family, row.family);
    EXPECT_EQ(p.id, row.id);
    EXPECT_EQ(p.d111, row.d111);
    EXPECT_EQ(p.grid, row.grid);
    EXPECT_EQ(p.simulator_grid, row.simulator_grid);
    EXPECT_EQ(p.exposure.min_ms, row.exposure.min_ms);
    EXPECT_EQ(p.exposure.max_ms, row.exposure.max_ms);
    EXPECT_EQ(p.exposure.max_extended_ms, row.exposure.max_extended_ms);
    EXPECT_EQ(p.caps.sensitivity, row.sensitivity);
    EXPECT_EQ(p.caps.aperture, row.aperture);
    EXPECT_EQ(p.caps.trigger_poll_abort, row.trigger_poll_abort);
    EXPECT_EQ(p.caps.remote_keyword, row.family != Family::pr650);
    EXPECT_EQ(p.wire.padded_errors, row.padded_errors);
    EXPECT_EQ(p.wire.data_exponent_digits, row.exponent_digits);
    EXPECT_EQ(p.wire.banner, BannerEnd::none);
    EXPECT_EQ(p.errors, row.family == Family::pr650 ? ErrorTable::pr650_quality : ErrorTable::pr6xx);
    EXPECT_EQ(p.sync, row.family == Family::pr650 ? SyncStyle::setup_field : SyncStyle::ss_sk);
    EXPECT_EQ(p.pacing.count(), row.family == Family::pr650 ? 0 : 50);
    EXPECT_EQ(p.serial.size(), 8u) << "PTB670 reads 8 characters of D110";
    EXPECT_THAT(std::string(p.name), ::testing::StartsWith("PR-"));
  }
}

TEST(MeterProfiles, GridsAreConsistentAndVariantsAreTheOnesTheSourcesGive) {
  for (const MeterProfile& p : all_profiles()) {
    SCOPED_TRACE(std::string(p.id));
    if (p.grid) {
      EXPECT_TRUE(p.grid->consistent());
    }
    ASSERT_TRUE(p.simulator_grid);
    EXPECT_TRUE(p.simulator_grid->consistent());
    for (const auto& variant : p.grid_variants) {
      if (variant) {
        EXPECT_TRUE(variant->consistent());
      }
    }
  }
  EXPECT_EQ(profile(Model::pr730).grid_variants[0], kGrid2nm) << "the D120 example of M730, M730b and M740";
  EXPECT_EQ(profile(Model::pr740).grid_variants[0], kGrid2nm);
  EXPECT_EQ(profile(Model::pr735).grid_variants[0], kGridTo1100) << "M730 p.11";
  EXPECT_FALSE(profile(Model::pr670).grid_variants[0]);
}

TEST(MeterProfiles, GridConsistency) {
  EXPECT_TRUE((Grid{380, 780, 2, 201}).consistent());
  EXPECT_FALSE((Grid{380, 780, 1, 201}).consistent());
  EXPECT_FALSE((Grid{380, 781, 2, 201}).consistent());
  EXPECT_FALSE((Grid{780, 380, 2, 201}).consistent());
  EXPECT_FALSE((Grid{380, 780, 0, 201}).consistent());
  EXPECT_FALSE(Grid{}.consistent());
}

TEST(MeterProfiles, LookupById) {
  for (const MeterProfile& p : all_profiles()) EXPECT_EQ(model_from_id(p.id), p.model);
  EXPECT_EQ(model_from_id("PR670"), Model::pr670);
  EXPECT_EQ(model_from_id("Pr730"), Model::pr730);
  for (const std::string_view unknown : {"", "670", "pr-670", "pr810", "pr670 ", "auto"}) {
    EXPECT_EQ(model_from_id(unknown), std::nullopt) << unknown;
  }
  EXPECT_EQ(to_string(Family::pr650), "pr650");
  EXPECT_EQ(to_string(Family::pr6xx), "pr6xx");
  EXPECT_EQ(to_string(Family::pr7xx), "pr7xx");
}

TEST(MeterProfiles, ReportedModelsInEverySpelling) {
  for (const std::string_view text : {"PR-670", "pr670", "PR 670", "  PR-670 ", "670", "Pr - 670", "PR-670L"}) {
    const auto match = match_reported_model(text);
    EXPECT_THAT(match.candidates, ElementsAre(Model::pr670)) << text;
  }
  EXPECT_EQ(match_reported_model("  PR-670 ").reported, "PR-670");
  EXPECT_THAT(match_reported_model("PR-730/735").candidates, ElementsAre(Model::pr730, Model::pr735));
  EXPECT_THAT(match_reported_model("PR-730/PR-735").candidates, ElementsAre(Model::pr730, Model::pr735));
  EXPECT_THAT(match_reported_model("PR-680L").candidates, ElementsAre(Model::pr680));
  EXPECT_THAT(match_reported_model("PR-655/655").candidates, ElementsAre(Model::pr655));
  EXPECT_THAT(match_reported_model("PR-740/810").candidates, ElementsAre(Model::pr740));
  for (const std::string_view unknown : {"PR-810", "", "   ", "SpectraScan", "PR-", "/", "PR-67O",
                                         "PR-6\x01"
                                         "70"}) {
    EXPECT_TRUE(match_reported_model(unknown).candidates.empty()) << printable(unknown);
  }
  EXPECT_EQ(match_reported_model("PR-810").reported, "PR-810");
  // Every model's own D111 names it.
  for (const MeterProfile& p : all_profiles()) {
    if (p.d111.empty()) continue;
    EXPECT_THAT(match_reported_model(p.d111).candidates, ::testing::Contains(p.model)) << p.id;
  }
}

TEST(MeterProfiles, SeveralCandidatesAreResolvedByTheGrid) {
  const auto both = match_reported_model("PR-730/735");
  EXPECT_EQ(resolve_model(both, kGrid1nm), Model::pr730);
  EXPECT_EQ(resolve_model(both, kGrid2nm), Model::pr730) << "the manuals' D120 example";
  EXPECT_EQ(resolve_model(both, kGridTo1080), Model::pr735);
  EXPECT_EQ(resolve_model(both, kGridTo1100), Model::pr735);
  EXPECT_EQ(resolve_model(both, kGrid4nm), std::nullopt);
  EXPECT_EQ(resolve_model(match_reported_model("PR-680"), Grid{380, 1000, 5, 125}), Model::pr680)
      << "one candidate: D120 is authoritative";
  EXPECT_EQ(resolve_model(match_reported_model("PR-810"), kGrid2nm), std::nullopt);
}

// ---- Commands -----------------------------------------------------------------------------

TEST(Pr6xxCommands, RemoteModeKeywordsHaveNoTerminator) {
  EXPECT_EQ(kRemoteKeyword, "PHOTO");
  EXPECT_EQ(kQuit, "Q");
  EXPECT_EQ(kBanner, " REMOTE MODE");
  EXPECT_EQ(kBanner.size(), 12u) << "PTBCM and BL670 compare exactly 12 characters";
}

TEST(Pr6xxCommands, ExactBytesOfEveryCommand) {
  EXPECT_EQ(format_report(5), "D5\r");
  EXPECT_EQ(format_report(110), "D110\r");
  EXPECT_EQ(format_report(111), "D111\r");
  EXPECT_EQ(format_report(120), "D120\r");
  EXPECT_EQ(format_report(117), "D117\r");
  EXPECT_EQ(format_measure(5), "M5\r");
  EXPECT_EQ(format_exposure(0), "SE0\r");
  EXPECT_EQ(format_exposure(6), "SE00006\r");
  EXPECT_EQ(format_exposure(250), "SE00250\r");
  EXPECT_EQ(format_exposure(30000), "SE30000\r");
  EXPECT_EQ(format_exposure(99999), "SE99999\r");
  EXPECT_EQ(format_exposure(120000), "SE120000\r");
  EXPECT_EQ(format_exposure(300000), "SE300000\r");
  EXPECT_EQ(format_averages(1), "SN01\r");
  EXPECT_EQ(format_averages(99), "SN99\r");
  EXPECT_EQ(format_sync_mode(SyncMode::none), "SS0\r");
  EXPECT_EQ(format_sync_mode(SyncMode::automatic), "SS1\r");
  EXPECT_EQ(format_sync_mode(SyncMode::user), "SS3\r");
  EXPECT_EQ(format_sync_frequency(20), "SK020\r");
  EXPECT_EQ(format_sync_frequency(60), "SK060\r");
  EXPECT_EQ(format_sync_frequency(400), "SK400\r");
  EXPECT_EQ(format_sensitivity(false), "SH0\r");
  EXPECT_EQ(format_sensitivity(true), "SH1\r");
  EXPECT_EQ(format_aperture(1), "SF1\r");
  EXPECT_EQ(format_units(true), "SU1\r");
  EXPECT_EQ(format_units(false), "SU0\r");
  EXPECT_EQ(format_flicker(), "F\r");
  EXPECT_EQ(pr7xx::format_trigger(), "T\r");
  EXPECT_EQ(pr7xx::format_poll(), "P\r");
  EXPECT_EQ(pr7xx::format_abort(), "A\r");
  EXPECT_EQ(pr7xx::format_last_error(), "V\r");
}

TEST(Pr6xxCommands, UpperCaseAndTheTerminatorAsked) {
  EXPECT_EQ(format_command("d111"), "D111\r");
  EXPECT_EQ(format_command("se00250"), "SE00250\r");
  EXPECT_EQ(format_report(111, {.terminator = '\n'}), "D111\n");
  EXPECT_EQ(format_measure(5, {.terminator = '\n'}), "M5\n");
  EXPECT_EQ(pr7xx::format_poll({.terminator = '\n'}), "P\n");
}

TEST(Pr6xxCommands, WhenACommandIsComplete) {
  for (const std::string_view whole : {"PHOTO", "Q", "D5\r", "D111\n", "M5\r\n", "PHOTO\n", "\r"}) {
    EXPECT_TRUE(command_complete(whole)) << printable(whole);
  }
  for (const std::string_view pending : {"", "P", "PHOT", "D5", "D11", "PHOTOX", "q", "photo", "QQ"}) {
    EXPECT_FALSE(command_complete(pending)) << printable(pending);
  }
}

// ---- The banner, echo and where a reply ends ----------------------------------------------

TEST(Pr6xxBanner, AloneWithAndWithoutItsLineEnd) {
  const auto alone = split_banner(reply("pr670_photo.txt"));
  EXPECT_EQ(alone.found, BannerSplit::Found::whole);
  EXPECT_FALSE(alone.line_end);
  EXPECT_EQ(alone.rest, "");
  for (const std::string_view ended :
       {" REMOTE MODE\r\n", " REMOTE MODE\n", " REMOTE MODE\r", "\r\n REMOTE MODE\r\n"}) {
    const auto split = split_banner(ended);
    EXPECT_EQ(split.found, BannerSplit::Found::whole) << printable(ended);
    EXPECT_TRUE(split.line_end) << printable(ended);
    EXPECT_EQ(split.rest, "") << printable(ended);
  }
  EXPECT_EQ(split_banner("REMOTE MODE\r\n").found, BannerSplit::Found::whole) << "its blank lost";
}

TEST(Pr6xxBanner, GluedToTheNextReply) {
  const std::string glued = reply("pr730_d111_glued.txt");
  const auto split = split_banner(glued);
  ASSERT_EQ(split.found, BannerSplit::Found::whole);
  EXPECT_FALSE(split.line_end);
  EXPECT_EQ(split.rest, "00000,PR-730/735\r\n");
  const auto model = parse_text_report(split.rest);
  ASSERT_TRUE(model) << model.error().message;
  EXPECT_EQ(model->text, "PR-730/735");
  EXPECT_EQ(split_banner(" REMOTE MODE\r\n00000,PR-670\r\n").rest, "00000,PR-670\r\n");
}

TEST(Pr6xxBanner, PartialMeansWaitAndOtherBytesAreNoBanner) {
  for (const std::string_view part : {" ", " R", " REM", " REMOTE MOD", "REMOTE", "\r\n REM"}) {
    EXPECT_EQ(split_banner(part).found, BannerSplit::Found::partial) << printable(part);
  }
  for (const std::string_view other : {"", "00000,PR-670\r\n", "-8\r\n", " REMOTE MODX", "000\r\n", "PHOTO", "\r\n"}) {
    const auto split = split_banner(other);
    EXPECT_EQ(split.found, BannerSplit::Found::none) << printable(other);
    EXPECT_EQ(split.rest, other);
  }
}

TEST(Pr6xxEcho, EchoAndPromptsAreStripped) {
  EXPECT_EQ(strip_echo("D111\r\n00000,PR-670\r\n>", "D111\r"), "00000,PR-670\r\n");
  EXPECT_EQ(strip_echo("d111\r00000,PR-670\r\n", "D111\r"), "00000,PR-670\r\n");
  EXPECT_EQ(strip_echo("00000,PR-670\r\n", "D111\r"), "00000,PR-670\r\n");
  EXPECT_EQ(strip_echo("D1", "D111\r"), "") << "only part of the echo: no reply yet";
  EXPECT_EQ(strip_echo("Backlight set to 3 %\r\n", "B3\r"), "Backlight set to 3 %\r\n");
}

TEST(Pr6xxReplySize, LinesSpectraAndListings) {
  EXPECT_EQ(reply_size(ReplyShape::line, "0000\r\n"), 6u);
  EXPECT_EQ(reply_size(ReplyShape::line, "0000"), 0u);
  EXPECT_EQ(reply_size(ReplyShape::line, "\r\n00000,PR-670\r\n00000,67065106\r\n"), 16u);

  const std::string m5 = reply("pr670_m5.txt");
  EXPECT_EQ(reply_size(ReplyShape::spectral, m5, 201), m5.size());
  EXPECT_EQ(reply_size(ReplyShape::spectral, m5 + "0000\r\n", 201), m5.size());
  EXPECT_EQ(reply_size(ReplyShape::spectral, m5.substr(0, m5.size() - 3), 201), 0u);
  EXPECT_EQ(reply_size(ReplyShape::spectral, m5, 0), 0u) << "without D120's count a whole report is not known";
  EXPECT_EQ(reply_size(ReplyShape::spectral, "-8\r\n", 201), 4u) << "the code alone is whole";
  EXPECT_EQ(reply_size(ReplyShape::spectral, "-0008\r\n", 201), 7u);
  EXPECT_EQ(reply_size(ReplyShape::spectral, "-8", 201), 0u);

  const std::string d117 = reply("pr670_d117.txt");
  EXPECT_EQ(reply_size(ReplyShape::listing, d117), d117.size());
  EXPECT_EQ(reply_size(ReplyShape::listing, d117.substr(0, 30)), 20u);
  EXPECT_EQ(reply_size(ReplyShape::listing, "00000,0,1"), 0u);
}

// ---- Statuses and error codes -------------------------------------------------------------

TEST(Pr6xxStatus, EveryWidthAndBothErrorForms) {
  const std::vector<std::pair<std::string_view, Status>> cases = {
      {"0000\r\n", {0, 4}},      {"00000\r\n", {0, 5}},         {"0001\r\n", {1, 4}},    {"-8\r\n", {-8, 1}},
      {"-0008\r\n", {-8, 4}},    {"-1010\r\n", {-1010, 4}},     {"-1035\n", {-1035, 4}}, {"-2000\r", {-2000, 4}},
      {"\r\n0000\r\n>", {0, 4}}, {"> \r\n-8\r\n\r\n", {-8, 1}},
  };
  for (const auto& [text, status] : cases) {
    const auto parsed_status = parse_status(text);
    ASSERT_TRUE(parsed_status) << printable(text) << ": " << parsed_status.error().message;
    EXPECT_EQ(*parsed_status, status) << printable(text);
  }
  EXPECT_EQ(parse_status(reply("pr670_setup.txt")), (Status{0, 4}));
  EXPECT_EQ(parse_status(reply("pr670_se_refused.txt")), (Status{-1010, 4}));
  EXPECT_EQ(parse_status(reply("pr655_sh_refused.txt")), (Status{-1035, 4}));
  EXPECT_EQ(parse_status(reply("pr730_se_busy.txt")), (Status{1, 4}));
  EXPECT_EQ(parse_status(reply("pr655_m0.txt")), (Status{0, 5}));
}

TEST(Pr6xxStatus, RefusesWhatNoMeterSends) {
  EXPECT_KIND(parse_status(""), "", Kind::truncated);
  EXPECT_KIND(parse_status("0000"), "0000", Kind::truncated);
  EXPECT_KIND(parse_status("-"), "-", Kind::truncated);
  EXPECT_KIND(parse_status("-\r\n"), "-", Kind::garbled);
  EXPECT_KIND(parse_status("\r\n"), "\r\n", Kind::garbled);
  EXPECT_KIND(parse_status("000000\r\n"), "six digits", Kind::garbled);
  EXPECT_KIND(parse_status("-100000\r\n"), "six digits", Kind::garbled);
  EXPECT_KIND(parse_status("99999999999999999999\r\n"), "huge", Kind::garbled);
  EXPECT_KIND(parse_status("0a00\r\n"), "0a00", Kind::garbled);
  EXPECT_KIND(parse_status("+8\r\n"), "+8", Kind::garbled);
  EXPECT_KIND(parse_status(" 0000\r\n"), " 0000", Kind::garbled);
  EXPECT_KIND(parse_status("0002\r\n"), "0002", Kind::garbled);
  EXPECT_KIND(parse_status("-8\0\r\n"sv), "-8\\0", Kind::garbled);
  EXPECT_KIND(parse_status("0000,12\r\n"), "0000,12", Kind::surplus);
  const auto surplus = parse_status("0000\r\nxyz");
  EXPECT_KIND(surplus, "0000\r\nxyz", Kind::surplus);
  EXPECT_EQ(error_of(surplus, "").line, 2u);
}

TEST(Pr6xxErrors, TheManualsTableWithItsClasses) {
  const std::vector<std::pair<int, ErrorClass>> table = {
      {0, ErrorClass::ok},
      {1, ErrorClass::busy},
      {-1, ErrorClass::source_not_constant},
      {-2, ErrorClass::overload},
      {-3, ErrorClass::sync},
      {-4, ErrorClass::adaptive},
      {-8, ErrorClass::too_dark},
      {-9, ErrorClass::sync},
      {-10, ErrorClass::sync},
      {-12, ErrorClass::unstable_source},
      {-1000, ErrorClass::command_rejected},
      {-1010, ErrorClass::command_rejected},
      {-1017, ErrorClass::command_rejected},
      {-1019, ErrorClass::command_rejected},
      {-1035, ErrorClass::command_rejected},
      {-2000, ErrorClass::no_data},
  };
  for (const auto& [code, error_class] : table) {
    EXPECT_EQ(to_string(classify(code)), to_string(error_class)) << code;
  }
  for (const int code : {-5, -6, -7, -11, -13, -999, -1036, -1999, -2001, -99999, 2, 77}) {
    EXPECT_EQ(classify(code), ErrorClass::unknown) << code;
  }
}

TEST(Pr6xxErrors, MessagesNameTheCode) {
  EXPECT_EQ(error_message(-8), "weak light (-8)");
  EXPECT_EQ(error_message(-2), "light overload (-2)");
  EXPECT_EQ(error_message(-1000), "illegal command (-1000)");
  EXPECT_EQ(error_message(-1010), "bad exposure time (-1010)");
  EXPECT_EQ(error_message(-1017), "parse error (-1017)");
  EXPECT_EQ(error_message(-2000), "no such report, or no measurement yet (-2000)");
  EXPECT_EQ(error_message(-77), "unknown error code -77");
  EXPECT_THAT(error_message(-12), HasSubstr("unstable"));
}

TEST(Pr6xxErrors, BothFormsOfAnErrorReadAsOneCode) {
  for (const std::string name : {"pr670_m5_dark.txt", "pr740_m5_dark.txt"}) {
    const auto dark = parse_spectral(reply(name), kGrid2nm);
    ASSERT_TRUE(dark) << name << ": " << dark.error().message;
    EXPECT_EQ(dark->status.code, -8) << name;
    EXPECT_EQ(classify(dark->status.code), ErrorClass::too_dark);
    EXPECT_TRUE(dark->values.empty());
  }
  EXPECT_EQ(parse_status("-8\r\n")->code, parse_status("-0008\r\n")->code);
}

// ---- Identity and configuration reports ---------------------------------------------------

TEST(Pr6xxTextReports, SerialModelAndFirmware) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"pr670_d111.txt", "PR-670"}, {"pr670_d110.txt", "67065106"},
      {"pr670_d114.txt", "2.22D"},  {"pr655_d111.txt", "PR-655"},
      {"pr740_d111.txt", "PR-740"}, {"pr745_d111.txt", "PR-745"},
      {"pr788_d111.txt", "PR-788"}, {"pr670_d14.txt", "User Sync,120.00 Hertz"},
  };
  for (const auto& [name, text] : cases) {
    const auto report = parse_text_report(reply(name));
    ASSERT_TRUE(report) << name << ": " << report.error().message;
    EXPECT_EQ(report->status, (Status{0, 5})) << name;
    EXPECT_EQ(report->text, text) << name;
  }
  EXPECT_EQ(parse_text_report("00000,67065106  \r\n")->text, "67065106") << "PTB670 keeps trailing blanks";
  EXPECT_EQ(parse_text_report("0000,PR-670\n")->text, "PR-670");
  const auto none = parse_text_report(reply("pr670_d5_none.txt"));
  ASSERT_TRUE(none);
  EXPECT_EQ(none->status.code, -2000);
  EXPECT_EQ(none->text, "");
}

TEST(Pr6xxTextReports, RefusesDamagedReports) {
  EXPECT_KIND(parse_text_report("00000,PR-670"), "no line end", Kind::truncated);
  EXPECT_KIND(parse_text_report("00000,"), "00000,", Kind::truncated);
  EXPECT_KIND(parse_text_report("00000,\r\n"), "00000,", Kind::garbled);
  EXPECT_KIND(parse_text_report("00000,   \r\n"), "blanks only", Kind::garbled);
  EXPECT_KIND(parse_text_report("00000\r\n"), "00000", Kind::garbled);
  EXPECT_KIND(parse_text_report("00000,PR-6\0"
                                "70\r\n"sv),
              "NUL", Kind::garbled);
  EXPECT_KIND(parse_text_report("00000,PR-6\x7f"
                                "70\r\n"),
              "DEL", Kind::garbled);
  EXPECT_KIND(parse_text_report("0x000,PR-670\r\n"), "0x000", Kind::garbled);
  EXPECT_KIND(parse_text_report("60912345\r\n"), "a PR-650's D110", Kind::garbled);
  EXPECT_KIND(parse_text_report("00000,PR-670\r\n00000,PR-670\r\n"), "twice", Kind::surplus);
}

TEST(Pr6xxHardwareConfiguration, EveryModelsGrid) {
  const std::vector<std::pair<std::string, Grid>> cases = {
      {"pr670_d120.txt", kGrid2nm},
      {"pr655_d120.txt", kGrid4nm},
      {"pr730_d120.txt", kGrid1nm},
      {"pr735_d120.txt", kGridTo1080},
  };
  for (const auto& [name, grid] : cases) {
    const auto configuration = parse_hardware_configuration(reply(name));
    ASSERT_TRUE(configuration) << name << ": " << configuration.error().message;
    EXPECT_EQ(configuration->status.code, 0);
    EXPECT_EQ(configuration->grid, grid) << name;
    EXPECT_EQ(configuration->bandwidth_nm, 0);
    EXPECT_EQ(configuration->pixels, 256);
    EXPECT_EQ(configuration->first_pixel, 7);
    EXPECT_EQ(configuration->last_pixel, 247);
  }
  const auto short_form = parse_hardware_configuration("00000,201,0.00,380,780,2\r\n");
  ASSERT_TRUE(short_form) << short_form.error().message;
  EXPECT_EQ(short_form->grid, kGrid2nm);
  EXPECT_FALSE(short_form->pixels);
  EXPECT_DOUBLE_EQ(parse_hardware_configuration("00000,201,8.5,380,780,2\r\n")->bandwidth_nm, 8.5);
  EXPECT_EQ(parse_hardware_configuration("-2000\r\n")->status.code, -2000);
}

TEST(Pr6xxHardwareConfiguration, RefusesWhatIsNotAGrid) {
  const auto inconsistent = parse_hardware_configuration("00000,201,0.00,380,780,1,256,7,247\r\n");
  EXPECT_KIND(inconsistent, "201 points by 1 nm", Kind::garbled);
  EXPECT_THAT(error_of(inconsistent, "").message, HasSubstr("201 points do not fit 380-780 nm by 1 nm"));
  EXPECT_KIND(parse_hardware_configuration("00000,201,0.00,380,780,2,256\r\n"), "7 fields", Kind::truncated);
  EXPECT_KIND(parse_hardware_configuration("00000,201,0.00,380,780\r\n"), "5 fields", Kind::truncated);
  EXPECT_KIND(parse_hardware_configuration("00000,201,0.00,380,780,2,256,7,247,1\r\n"), "10 fields", Kind::surplus);
  EXPECT_KIND(parse_hardware_configuration("00000,2x1,0.00,380,780,2\r\n"), "2x1", Kind::garbled);
  EXPECT_KIND(parse_hardware_configuration("00000,9999999,0.00,380,780,2\r\n"), "huge", Kind::garbled);
  EXPECT_KIND(parse_hardware_configuration("00000,201,1e999,380,780,2\r\n"), "1e999", Kind::garbled);
  EXPECT_KIND(parse_hardware_configuration("00000,201,nan,380,780,2\r\n"), "nan", Kind::garbled);
  EXPECT_KIND(parse_hardware_configuration("00000,201,inf,380,780,2\r\n"), "inf", Kind::garbled);
  EXPECT_KIND(parse_hardware_configuration("00000,201,0.00,380,780,-2\r\n"), "-2", Kind::garbled);
  EXPECT_KIND(parse_hardware_configuration("00000,201,0.00,380,780,2"), "no line end", Kind::truncated);
  EXPECT_KIND(parse_hardware_configuration("0101,008.0,0380.,0780.,004.\r\n"), "a PR-650's D120", Kind::garbled);
}

TEST(Pr6xxFlicker, FrequencyOrNone) {
  const auto flicker = parse_flicker(reply("pr670_f.txt"));
  ASSERT_TRUE(flicker) << flicker.error().message;
  EXPECT_EQ(flicker->status.code, 0);
  EXPECT_EQ(flicker->hz, 60.0);
  const auto none = parse_flicker("-3\r\n");
  ASSERT_TRUE(none) << none.error().message;
  EXPECT_EQ(none->status.code, -3);
  EXPECT_FALSE(none->hz);
  EXPECT_EQ(parse_flicker("0000,120.5 Hertz\r\n")->hz, 120.5);
  EXPECT_EQ(parse_flicker("0000,59.94\r\n")->hz, 59.94);
  EXPECT_EQ(parse_flicker("00000,400.00 Hertz (Period = 2.50 milliseconds)\n")->hz, 400.0);
}

TEST(Pr6xxFlicker, RefusesDamage) {
  EXPECT_KIND(parse_flicker("0000\r\n"), "no frequency", Kind::garbled);
  EXPECT_KIND(parse_flicker("0000"), "cut", Kind::truncated);
  EXPECT_KIND(parse_flicker("0000,\r\n"), "empty", Kind::garbled);
  EXPECT_KIND(parse_flicker("0000,60.0"), "cut", Kind::truncated);
  EXPECT_KIND(parse_flicker("0000,60.00 Hertz (Period"), "cut", Kind::truncated);
  EXPECT_KIND(parse_flicker("0000,6x.00 Hertz\r\n"), "6x", Kind::garbled);
  EXPECT_KIND(parse_flicker("0000,60.00 Herz\r\n"), "Herz", Kind::garbled);
  EXPECT_KIND(parse_flicker("0000,nan Hertz\r\n"), "nan", Kind::garbled);
  EXPECT_KIND(parse_flicker("0000,inf Hertz\r\n"), "inf", Kind::garbled);
  EXPECT_KIND(parse_flicker("0000,1e999 Hertz\r\n"), "1e999", Kind::garbled);
  EXPECT_KIND(parse_flicker("0000,-60.00 Hertz\r\n"), "-60", Kind::garbled);
  EXPECT_KIND(parse_flicker("0000,60.00 Hertz\0\r\n"sv), "NUL", Kind::garbled);
}

TEST(Pr6xxApertures, OneLinePerAperture) {
  const auto list = parse_apertures(reply("pr670_d117.txt"));
  ASSERT_TRUE(list) << list.error().message;
  EXPECT_EQ(list->status.code, 0);
  EXPECT_THAT(list->apertures, ElementsAre(Aperture{0, "1 deg", 0}, Aperture{1, "1/2 deg", 0},
                                           Aperture{2, "1/4 deg", 0}, Aperture{3, "1/8 deg", 0}));
  const auto one = parse_apertures("00000,1,1/2 deg,0.00\r\n");
  ASSERT_TRUE(one) << one.error().message;
  EXPECT_THAT(one->apertures, ElementsAre(Aperture{1, "1/2 deg", 0}));
  const auto none = parse_apertures("-2000\r\n");
  ASSERT_TRUE(none) << none.error().message;
  EXPECT_EQ(none->status.code, -2000);
  EXPECT_TRUE(none->apertures.empty());
}

TEST(Pr6xxApertures, RefusesDamage) {
  const std::string d117 = reply("pr670_d117.txt");
  EXPECT_KIND(parse_apertures(d117.substr(0, d117.size() - 8)), "cut", Kind::truncated);
  EXPECT_KIND(parse_apertures(d117.substr(0, d117.size() - 2)), "no line end", Kind::truncated);
  EXPECT_KIND(parse_apertures(d117 + "-8\r\n"), "an error after the list", Kind::garbled);
  EXPECT_KIND(parse_apertures("00000,1,,0.00\r\n"), "no name", Kind::garbled);
  EXPECT_KIND(parse_apertures("00000,x,1 deg,0.00\r\n"), "x", Kind::garbled);
  EXPECT_KIND(parse_apertures("00000,1,1 deg\r\n"), "3 fields", Kind::truncated);
  EXPECT_KIND(parse_apertures(""), "empty", Kind::truncated);
}

TEST(Pr6xxExposureReport, GainAndTheExposureUsed) {
  const auto report = parse_exposure_report(reply("pr670_d13.txt"));
  ASSERT_TRUE(report) << report.error().message;
  EXPECT_EQ(report->status.code, 0);
  EXPECT_EQ(report->gain, "Fast");
  EXPECT_EQ(report->exposure_ms, 16500);
  EXPECT_EQ(parse_exposure_report("00000,4X Fast,300000 msec\r\n")->exposure_ms, 300000);
  EXPECT_EQ(parse_exposure_report("-2000\r\n")->status.code, -2000);
  EXPECT_KIND(parse_exposure_report("00000,Fast,16500 ms\r\n"), "ms", Kind::truncated);
  EXPECT_KIND(parse_exposure_report("00000,Fast,16500msec\r\n"), "no blank", Kind::garbled);
  EXPECT_KIND(parse_exposure_report("00000,Fast,1650000 msec\r\n"), "huge", Kind::garbled);
  EXPECT_KIND(parse_exposure_report("00000,Fast\r\n"), "2 fields", Kind::truncated);
}

// ---- Colorimetric reports -----------------------------------------------------------------

TEST(Pr6xxColorimetric, TheManualsExamples) {
  const auto d1 = parse_colorimetric(1, reply("pr670_d1.txt"));
  ASSERT_TRUE(d1) << d1.error().message;
  EXPECT_EQ(d1->status.code, 0);
  EXPECT_EQ(d1->units, 0);
  EXPECT_THAT(d1->values, ElementsAre(18.65, 0.4035, 0.4202));
  const auto d2 = parse_colorimetric(2, reply("pr670_d2.txt"));
  ASSERT_TRUE(d2) << d2.error().message;
  EXPECT_THAT(d2->values, ElementsAre(61.36, 18.65, 26.81));
  EXPECT_DOUBLE_EQ(d2->values[1], d1->values[0]) << "Y of D1 and D2";
  const auto d4 = parse_colorimetric(4, reply("pr655_d4.txt"));
  ASSERT_TRUE(d4) << d4.error().message;
  EXPECT_THAT(d4->values, ElementsAre(18.65, 3757, 0.0129));
  const auto d3 = parse_colorimetric(3, "00000,0,1.865e+01,0.2231,0.5227\r\n");
  ASSERT_TRUE(d3) << d3.error().message;
  EXPECT_THAT(d3->values, ElementsAre(18.65, 0.2231, 0.5227));
  const auto d6 = parse_colorimetric(6, "00000,0,2.041e+01,0.4089,0.4151,0.2283,0.5215\r\n");
  ASSERT_TRUE(d6) << d6.error().message;
  EXPECT_THAT(d6->values, ElementsAre(20.41, 0.4089, 0.4151, 0.2283, 0.5215));
}

TEST(Pr6xxColorimetric, EveryUnitsTableAndNumberForm) {
  for (const int units : {0, 1, 2, 3, 11, 12, 13, 14, 111, 112, 113, 114}) {
    const auto report = parse_colorimetric(1, fmt::format("00000,{},1.865e+01,0.4035,0.4202\r\n", units));
    ASSERT_TRUE(report) << units << ": " << report.error().message;
    EXPECT_EQ(report->units, units);
  }
  for (const std::string_view text : {"00000,0,1.865E+01,0.4035,0.4202\r\n", "00000,0,1.865e+001,0.4035,0.4202\r\n",
                                      "0000,0,1.865e+01,.4035,.4202\n"}) {
    const auto report = parse_colorimetric(1, text);
    ASSERT_TRUE(report) << printable(text) << ": " << report.error().message;
    EXPECT_THAT(report->values, ElementsAre(18.65, 0.4035, 0.4202));
  }
  EXPECT_EQ(parse_colorimetric(4, "00000,0,1.865e+01,3757,-0.0031\r\n")->values[2], -0.0031);
  EXPECT_EQ(parse_colorimetric(2, "00000,0,-1.000e-03,0.000e+00,1.000e-03\r\n")->values[0], -0.001);
  const auto dark = parse_colorimetric(1, "-8\r\n");
  ASSERT_TRUE(dark) << dark.error().message;
  EXPECT_EQ(dark->status.code, -8);
  EXPECT_TRUE(dark->values.empty());
}

TEST(Pr6xxColorimetric, RefusesDamage) {
  EXPECT_KIND(parse_colorimetric(5, reply("pr670_d1.txt")), "report 5", Kind::garbled);
  EXPECT_KIND(parse_colorimetric(7, reply("pr670_d1.txt")), "report 7", Kind::garbled);
  for (const int units : {4, 10, 15, 110, 115, 11111}) {
    const std::string text = fmt::format("00000,{},1.865e+01,0.4035,0.4202\r\n", units);
    EXPECT_KIND(parse_colorimetric(1, text), text, Kind::garbled);
  }
  EXPECT_KIND(parse_colorimetric(1, "00000,0,1.865e+01,0.4035\r\n"), "4 fields", Kind::truncated);
  EXPECT_KIND(parse_colorimetric(1, "00000,0,1.865e+01,0.4035,0.42"), "cut", Kind::truncated);
  EXPECT_KIND(parse_colorimetric(1, "00000,0,1.86e+01,0.4035,0.4202\r\n"), "dropped digit", Kind::garbled);
  EXPECT_KIND(parse_colorimetric(1, "00000,0,nan,0.4035,0.4202\r\n"), "nan", Kind::garbled);
  EXPECT_KIND(parse_colorimetric(1, "00000,0,inf,0.4035,0.4202\r\n"), "inf", Kind::garbled);
  EXPECT_KIND(parse_colorimetric(2, "00000,0,9.999e+999,1.000e+00,1.000e+00\r\n"), "9.999e+999", Kind::garbled);
  EXPECT_KIND(parse_colorimetric(4, "00000,0,1.865e+01,3757.0,0.0129\r\n"), "3757.0", Kind::garbled);
  EXPECT_KIND(parse_colorimetric(1, "00000,0,1.865e+01,0.4035,0.4202,1\r\n"), "6 fields", Kind::surplus);
  EXPECT_KIND(parse_colorimetric(1,
                                 "00000,0,1.865e+01,0.4\0"
                                 "035,0.4202\r\n"sv),
              "NUL", Kind::garbled);
}

// ---- Spectral reports ---------------------------------------------------------------------

struct SpectralCase {
  std::string name;
  Grid grid;
  int exponent_digits;
  bool consistent_header;  // a derived report, whose integral is the sum of its values
};

class Pr6xxSpectral : public ::testing::TestWithParam<SpectralCase> {};

TEST_P(Pr6xxSpectral, EveryLineOnTheGridOfD120) {
  const SpectralCase& c = GetParam();
  const auto report = parse_spectral(reply(c.name), c.grid);
  ASSERT_TRUE(report) << report.error().message;
  EXPECT_EQ(report->status, (Status{0, 5}));
  EXPECT_EQ(report->units, 0);
  EXPECT_EQ(report->wavelength_nm, wavelengths(c.grid));
  EXPECT_EQ(report->values.size(), static_cast<std::size_t>(c.grid.points));
  EXPECT_EQ(report->exponent_digits, c.exponent_digits);
  for (const double value : report->values) EXPECT_GT(value, 0);
  if (c.consistent_header) {
    EXPECT_NEAR(integral(*report, c.grid.step_nm), report->integrated, 1e-3 * report->integrated);
  }
}

TEST_P(Pr6xxSpectral, FormatterReproducesTheReplyByteForByte) {
  const SpectralCase& c = GetParam();
  const auto report = parse_spectral(reply(c.name), c.grid);
  ASSERT_TRUE(report) << report.error().message;
  ReplyStyle style;
  style.data_exponent_digits = c.exponent_digits;
  EXPECT_EQ(format_spectral_reply(*report, style), reply(c.name));
}

TEST_P(Pr6xxSpectral, EveryCutIsTruncated) {
  const SpectralCase& c = GetParam();
  const std::string whole = reply(c.name);
  // Every proper prefix but the one ending in the last CR, which already ends the last line.
  for (std::size_t length = 0; length + 1 < whole.size(); ++length) {
    const std::string cut = whole.substr(0, length);
    const auto report = parse_spectral(cut, c.grid);
    ASSERT_FALSE(report) << "accepted after " << length << " bytes";
    ASSERT_EQ(to_string(report.error().kind), "truncated") << length << ": " << report.error().message;
  }
  EXPECT_TRUE(parse_spectral(whole.substr(0, whole.size() - 1), c.grid));
}

INSTANTIATE_TEST_SUITE_P(Models, Pr6xxSpectral,
                         ::testing::Values(SpectralCase{"pr670_m5.txt", kGrid2nm, 2, false},
                                           SpectralCase{"pr655_m5.txt", kGrid4nm, 3, true},
                                           SpectralCase{"pr730_d5.txt", kGrid1nm, 2, true},
                                           SpectralCase{"pr735_d5.txt", kGridTo1080, 2, true}),
                         [](const ::testing::TestParamInfo<SpectralCase>& test) {
                           return test.param.name.substr(0, test.param.name.find('.'));
                         });

TEST(Pr6xxSpectralReport, TheManualsExample) {
  const auto report = parsed("pr670_m5.txt", kGrid2nm);
  EXPECT_EQ(report.peak_nm, 0.0);
  EXPECT_DOUBLE_EQ(report.integrated, 1.827e-01);
  EXPECT_DOUBLE_EQ(report.integrated_photon, 5.147e+01);
  ASSERT_EQ(report.values.size(), 201u);
  EXPECT_DOUBLE_EQ(report.values[1], 9.910e-07);
  EXPECT_DOUBLE_EQ(report.values[2], 5.356e-06);
  EXPECT_DOUBLE_EQ(report.values[5], 1.127e-05);
  EXPECT_EQ(report.wavelength_nm[5], 390);
  EXPECT_EQ(reply("pr670_m5.txt").size(), 3055u);
  EXPECT_EQ(reply("pr655_m5.txt").size(), 1656u) << "PTB655's 16-byte stride";
  EXPECT_EQ(reply("pr730_d5.txt").size(), 6055u);
  EXPECT_EQ(reply("pr735_d5.txt").size(), 5346u);
}

TEST(Pr6xxSpectralReport, AFailedMeasurementCarriesOnlyItsCode) {
  for (const std::string_view text : {"-8\r\n", "-0008\r\n", "\r\n-8\r\n>", "-2000\r\n", "-12\n"}) {
    const auto report = parse_spectral(text, kGrid2nm);
    ASSERT_TRUE(report) << printable(text) << ": " << report.error().message;
    EXPECT_LT(report->status.code, 0);
    EXPECT_TRUE(report->values.empty());
    EXPECT_TRUE(report->wavelength_nm.empty());
  }
  // A failed header with data after it: the data are never handed out.
  const std::string m5 = reply("pr670_m5.txt");
  const auto failed = parse_spectral(replace_line(m5, 1, "-1,0,0.000e+000,1.827e-01,5.147e+01"), kGrid2nm);
  ASSERT_TRUE(failed) << failed.error().message;
  EXPECT_EQ(failed->status.code, -1);
  EXPECT_TRUE(failed->values.empty());
  EXPECT_KIND(parse_spectral("-8", kGrid2nm), "-8 without line end", Kind::truncated);
}

TEST(Pr6xxSpectralReport, LineEndsExponentLettersPromptsAndBlankLines) {
  const std::string m5 = reply("pr670_m5.txt");
  const auto reference = parsed("pr670_m5.txt", kGrid2nm);
  const std::vector<std::string> variants = {
      replace_all(m5, "\r\n", "\n"),
      replace_all(m5, "\r\n", "\r"),
      replace_all(m5, "e-", "E-"),
      "\r\n" + m5,
      m5 + ">",
      m5 + "\r\n\r\n",
      replace_line(m5, 1, "00000,0,0.000e+000,1.827e-01,5.147e+01\r\n> "),
      replace_line(m5, 1, "0000,0,0.000e+00,1.827e-01,5.147e+01"),
  };
  for (const std::string& variant : variants) {
    const auto report = parse_spectral(variant, kGrid2nm);
    ASSERT_TRUE(report) << printable(variant.substr(0, 80)) << ": " << report.error().message;
    EXPECT_EQ(report->values, reference.values);
    EXPECT_EQ(report->wavelength_nm, reference.wavelength_nm);
  }
  // Negative values (a dark reading) and any units code of either table.
  const auto negative = parse_spectral(replace_line(m5, 2, "380,-1.627e-06"), kGrid2nm);
  ASSERT_TRUE(negative) << negative.error().message;
  EXPECT_DOUBLE_EQ(negative->values[0], -1.627e-06);
  const auto units = parse_spectral(replace_line(m5, 1, "00000,111,0.000e+000,1.827e-01,5.147e+01"), kGrid2nm);
  ASSERT_TRUE(units) << units.error().message;
  EXPECT_EQ(units->units, 111);
}

TEST(Pr6xxSpectralReport, AGridOtherThanD120sIsWrongGrid) {
  // The PR-730's 1 nm report where D120 gave the manuals' 2 nm example, and the reverse.
  const auto on_1nm = parse_spectral(reply("pr730_d5.txt"), kGrid2nm);
  EXPECT_KIND(on_1nm, "401 lines by 1 nm", Kind::wrong_grid);
  EXPECT_THAT(error_of(on_1nm, "").message, HasSubstr("380-780 nm by 1 nm (401 points)"));
  EXPECT_THAT(error_of(on_1nm, "").message, HasSubstr("380-780 nm by 2 nm (201 points)"));
  EXPECT_EQ(error_of(on_1nm, "").line, 3u);
  EXPECT_KIND(parse_spectral(reply("pr670_m5.txt"), kGrid1nm), "201 lines by 2 nm", Kind::wrong_grid);
  EXPECT_KIND(parse_spectral(reply("pr655_m5.txt"), kGrid2nm), "101 lines by 4 nm", Kind::wrong_grid);
  // The PR-735's two ranges: more lines than D120 said, regularly, is another grid.
  const std::string to_1080 = reply("pr735_d5.txt");
  std::string to_1100 = to_1080;
  for (int nm = 1082; nm <= 1100; nm += 2) to_1100 += fmt::format("{},2.130e-04\r\n", nm);
  EXPECT_TRUE(parse_spectral(to_1100, kGridTo1100));
  const auto longer = parse_spectral(to_1100, kGridTo1080);
  EXPECT_KIND(longer, "361 lines where 351", Kind::wrong_grid);
  EXPECT_THAT(error_of(longer, "").message, HasSubstr("380-1100 nm by 2 nm (361 points)"));
  // Fewer lines ending on a line end cannot be told from a reply cut there.
  EXPECT_KIND(parse_spectral(to_1080, kGridTo1100), "351 of 361", Kind::truncated);
  // Data starting at 382 (the manual's cut first line): not the grid D120 gave.
  EXPECT_KIND(parse_spectral(remove_line(reply("pr670_m5.txt"), 2), kGrid2nm), "from 382", Kind::wrong_grid);
}

TEST(Pr6xxSpectralReport, LostRepeatedAndWrongLines) {
  const std::string m5 = reply("pr670_m5.txt");
  const auto lost = parse_spectral(remove_line(m5, 50), kGrid2nm);
  EXPECT_KIND(lost, "a line lost", Kind::wrong_count);
  EXPECT_THAT(error_of(lost, "").message, HasSubstr("200 data lines where 201 are expected"));
  EXPECT_KIND(parse_spectral(duplicate_line(m5, 50), kGrid2nm), "a line repeated", Kind::wrong_count);
  EXPECT_KIND(parse_spectral(duplicate_line(m5, 202), kGrid2nm), "the last line repeated", Kind::wrong_count);
  const auto wrong = parse_spectral(replace_line(m5, 10, "406,1.000e-05"), kGrid2nm);
  EXPECT_KIND(wrong, "406 for 396", Kind::wrong_wavelength);
  EXPECT_EQ(error_of(wrong, "").line, 10u);
  EXPECT_KIND(parse_spectral(m5 + "00000\r\n", kGrid2nm), "a status after the data", Kind::surplus);
  EXPECT_KIND(
      parse_spectral(replace_line(m5, 1, "00000,0,0.000e+000,1.827e-01,5.147e+01\r\n" + m5.substr(0, 38)), kGrid2nm),
      "two headers", Kind::garbled);
}

TEST(Pr6xxSpectralReport, DamagedFieldsAreGarbled) {
  const std::string m5 = reply("pr670_m5.txt");
  const std::vector<std::pair<std::size_t, std::string>> damaged = {
      {3, "382,9.91e-07"},     // a dropped mantissa digit
      {3, "382,9.910e-7"},     // a dropped exponent digit
      {3, "382,9.910e-007"},   // an exponent wider than the first line's
      {3, "382,abcdefghi"},    // not a number
      {3, "382,nan"},          // NaN text
      {3, "382,inf"},          // infinity text
      {3, "382,9.999e+999"},   // beyond a double
      {3, "382;9.910e-07"},    // wrong separator
      {3, "38,9.910e-07"},     // two-digit wavelength
      {3, "382,9.910e-07,1"},  // a third field
      {3, std::string("382,9.9\0"
                      "10e-07"sv)},                   // an embedded NUL
      {1, "00000,9,0.000e+000,1.827e-01,5.147e+01"},  // units no table has
      {1, "00000,0,0.000e+000,nan,5.147e+01"},        // NaN in the header
      {1, std::string("00000,0,0.000e+000,1.8\0"
                      "27e-01,5.147e+01"sv)},
      {1, "0000x,0,0.000e+000,1.827e-01,5.147e+01"},
      {1, "00002,0,0.000e+000,1.827e-01,5.147e+01"},  // a positive status no meter sends
  };
  for (const auto& [line, text] : damaged) {
    const std::string bytes = replace_line(m5, line, text);
    const auto report = parse_spectral(bytes, kGrid2nm);
    EXPECT_KIND(report, text, Kind::garbled);
    EXPECT_EQ(error_of(report, "").line, line) << printable(text);
  }
  EXPECT_KIND(parse_spectral(replace_line(m5, 1, "00000,0,0.000e+000,1.827e-01"), kGrid2nm), "4 header fields",
              Kind::truncated);
  EXPECT_KIND(parse_spectral(replace_line(m5, 1, "00000,0,0.000e+000,1.827e-01,5.147e+01,1"), kGrid2nm),
              "6 header fields", Kind::surplus);
  EXPECT_KIND(parse_spectral(m5, Grid{380, 780, 3, 201}), "an impossible expected grid", Kind::garbled);
  EXPECT_KIND(parse_spectral("", kGrid2nm), "empty", Kind::truncated);
  EXPECT_KIND(parse_spectral("\r\n>\r\n", kGrid2nm), "noise only", Kind::garbled);
}

// ---- Reply formatting ---------------------------------------------------------------------

TEST(Pr6xxFormat, ValuesInBothExponentWidths) {
  EXPECT_EQ(format_value(9.91e-07), "9.910e-07");
  EXPECT_EQ(format_value(9.91e-07, 3), "9.910e-007");
  EXPECT_EQ(format_value(0, 3), "0.000e+000");
  EXPECT_EQ(format_value(18.65, 2, 'E'), "1.865E+01");
  EXPECT_EQ(format_value(-1.5e-3), "-1.500e-03");
  EXPECT_EQ(format_value(1e-120), "0.000e+00");
  EXPECT_EQ(format_value(1e-120, 3), "1.000e-120");
  EXPECT_EQ(format_value(1e120), "9.999e+99");
  EXPECT_EQ(format_value(9.9996e-5), "1.000e-04");
}

TEST(Pr6xxFormat, StatusesBannerAndErrorsPerModel) {
  const ReplyStyle short_style = reply_style(profile(Model::pr670).wire);
  const ReplyStyle padded_style = reply_style(profile(Model::pr740).wire);
  EXPECT_EQ(format_banner(short_style), " REMOTE MODE");
  EXPECT_EQ(format_banner({.banner = BannerEnd::crlf}), " REMOTE MODE\r\n");
  EXPECT_EQ(format_setup_status(0, short_style), reply("pr670_setup.txt"));
  EXPECT_EQ(format_setup_status(1, short_style), reply("pr730_se_busy.txt"));
  EXPECT_EQ(format_setup_status(-1010, short_style), reply("pr670_se_refused.txt"));
  EXPECT_EQ(format_error(-8, short_style), reply("pr670_m5_dark.txt"));
  EXPECT_EQ(format_error(-8, padded_style), reply("pr740_m5_dark.txt"));
  EXPECT_EQ(format_error(-1035, padded_style), "-1035\r\n");
  EXPECT_EQ(format_error(-2000, short_style), reply("pr670_d5_none.txt"));
  EXPECT_EQ(format_error(0, short_style), reply("pr655_m0.txt"));
}

TEST(Pr6xxFormat, EveryExampleReplyByteForByte) {
  const ReplyStyle style = reply_style(profile(Model::pr670).wire);
  EXPECT_EQ(format_text_report("PR-670", style), reply("pr670_d111.txt"));
  EXPECT_EQ(format_text_report("67065106", style), reply("pr670_d110.txt"));
  EXPECT_EQ(format_text_report("2.22D", style), reply("pr670_d114.txt"));
  for (const auto& [name, model] : std::vector<std::pair<std::string, Model>>{
           {"pr655_d111.txt", Model::pr655}, {"pr740_d111.txt", Model::pr740}, {"pr788_d111.txt", Model::pr788}}) {
    EXPECT_EQ(format_text_report(profile(model).d111, style), reply(name));
  }
  for (const std::string name : {"pr670_d120.txt", "pr655_d120.txt", "pr730_d120.txt", "pr735_d120.txt"}) {
    EXPECT_EQ(format_hardware_configuration(*parse_hardware_configuration(reply(name)), style), reply(name));
  }
  EXPECT_EQ(format_flicker_reply({{0, 4}, 60.0}, style), reply("pr670_f.txt"));
  EXPECT_EQ(format_flicker_reply({{-3, 1}, std::nullopt}, style), "-3\r\n");
  EXPECT_EQ(format_apertures_reply(parse_apertures(reply("pr670_d117.txt"))->apertures, style),
            reply("pr670_d117.txt"));
  EXPECT_EQ(format_exposure_report(*parse_exposure_report(reply("pr670_d13.txt")), style), reply("pr670_d13.txt"));
  EXPECT_EQ(format_colorimetric_reply(*parse_colorimetric(1, reply("pr670_d1.txt")), style), reply("pr670_d1.txt"));
  EXPECT_EQ(format_colorimetric_reply(*parse_colorimetric(2, reply("pr670_d2.txt")), style), reply("pr670_d2.txt"));
  EXPECT_EQ(format_colorimetric_reply(*parse_colorimetric(4, reply("pr655_d4.txt")), style), reply("pr655_d4.txt"));
  EXPECT_EQ(format_colorimetric_reply({1, {-8, 1}, 0, {}}, style), "-8\r\n");
}

// Any spectrum on any model's grid, printed in that model's style, reads back as printed.
TEST(Pr6xxFormat, SpectraReadBackOnEveryModelsGrid) {
  std::mt19937 random(15);
  std::uniform_real_distribution<double> exponent(-12, 3);
  for (const MeterProfile& p : all_profiles()) {
    if (p.family == Family::pr650) continue;
    SCOPED_TRACE(std::string(p.id));
    const Grid grid = *p.simulator_grid;
    SpectralReport report;
    report.status = {0, p.wire.data_status_digits};
    report.peak_nm = 5.5e2;
    for (const int nm : wavelengths(grid)) {
      report.wavelength_nm.push_back(nm);
      report.values.push_back(std::stod(format_value(std::pow(10, exponent(random)))));
    }
    report.integrated = std::stod(format_value(integral(report, grid.step_nm)));
    report.integrated_photon = 1.5e7;
    const std::string bytes = format_spectral_reply(report, reply_style(p.wire));
    const auto back = parse_spectral(bytes, grid);
    ASSERT_TRUE(back) << back.error().message;
    EXPECT_EQ(back->values, report.values);
    EXPECT_EQ(back->wavelength_nm, report.wavelength_nm);
    EXPECT_EQ(back->integrated, report.integrated);
    EXPECT_EQ(back->exponent_digits, p.wire.data_exponent_digits);
    EXPECT_EQ(reply_size(ReplyShape::spectral, bytes, grid.points), bytes.size());
  }
}

// ---- PR-7xx -------------------------------------------------------------------------------

TEST(Pr7xx, TriggerReplyIsNothingOrAStatus) {
  for (const std::string_view nothing : {"", "\r\n", " \r\n>"}) {
    const auto trigger = pr7xx::parse_trigger(nothing);
    ASSERT_TRUE(trigger) << printable(nothing);
    EXPECT_FALSE(*trigger);
  }
  const auto status = pr7xx::parse_trigger(reply("pr730_t.txt"));
  ASSERT_TRUE(status) << status.error().message;
  ASSERT_TRUE(*status);
  EXPECT_EQ(**status, (Status{0, 4}));
  EXPECT_EQ((*pr7xx::parse_trigger("-1000\r\n"))->code, -1000);
  EXPECT_KIND(pr7xx::parse_trigger("xyz\r\n"), "xyz", Kind::garbled);
}

TEST(Pr7xx, PollWhileMeasuringAndWhenDone) {
  const auto busy = pr7xx::parse_poll(reply("pr730_p_busy.txt"));
  ASSERT_TRUE(busy) << busy.error().message;
  EXPECT_EQ(busy->state, pr7xx::PollReply::State::measuring);
  const auto done = pr7xx::parse_poll(reply("pr730_p_done.txt"));
  ASSERT_TRUE(done) << done.error().message;
  EXPECT_EQ(done->state, pr7xx::PollReply::State::done);
  EXPECT_EQ(done->code, 0);
  EXPECT_EQ(done->tail, "0");
  for (const std::string_view bare : {"0000\r\n", "00000\r\n"}) {
    const auto poll = pr7xx::parse_poll(bare);
    ASSERT_TRUE(poll) << printable(bare);
    EXPECT_EQ(poll->state, pr7xx::PollReply::State::done);
    EXPECT_FALSE(poll->code);
  }
  const auto tail = pr7xx::parse_poll("0000,Measurement complete 12.5\r\n");
  ASSERT_TRUE(tail) << tail.error().message;
  EXPECT_FALSE(tail->code);
  EXPECT_EQ(tail->tail, "Measurement complete 12.5");
  EXPECT_EQ(pr7xx::parse_poll("0000,-8\r\n")->code, -8);
  for (const std::string_view failed : {"-8\r\n", "-0008\r\n"}) {
    const auto poll = pr7xx::parse_poll(failed);
    ASSERT_TRUE(poll) << printable(failed);
    EXPECT_EQ(poll->state, pr7xx::PollReply::State::done);
    EXPECT_EQ(poll->code, -8);
  }
  EXPECT_KIND(pr7xx::parse_poll("0001"), "no line end", Kind::truncated);
  EXPECT_KIND(pr7xx::parse_poll("0002\r\n"), "0002", Kind::garbled);
  EXPECT_KIND(pr7xx::parse_poll("0001,x\r\n"), "busy with a tail", Kind::garbled);
  EXPECT_KIND(pr7xx::parse_poll("0000,\0\r\n"sv), "NUL", Kind::garbled);
  EXPECT_KIND(pr7xx::parse_poll(""), "empty", Kind::truncated);
}

TEST(Pr7xx, AbortAndLastError) {
  EXPECT_EQ(pr7xx::parse_abort(reply("pr730_a_aborted.txt"))->result, pr7xx::AbortReply::Result::aborted);
  EXPECT_EQ(pr7xx::parse_abort(reply("pr730_a_idle.txt"))->result, pr7xx::AbortReply::Result::nothing_running);
  EXPECT_EQ(pr7xx::parse_abort("00001\r\n")->result, pr7xx::AbortReply::Result::nothing_running);
  const auto refused = pr7xx::parse_abort("-1000\r\n");
  ASSERT_TRUE(refused);
  EXPECT_EQ(refused->result, pr7xx::AbortReply::Result::refused);
  EXPECT_EQ(refused->code, -1000);
  EXPECT_KIND(pr7xx::parse_abort("0002\r\n"), "0002", Kind::garbled);
  EXPECT_KIND(pr7xx::parse_abort(""), "empty", Kind::truncated);

  EXPECT_EQ(pr7xx::parse_last_error(reply("pr730_v.txt")), (Status{0, 5}));
  EXPECT_EQ(pr7xx::parse_last_error(reply("pr730_v_dark.txt")), (Status{-8, 1}));
  EXPECT_EQ(pr7xx::parse_last_error("-0008\r\n")->code, -8);
  EXPECT_KIND(pr7xx::parse_last_error("-8,x\r\n"), "a tail", Kind::surplus);
}

TEST(Pr7xx, RepliesByteForByte) {
  const ReplyStyle style = reply_style(profile(Model::pr730).wire);
  using pr7xx::PollReply;
  EXPECT_EQ(pr7xx::format_poll_reply({PollReply::State::measuring, std::nullopt, {}}, style),
            reply("pr730_p_busy.txt"));
  EXPECT_EQ(pr7xx::format_poll_reply({PollReply::State::done, 0, {}}, style), reply("pr730_p_done.txt"));
  EXPECT_EQ(pr7xx::format_poll_reply({PollReply::State::done, -8, {}}, style), "-8\r\n");
  EXPECT_EQ(pr7xx::format_poll_reply({PollReply::State::done, -8, {}}, reply_style(profile(Model::pr740).wire)),
            "-0008\r\n");
  const auto done = *pr7xx::parse_poll(reply("pr730_p_done.txt"));
  EXPECT_EQ(pr7xx::format_poll_reply(done, style), reply("pr730_p_done.txt"));
  using pr7xx::AbortReply;
  EXPECT_EQ(pr7xx::format_abort_reply({AbortReply::Result::aborted, 0}, style), reply("pr730_a_aborted.txt"));
  EXPECT_EQ(pr7xx::format_abort_reply({AbortReply::Result::nothing_running, 1}, style), reply("pr730_a_idle.txt"));
  EXPECT_EQ(pr7xx::format_abort_reply({AbortReply::Result::refused, -1000}, style), "-1000\r\n");
}

// ---- Damage anywhere ----------------------------------------------------------------------

// Every reply file with bytes flipped, dropped and inserted: every parser answers, and an error
// names a line of the reply.
TEST(Pr6xxDamage, NoParserCrashesOrNamesALineThatIsNotThere) {
  const std::vector<std::string> names = {"pr670_photo.txt", "pr670_d111.txt",  "pr670_d120.txt", "pr670_d117.txt",
                                          "pr670_f.txt",     "pr670_d1.txt",    "pr655_d4.txt",   "pr670_d13.txt",
                                          "pr670_m5.txt",    "pr730_p_done.txt"};
  std::mt19937 random(1501);
  const auto check = [](const auto& result, std::string_view bytes) {
    if (result) return;
    std::size_t line_ends = 0;
    for (const char c : bytes) line_ends += c == '\r' || c == '\n';
    EXPECT_FALSE(result.error().message.empty());
    EXPECT_LE(result.error().line, line_ends + 1) << printable(bytes.substr(0, 120));
  };
  for (const std::string& name : names) {
    const std::string original = reply(name);
    for (int round = 0; round < 200; ++round) {
      std::string bytes = original;
      std::uniform_int_distribution<std::size_t> at(0, bytes.size() - 1);
      std::uniform_int_distribution<int> byte(0, 255);
      for (int edits = 1 + round % 3; edits > 0 && !bytes.empty(); --edits) {
        const std::size_t i = std::min(at(random), bytes.size() - 1);
        switch (round % 3) {
          case 0:
            bytes[i] = static_cast<char>(byte(random));
            break;
          case 1:
            bytes.erase(i, 1);
            break;
          default:
            bytes.insert(i, 1, static_cast<char>(byte(random)));
        }
      }
      check(parse_status(bytes), bytes);
      check(parse_text_report(bytes), bytes);
      check(parse_hardware_configuration(bytes), bytes);
      check(parse_flicker(bytes), bytes);
      check(parse_apertures(bytes), bytes);
      check(parse_exposure_report(bytes), bytes);
      for (const int report : {1, 2, 4, 6}) check(parse_colorimetric(report, bytes), bytes);
      check(parse_spectral(bytes, kGrid2nm), bytes);
      check(pr7xx::parse_poll(bytes), bytes);
      check(pr7xx::parse_trigger(bytes), bytes);
      check(pr7xx::parse_abort(bytes), bytes);
      split_banner(bytes);
      reply_size(ReplyShape::spectral, bytes, 201);
    }
  }
}

}  // namespace
}  // namespace skinspec::drivers::pr6xx
