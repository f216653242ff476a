// The PR-650 protocol against the synthesized transcripts of the protocol reference
// (tests/data/pr650/, byte for byte) and against every way a reply can arrive damaged.

#include "skinspec/drivers/pr650_protocol.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>
#include <numeric>
#include <random>
#include <string>

#include <fmt/format.h>

#include "support/protocol_checks.hpp"

namespace skinspec::drivers::pr650 {
namespace {

using testing::duplicate_line;
using testing::error_of;
using ::testing::HasSubstr;
using testing::line_start;
using testing::line_text;
using testing::printable;
using testing::remove_line;
using testing::replace_all;
using testing::replace_line;
using Kind = ProtocolError::Kind;
// GoogleTest fixtures have a member named Setup, which would hide the protocol's.
using MeterSetup = Setup;

std::string transcript(const std::string& name) { return testing::file_bytes(PR650_TEST_DATA_DIR, name); }

const std::string& d5_a() {
  static const std::string bytes = transcript("transcript_a_d5.txt");
  return bytes;
}

const std::string& m5_b() {
  static const std::string bytes = transcript("transcript_b_m5.txt");
  return bytes;
}

// Line numbers in a D5 reply: the header takes two, so data line i (0-based) is line i + 3.
constexpr std::size_t data_line(std::size_t index) { return index + 3; }

SpectralReport parsed_a() {
  const auto report = parse_spectral(d5_a());
  if (!report) {
    ADD_FAILURE() << report.error().message;
    return {};
  }
  return *report;
}

bool same_report(const SpectralReport& a, const SpectralReport& b) {
  return a.quality == b.quality && a.units == b.units && a.integrated == b.integrated &&
         a.wavelength_nm == b.wavelength_nm && a.values == b.values;
}

std::vector<double> native_grid() {
  std::vector<double> grid;
  for (int i = 0; i < kSpectralPoints; ++i) grid.push_back(380 + 4 * i);
  return grid;
}

// ---- Messages ---------------------------------------------------------------------------

// The manual's table (tests/data/pr650/quality-codes.md, from the protocol reference): code ->
// meaning, with the Markdown escapes removed.
std::map<int, std::string> manual_quality_codes() {
  std::map<int, std::string> table;
  std::istringstream lines(transcript("quality-codes.md"));
  for (std::string line; std::getline(lines, line);) {
    if (line.size() < 8 || !line.starts_with("| ") || !std::isdigit(static_cast<unsigned char>(line[2]))) continue;
    const auto bar = line.find(" | ", 2);
    std::string meaning = line.substr(bar + 3, line.rfind(" |") - bar - 3);
    std::erase(meaning, '\\');
    table[std::stoi(line.substr(2, bar - 2))] = meaning;
  }
  return table;
}

TEST(Pr650Quality, EveryCodeOfTheManualHasItsMessage) {
  const auto table = manual_quality_codes();
  ASSERT_EQ(table.size(), 20u) << "the manual lists 20 codes";
  std::vector<int> codes;
  for (const auto& [code, meaning] : table) {
    EXPECT_EQ(quality_message(code), meaning) << code;
    codes.push_back(code);
  }
  EXPECT_EQ(known_quality_codes(), codes);
}

TEST(Pr650Quality, UnlistedCodesAreNamedUnknown) {
  EXPECT_EQ(quality_message(2), "unknown quality code 02");
  EXPECT_EQ(quality_message(31), "unknown quality code 31");
  EXPECT_EQ(quality_message(99), "unknown quality code 99");
}

TEST(Pr650Quality, ClassifiesSyncLowLightAndOverload) {
  for (int code = 0; code < 100; ++code) {
    EXPECT_EQ(is_sync_failure(code), code == 7 || code == 8 || code == 20) << code;
    EXPECT_EQ(is_low_light(code), code == 10 || code == 18) << code;
    EXPECT_EQ(is_overload(code), code == 19) << code;
  }
}

TEST(Pr650SetupReply, MessagesNameTheInvalidField) {
  EXPECT_EQ(setup_reply_message(0), "setup accepted");
  for (int field = 1; field <= 8; ++field) {
    EXPECT_THAT(setup_reply_message(field), HasSubstr("field " + std::to_string(field) + " ("));
  }
  EXPECT_THAT(setup_reply_message(6), HasSubstr("integration time"));
  EXPECT_THAT(setup_reply_message(50), HasSubstr("primary accessory"));
  EXPECT_EQ(setup_reply_message(9), "unknown setup reply code 09");
}

// ---- Commands ---------------------------------------------------------------------------

TEST(Pr650Commands, BacklightInEitherCaseAndTerminator) {
  EXPECT_EQ(format_backlight(3), "b3\n");
  EXPECT_EQ(format_backlight(0, {.terminator = '\n', .upper_case = true}), "B0\n");
  EXPECT_EQ(format_backlight(2, {.terminator = '\r', .upper_case = true}), "B2\r");
}

TEST(Pr650Commands, SetupMatchesTheDriversStrings) {
  EXPECT_EQ(format_setup({}), "s01,,,,,0,01,1\n");
  EXPECT_EQ(format_setup({}, {.terminator = '\n', .upper_case = true}), "S01,,,,,0,01,1\n");
  EXPECT_EQ(format_setup({}, {.terminator = '\r', .upper_case = false}), "s01,,,,,0,01,1\r");

  MeterSetup sync_last;
  sync_last.sync = MeterSetup::Sync::last_measured;
  EXPECT_EQ(format_setup(sync_last), "s01,,,,1,0,01,1\n");

  MeterSetup sync_60;
  sync_60.sync = MeterSetup::Sync::frequency;
  sync_60.sync_hz = 60;
  EXPECT_EQ(format_setup(sync_60), "s01,,,,60,0,01,1\n");
  sync_60.sync_hz = 59.94;
  EXPECT_EQ(format_setup(sync_60), "s01,,,,59.94,0,01,1\n");

  MeterSetup fixed;
  fixed.primary_accessory = 3;
  fixed.addons = {2, std::nullopt, 12};
  fixed.integration_ms = 1000;
  fixed.averages = 5;
  fixed.si_units = false;
  EXPECT_EQ(format_setup(fixed), "s03,02,,12,,1000,05,0\n");
}

TEST(Pr650Commands, FlickerMeasureAndReports) {
  EXPECT_EQ(format_flicker(), "f\n");
  EXPECT_EQ(format_flicker({.terminator = '\r', .upper_case = true}), "F\r");
  for (int report = 0; report <= 6; ++report) {
    EXPECT_EQ(format_measure(report), "m" + std::to_string(report) + "\n");
  }
  EXPECT_EQ(format_measure(5, {.terminator = '\r', .upper_case = true}), "M5\r");
  for (const int report : {1, 2, 3, 4, 5, 6, 110, 120, 201}) {
    EXPECT_EQ(format_report(report), "d" + std::to_string(report) + "\n");
  }
  EXPECT_EQ(format_report(110, {.terminator = '\n', .upper_case = true}), "D110\n");
}

TEST(Pr650Commands, OnlyReport5IsSpectral) {
  for (int report = 0; report <= 6; ++report) {
    const auto expected = report == 5 ? ReplyShape::spectral : ReplyShape::line;
    EXPECT_EQ(reply_shape_of_measure(report), expected) << report;
    EXPECT_EQ(reply_shape_of_report(report), expected) << report;
  }
  for (const int report : {110, 120, 201}) EXPECT_EQ(reply_shape_of_report(report), ReplyShape::line);
}

// ---- Transcripts of the reference -------------------------------------------------------

TEST(Pr650Transcripts, A_BacklightSetupAndMeasureReplies) {
  EXPECT_EQ(parse_status(transcript("transcript_a_b3.txt")), 0);
  EXPECT_EQ(parse_setup_reply(transcript("transcript_a_s.txt")), 0);
  EXPECT_EQ(parse_status(transcript("transcript_a_m0.txt")), 0);
}

TEST(Pr650Transcripts, A_SpectralReportH1) {
  ASSERT_EQ(d5_a().size(), 1733u);
  const auto report = parse_spectral(d5_a());
  ASSERT_TRUE(report) << report.error().message;
  EXPECT_EQ(report->quality, 0);
  EXPECT_EQ(report->units, 0);
  EXPECT_DOUBLE_EQ(report->integrated, 0.3019);
  ASSERT_EQ(report->wavelength_nm.size(), 101u);
  ASSERT_EQ(report->values.size(), 101u);
  EXPECT_EQ(report->wavelength_nm.front(), 380);
  EXPECT_EQ(report->wavelength_nm.back(), 780);
  EXPECT_EQ(report->wavelength_nm, native_grid());
  EXPECT_DOUBLE_EQ(report->values.front(), 5.882e-05);
  EXPECT_DOUBLE_EQ(report->values[17], 3.062e-03);  // 448 nm, the blue peak
  EXPECT_DOUBLE_EQ(report->values.back(), 5.900e-05);
  const double area = 4 * std::accumulate(report->values.begin(), report->values.end(), 0.0);
  EXPECT_NEAR(area, report->integrated, 0.01 * report->integrated);
}

TEST(Pr650Transcripts, A_ColorimetricReportsAgreeWithEachOther) {
  const auto d2 = parse_colorimetric(2, transcript("transcript_a_d2.txt"));
  ASSERT_TRUE(d2) << d2.error().message;
  EXPECT_EQ(d2->report, 2);
  EXPECT_EQ(d2->quality, 0);
  EXPECT_EQ(d2->units, 0);
  EXPECT_THAT(d2->values, ::testing::ElementsAre(102.6, 100.0, 103.2));

  const auto d1 = parse_colorimetric(1, transcript("transcript_a_d1.txt"));
  ASSERT_TRUE(d1) << d1.error().message;
  EXPECT_THAT(d1->values, ::testing::ElementsAre(100.0, 0.3355, 0.3270));

  const double sum = d2->values[0] + d2->values[1] + d2->values[2];
  EXPECT_NEAR(d2->values[0] / sum, d1->values[1], 5e-4);
  EXPECT_NEAR(d2->values[1] / sum, d1->values[2], 5e-4);
  EXPECT_DOUBLE_EQ(d2->values[1], d1->values[0]);
}

TEST(Pr650Transcripts, B_FlickerAndLowLightReportH2) {
  const auto flicker = parse_flicker(transcript("transcript_b_f.txt"));
  ASSERT_TRUE(flicker) << flicker.error().message;
  EXPECT_EQ(flicker->quality, 0);
  EXPECT_DOUBLE_EQ(flicker->frequency_hz, 60.02);
  EXPECT_EQ(parse_setup_reply(transcript("transcript_b_s.txt")), 0);

  ASSERT_EQ(m5_b().size(), 1734u);
  const auto report = parse_spectral(m5_b());
  ASSERT_TRUE(report) << report.error().message;
  EXPECT_EQ(report->quality, 18);
  EXPECT_TRUE(is_low_light(report->quality));
  EXPECT_EQ(quality_message(report->quality), "Low light level");
  EXPECT_DOUBLE_EQ(report->integrated, 1.057e-03);
  EXPECT_EQ(report->wavelength_nm, native_grid());
  EXPECT_DOUBLE_EQ(report->values.front(), 2.071e-07);
  EXPECT_DOUBLE_EQ(report->values.back(), 2.073e-07);
  const double area = 4 * std::accumulate(report->values.begin(), report->values.end(), 0.0);
  EXPECT_NEAR(area, report->integrated, 0.01 * report->integrated);
}

TEST(Pr650Transcripts, C_SyncLostIsReportedWithItsData) {
  const auto report = parse_spectral(transcript("transcript_c_d5.txt"));
  ASSERT_TRUE(report) << report.error().message;
  EXPECT_EQ(report->quality, 8);
  EXPECT_TRUE(is_sync_failure(report->quality));
  EXPECT_EQ(report->values, parsed_a().values);
}

TEST(Pr650Transcripts, D_SerialNumberAndConfiguration) {
  EXPECT_EQ(parse_serial_number(transcript("transcript_d_d110.txt")), "60912345");
  const auto configuration = parse_spectral_configuration(transcript("transcript_d_d120.txt"));
  ASSERT_TRUE(configuration) << configuration.error().message;
  EXPECT_EQ(configuration->points, 101);
  EXPECT_DOUBLE_EQ(configuration->bandwidth_nm, 8.0);
  EXPECT_DOUBLE_EQ(configuration->first_nm, 380);
  EXPECT_DOUBLE_EQ(configuration->last_nm, 780);
  EXPECT_DOUBLE_EQ(configuration->step_nm, 4);
}

TEST(Pr650Transcripts, FormattersReproduceEveryReplyByteForByte) {
  EXPECT_EQ(format_status_reply(0), transcript("transcript_a_b3.txt"));
  EXPECT_EQ(format_setup_reply(0), transcript("transcript_a_s.txt"));
  EXPECT_EQ(format_flicker_reply({0, 60.02}), transcript("transcript_b_f.txt"));
  EXPECT_EQ(format_spectral_reply(parsed_a()), d5_a());
  EXPECT_EQ(format_spectral_reply(*parse_spectral(m5_b()), {.header = HeaderVariant::h2_two_lines}), m5_b());
  EXPECT_EQ(format_colorimetric_reply(*parse_colorimetric(2, transcript("transcript_a_d2.txt"))),
            transcript("transcript_a_d2.txt"));
  EXPECT_EQ(format_colorimetric_reply(*parse_colorimetric(1, transcript("transcript_a_d1.txt"))),
            transcript("transcript_a_d1.txt"));
  EXPECT_EQ(format_serial_number_reply("60912345"), transcript("transcript_d_d110.txt"));
  EXPECT_EQ(format_spectral_configuration_reply({101, 8, 380, 780, 4}), transcript("transcript_d_d120.txt"));
}

// ---- Line replies -----------------------------------------------------------------------

TEST(Pr650Status, AcceptsEveryKnownForm) {
  for (const std::string_view reply :
       {"000\r\n", "00\r\n", "0\r\n", "000\n", "000\r", "000", "00", "0", "000\r\n>", "000\r\n\r\n", "\r\n000\r\n"}) {
    EXPECT_EQ(parse_status(reply), 0) << printable(reply);
  }
  EXPECT_EQ(parse_status("101\r\n"), 101);
}

TEST(Pr650Status, RefusesWhatIsNotAStatus) {
  EXPECT_KIND(parse_status(""), "", Kind::truncated);
  EXPECT_KIND(parse_status("\r\n"), "\r\n", Kind::garbled);
  EXPECT_KIND(parse_status("0a0\r\n"), "0a0\r\n", Kind::garbled);
  EXPECT_KIND(parse_status("0000\r\n"), "0000\r\n", Kind::garbled);
  EXPECT_KIND(parse_status(std::string("0\0\r\n", 4)), "0\\0", Kind::garbled);
  const auto surplus = parse_status("000\r\nxyz");
  EXPECT_KIND(surplus, "000\r\nxyz", Kind::surplus);
  EXPECT_EQ(error_of(surplus, "").line, 2u);
}

TEST(Pr650SetupReply, ParsesCodesAndRefusesDamage) {
  EXPECT_EQ(parse_setup_reply("00\r\n"), 0);
  EXPECT_EQ(parse_setup_reply("05\r\n"), 5);
  EXPECT_EQ(parse_setup_reply("50\n"), 50);
  EXPECT_KIND(parse_setup_reply("05"), "05", Kind::truncated);
  EXPECT_KIND(parse_setup_reply("5x\r\n"), "5x", Kind::garbled);
  EXPECT_KIND(parse_setup_reply("000\r\n"), "000", Kind::garbled);
  EXPECT_KIND(parse_setup_reply("00\r\n01\r\n"), "00 01", Kind::surplus);
}

TEST(Pr650Flicker, ParsesQualityAndFrequency) {
  const auto failed = parse_flicker("07\r\n");
  ASSERT_TRUE(failed) << failed.error().message;
  EXPECT_EQ(failed->quality, 7);
  EXPECT_EQ(failed->frequency_hz, 0);
  EXPECT_DOUBLE_EQ(parse_flicker("00,120\n")->frequency_hz, 120);
  EXPECT_KIND(parse_flicker("00\r\n"), "00", Kind::truncated);
  EXPECT_KIND(parse_flicker("00,\r\n"), "00,", Kind::truncated);
  EXPECT_KIND(parse_flicker("00,60.0"), "00,60.0", Kind::truncated);
  EXPECT_KIND(parse_flicker("00,6x.02\r\n"), "6x", Kind::garbled);
  EXPECT_KIND(parse_flicker("00,-60.02\r\n"), "-60", Kind::garbled);
  EXPECT_KIND(parse_flicker("00,nan\r\n"), "nan", Kind::garbled);
  EXPECT_KIND(parse_flicker("00,60.02,1\r\n"), "extra field", Kind::surplus);
}

TEST(Pr650Colorimetric, ReadsEveryReportWithEitherExponentLetter) {
  const std::vector<std::pair<int, std::string>> replies = {
      {1, "00,0,1.000E+02,.3355,.3270\r\n"},
      {2, "00,0,1.026e+02,1.000e+02,1.032e+02\r\n"},
      {3, "00,1,1.000E+02,.2146,.4707\r\n"},
      {4, "00,0,1.000E+02,5.420E+03,-.0031\r\n"},
      {6, "00,2,1.000e+02,.3355,.3270,.2146,.4707\r\n"},
  };
  for (const auto& [report, reply] : replies) {
    const auto parsed = parse_colorimetric(report, reply);
    ASSERT_TRUE(parsed) << report << ": " << parsed.error().message;
    EXPECT_EQ(parsed->report, report);
    EXPECT_EQ(parsed->values.size(), report == 6 ? 5u : 3u);
    EXPECT_DOUBLE_EQ(parsed->values[0], report == 2 ? 102.6 : 100.0);
  }
  EXPECT_DOUBLE_EQ(parse_colorimetric(4, replies[3].second)->values[2], -0.0031);
  EXPECT_DOUBLE_EQ(parse_colorimetric(4, "00,0,1.000E+02,6504,.0012\r\n")->values[1], 6504);
  EXPECT_DOUBLE_EQ(parse_colorimetric(1, "00,0,1.000E+02,0.3355,.3270\r\n")->values[1], 0.3355);
  EXPECT_EQ(parse_colorimetric(6, replies[4].second)->units, 2);
}

TEST(Pr650Colorimetric, ChecksTheFieldCountOfEachReport) {
  const std::string d1 = "00,0,1.000E+02,.3355,.3270\r\n";
  const std::string d2 = "00,0,1.026E+02,1.000E+02,1.032E+02\r\n";
  EXPECT_KIND(parse_colorimetric(1, "00,0,1.000E+02,.3355\r\n"), "4 fields", Kind::truncated);
  EXPECT_KIND(parse_colorimetric(1, "00,0,1.000E+02,.3355,.3270,.2146\r\n"), "6 fields", Kind::surplus);
  EXPECT_KIND(parse_colorimetric(6, d1), "d1 as 6", Kind::truncated);
  EXPECT_KIND(parse_colorimetric(1, d2), "d2 as 1", Kind::garbled);
  EXPECT_KIND(parse_colorimetric(2, d1), "d1 as 2", Kind::garbled);
  EXPECT_KIND(parse_colorimetric(5, d1), "report 5", Kind::garbled);
  EXPECT_KIND(parse_colorimetric(1, "00,3,1.000E+02,.3355,.3270\r\n"), "units 3", Kind::garbled);
  EXPECT_KIND(parse_colorimetric(1, "00,0,1.000E+02,.335,.3270\r\n"), "short middle", Kind::garbled);
  EXPECT_KIND(parse_colorimetric(2, "00,0,1.026E+02,1.00E+02,1.032E+02\r\n"), "digit lost", Kind::garbled);
  EXPECT_KIND(parse_colorimetric(2, "00,0,-1.02E+02,1.000E+02,1.032E+02\r\n"), "negative", Kind::garbled);
  EXPECT_KIND(parse_colorimetric(1, d1 + "00\r\n"), "second line", Kind::surplus);
}

TEST(Pr650Colorimetric, EveryCutIsTruncated) {
  for (const std::string reply : {"00,0,1.000E+02,.3355,.3270\r\n", "00,0,1.026E+02,1.000E+02,1.032E+02\r\n"}) {
    const int report = reply.size() == 28 ? 1 : 2;
    for (std::size_t length = 0; length + 2 < reply.size(); ++length) {
      const std::string cut = reply.substr(0, length);
      EXPECT_KIND(parse_colorimetric(report, cut), cut, Kind::truncated);
    }
    EXPECT_TRUE(parse_colorimetric(report, reply.substr(0, reply.size() - 1)));  // ends in CR
  }
}

TEST(Pr650SerialNumber, TakesEightCharactersWithoutTrailingBlanks) {
  EXPECT_EQ(parse_serial_number("60912345\r\n"), "60912345");
  EXPECT_EQ(parse_serial_number("60912345    \r\n"), "60912345");
  EXPECT_EQ(parse_serial_number("6091234 \r\n"), "6091234");
  EXPECT_EQ(parse_serial_number("A1-234\n"), "A1-234");
  EXPECT_KIND(parse_serial_number(""), "empty", Kind::truncated);
  EXPECT_KIND(parse_serial_number("        \r\n"), "blank", Kind::garbled);
  EXPECT_KIND(parse_serial_number("60912345"), "no line end", Kind::truncated);
  EXPECT_KIND(parse_serial_number("609123456789\r\n"), "12 characters", Kind::surplus);
  EXPECT_KIND(parse_serial_number(std::string("6091\0"
                                              "345\r\n",
                                              10)),
              "NUL", Kind::garbled);
  EXPECT_KIND(parse_serial_number("6091\x07"
                                  "345\r\n"),
              "BEL", Kind::garbled);
  EXPECT_KIND(parse_serial_number("6091\xe9"
                                  "345\r\n"),
              "Latin-1", Kind::garbled);
}

TEST(Pr650Configuration, RefusesCutsAndDamage) {
  const std::string reply = transcript("transcript_d_d120.txt");
  for (std::size_t length = 0; length + 2 < reply.size(); ++length) {
    const std::string cut = reply.substr(0, length);
    EXPECT_KIND(parse_spectral_configuration(cut), cut, Kind::truncated);
  }
  EXPECT_KIND(parse_spectral_configuration("01x1,008.0,0380.,0780.,004.\r\n"), "x", Kind::garbled);
  EXPECT_KIND(parse_spectral_configuration("0101,008.0,0380.,0780.,004.,1\r\n"), "6", Kind::surplus);
  EXPECT_KIND(parse_spectral_configuration("0101,008.0,-380.,0780.,004.\r\n"), "-", Kind::garbled);
}

// ---- Spectral report variants -------------------------------------------------------------

TEST(Pr650Spectral, EveryHeaderExponentAndLineEndVariantReadsTheSame) {
  const SpectralReport reference = parsed_a();
  const std::string h2 = replace_all(d5_a().substr(0, 16), "\r3", "\r\n3") + d5_a().substr(16);
  ASSERT_EQ(h2.size(), 1734u);
  for (const std::string& header_variant : {d5_a(), h2}) {
    for (const bool lower_e : {false, true}) {
      const std::string exponent = lower_e ? replace_all(header_variant, "E", "e") : header_variant;
      for (const std::string_view line_end : {"\r\n", "\n", "\r"}) {
        const std::string reply = replace_all(exponent, "\r\n", line_end);
        SCOPED_TRACE(printable(reply.substr(0, 40)));
        const auto report = parse_spectral(reply);
        ASSERT_TRUE(report) << report.error().message;
        EXPECT_TRUE(same_report(*report, reference));
        EXPECT_TRUE(reply_complete(ReplyShape::spectral, reply));
      }
    }
  }
}

TEST(Pr650Spectral, ToleratesBlankLinesAndPromptsAround) {
  const SpectralReport reference = parsed_a();
  for (const std::string& reply :
       {d5_a() + "\r\n", d5_a() + "\r\n\r\n", d5_a() + ">", d5_a() + "\r\n> ", "\r\n" + d5_a(), ">\r\n" + d5_a()}) {
    const auto report = parse_spectral(reply);
    ASSERT_TRUE(report) << printable(reply.substr(0, 20)) << ": " << report.error().message;
    EXPECT_TRUE(same_report(*report, reference));
  }
}

TEST(Pr650Spectral, EveryQualityCodeInTheHeaderIsReported) {
  const auto manual = manual_quality_codes();
  ASSERT_FALSE(manual.empty());
  for (int quality = 0; quality <= 99; ++quality) {
    const std::string reply = fmt::format("{:02d}", quality) + d5_a().substr(2);
    const auto report = parse_spectral(reply);
    ASSERT_TRUE(report) << quality << ": " << report.error().message;
    EXPECT_EQ(report->quality, quality);
    const auto listed = manual.find(quality);
    if (listed != manual.end()) EXPECT_EQ(quality_message(report->quality), listed->second) << quality;
    else EXPECT_EQ(quality_message(report->quality), fmt::format("unknown quality code {:02d}", quality)) << quality;
  }
}

TEST(Pr650Spectral, UnitsCodes) {
  for (const char units : {'0', '1', '2'}) {
    std::string reply = d5_a();
    reply[3] = units;
    EXPECT_EQ(parse_spectral(reply)->units, units - '0');
  }
  std::string reply = d5_a();
  reply[3] = '3';
  EXPECT_KIND(parse_spectral(reply), "units 3", Kind::garbled);
}

// ---- Spectral report damage ---------------------------------------------------------------

TEST(Pr650SpectralDamage, EveryCutIsTruncatedAndNeverAccepted) {
  for (const std::string* full : {&d5_a(), &m5_b()}) {
    // The last byte is the LF of the final CR LF; the CR alone already ends the report.
    for (std::size_t length = 0; length + 1 < full->size(); ++length) {
      const std::string_view cut = std::string_view(*full).substr(0, length);
      const auto report = parse_spectral(cut);
      ASSERT_FALSE(report) << "accepted a cut at byte " << length;
      ASSERT_EQ(to_string(report.error().kind), "truncated") << length << ": " << report.error().message;
      ASSERT_FALSE(reply_complete(ReplyShape::spectral, cut)) << length;
    }
    EXPECT_TRUE(parse_spectral(std::string_view(*full).substr(0, full->size() - 1)));
  }
}

TEST(Pr650SpectralDamage, CutsAtLineBoundariesNameTheMissingLine) {
  for (std::size_t lines = 0; lines < 103; ++lines) {
    const std::string cut = d5_a().substr(0, line_start(d5_a(), lines + 1));
    const auto error = error_of(parse_spectral(cut), cut);
    EXPECT_EQ(to_string(error.kind), "truncated") << lines;
    if (lines >= 2) {
      EXPECT_EQ(error.line, lines + 1) << error.message;
      EXPECT_THAT(error.message, HasSubstr(std::to_string(lines - 2) + " of 101 data lines"));
    }
  }
}

TEST(Pr650SpectralDamage, ALineCutShortInsideTheReplyIsTruncated) {
  const std::string reply = replace_line(d5_a(), data_line(30), "0500.,1.9");
  const auto error = error_of(parse_spectral(reply), "cut line");
  EXPECT_EQ(to_string(error.kind), "truncated");
  EXPECT_EQ(error.line, data_line(30));
}

TEST(Pr650SpectralDamage, GarbledValuesAreRefused) {
  const std::vector<std::string> garbled_values = {"5.8a2E-05", "-.882E-05", "-5.882E-05", "5.882E-005", "      nan",
                                                   "      NaN", "      inf", "5,882E-05",  "5.882F-05",  "5.882E 05",
                                                   "5.882E-0 ", " 5.882E-0", "5.882e-05x"};
  for (const auto& value : garbled_values) {
    const std::string reply = replace_line(d5_a(), data_line(0), "0380.," + value);
    const auto error = error_of(parse_spectral(reply), value);
    EXPECT_EQ(to_string(error.kind), "garbled") << value << ": " << error.message;
    EXPECT_EQ(error.line, 3u) << value;
  }
  std::string nul = d5_a();
  nul[line_start(nul, data_line(50)) + 8] = '\0';
  EXPECT_KIND(parse_spectral(nul), "NUL", Kind::garbled);
  EXPECT_KIND(parse_spectral(replace_line(d5_a(), 2, "3.019E-0x")), "header value", Kind::garbled);
  EXPECT_KIND(parse_spectral(replace_line(d5_a(), 1, "0,0")), "header code", Kind::garbled);
}

TEST(Pr650SpectralDamage, AFlippedWavelengthDigitIsAWrongWavelength) {
  std::string reply = d5_a();
  const std::size_t at = line_start(reply, data_line(1));
  ASSERT_EQ(reply.substr(at, 5), "0384.");
  reply[at + 3] = '5';
  const auto error = error_of(parse_spectral(reply), "0385.");
  EXPECT_EQ(to_string(error.kind), "wrong_wavelength");
  EXPECT_EQ(error.line, data_line(1));
  EXPECT_THAT(error.message, HasSubstr("385 nm where 384 nm should be"));
}

TEST(Pr650SpectralDamage, EveryBitFlipInAWavelengthIsCaught) {
  for (std::size_t index = 0; index < 101; ++index) {
    const std::size_t at = line_start(d5_a(), data_line(index));
    for (std::size_t digit = 0; digit < 4; ++digit) {
      for (int bit = 0; bit < 8; ++bit) {
        std::string reply = d5_a();
        reply[at + digit] = static_cast<char>(reply[at + digit] ^ (1 << bit));
        const auto report = parse_spectral(reply);
        ASSERT_FALSE(report) << index << "/" << digit << "/" << bit;
        const bool still_digit = reply[at + digit] >= '0' && reply[at + digit] <= '9';
        const auto expected = still_digit ? "wrong_wavelength" : "garbled";
        ASSERT_EQ(to_string(report.error().kind), expected) << report.error().message;
        ASSERT_EQ(report.error().line, data_line(index));
      }
    }
  }
}

TEST(Pr650SpectralDamage, ABitFlipAnywhereFailsOrChangesAtMostOneNumber) {
  const SpectralReport reference = parsed_a();
  for (std::size_t at = 0; at < d5_a().size(); ++at) {
    for (int bit = 0; bit < 8; ++bit) {
      std::string reply = d5_a();
      reply[at] = static_cast<char>(reply[at] ^ (1 << bit));
      const auto report = parse_spectral(reply);
      if (!report) continue;
      // Only a digit turned into another digit can pass, and then only that number differs.
      ASSERT_EQ(report->wavelength_nm, reference.wavelength_nm) << at;
      int changed = (report->quality != reference.quality) + (report->units != reference.units) +
                    (report->integrated != reference.integrated);
      for (std::size_t i = 0; i < reference.values.size(); ++i) {
        changed += report->values[i] != reference.values[i];
      }
      ASSERT_LE(changed, 1) << "byte " << at << " bit " << bit;
    }
  }
}

TEST(Pr650SpectralDamage, InsertedBytesFailOrChangeNothing) {
  const SpectralReport reference = parsed_a();
  const std::string garbage = std::string("x7,.- E>\xff\x80", 10) + std::string(1, '\0');
  for (std::size_t at = 0; at <= d5_a().size(); ++at) {
    for (const char byte : garbage + "\r\n") {
      std::string reply = d5_a();
      reply.insert(at, 1, byte);
      const auto report = parse_spectral(reply);
      if (report) {
        // Only line ends, and prompts or blanks after the report, are harmless.
        const bool harmless = byte == '\r' || byte == '\n' || ((byte == '>' || byte == ' ') && at + 1 >= d5_a().size());
        ASSERT_TRUE(harmless) << "accepted '" << printable(std::string(1, byte)) << "' at " << at;
        ASSERT_TRUE(same_report(*report, reference)) << at;
      }
    }
  }
}

TEST(Pr650SpectralDamage, RandomGarbageRunsAreRefused) {
  std::mt19937 random(650);
  std::uniform_int_distribution<int> byte(0, 255);
  for (int trial = 0; trial < 2000; ++trial) {
    std::string reply = d5_a();
    const std::size_t at = std::uniform_int_distribution<std::size_t>(0, reply.size() - 3)(random);
    std::string run;
    for (int i = 0; i < 4; ++i) {
      char c = static_cast<char>(byte(random));
      if (c == '\r' || c == '\n') c = '#';
      run += c;
    }
    reply.insert(at, run);
    EXPECT_FALSE(parse_spectral(reply)) << "accepted garbage at " << at;
  }
}

TEST(Pr650SpectralDamage, WrongNumberOfDataLines) {
  const std::string missing_middle = remove_line(d5_a(), data_line(50));
  auto error = error_of(parse_spectral(missing_middle), "100 lines");
  EXPECT_EQ(to_string(error.kind), "wrong_count") << error.message;
  EXPECT_THAT(error.message, HasSubstr("100 data lines"));
  EXPECT_EQ(error.line, data_line(50));

  EXPECT_KIND(parse_spectral(remove_line(d5_a(), data_line(0))), "no 380", Kind::wrong_count);
  EXPECT_KIND(parse_spectral(remove_line(d5_a(), data_line(100))), "no 780", Kind::truncated);

  error = error_of(parse_spectral(duplicate_line(d5_a(), data_line(20))), "102 lines");
  EXPECT_EQ(to_string(error.kind), "wrong_count") << error.message;
  EXPECT_THAT(error.message, HasSubstr("102 data lines"));

  error = error_of(parse_spectral(d5_a() + "0784.,5.900E-05\r\n"), "0784");
  EXPECT_EQ(to_string(error.kind), "wrong_count");
  EXPECT_EQ(error.line, 104u);
  EXPECT_KIND(parse_spectral(duplicate_line(d5_a(), data_line(100))), "780 twice", Kind::wrong_count);
}

TEST(Pr650SpectralDamage, WrongWavelengths) {
  // Two lines swapped: the count is right but the order is not.
  const std::string first = line_text(d5_a(), data_line(10));
  const std::string second = line_text(d5_a(), data_line(11));
  const std::string swapped = replace_line(replace_line(d5_a(), data_line(10), second), data_line(11), first);
  auto error = error_of(parse_spectral(swapped), "swapped");
  EXPECT_EQ(to_string(error.kind), "wrong_wavelength");
  EXPECT_EQ(error.line, data_line(10));

  // A 2 nm grid shifted by 2 (as a PR-670 would print) from the very first line.
  std::string shifted = d5_a();
  for (std::size_t i = 0; i < 101; ++i) {
    const std::size_t at = line_start(shifted, data_line(i));
    const std::string nm = std::to_string(382 + 4 * i);
    shifted.replace(at, 4, std::string(4 - nm.size(), '0') + nm);
  }
  error = error_of(parse_spectral(shifted), "shifted");
  EXPECT_EQ(to_string(error.kind), "wrong_wavelength");
  EXPECT_EQ(error.line, 3u);
}

TEST(Pr650SpectralDamage, TrailingGarbageIsSurplus) {
  for (const std::string& tail :
       {std::string("xyz\r\n"), std::string("00"), std::string("\r\n0380."), std::string("000\r\n")}) {
    const auto error = error_of(parse_spectral(d5_a() + tail), tail);
    EXPECT_EQ(to_string(error.kind), "surplus") << printable(tail);
    EXPECT_GE(error.line, 104u);
  }
}

TEST(Pr650SpectralDamage, ErrorMessagesShowTheBytesPrintably) {
  std::string reply = d5_a();
  reply[line_start(reply, data_line(5)) + 7] = '\x01';
  const auto error = error_of(parse_spectral(reply), "\\x01");
  EXPECT_THAT(error.message, HasSubstr("line 8"));
  EXPECT_THAT(error.message, HasSubstr("\\x01"));
}

// ---- Completeness and echo ---------------------------------------------------------------

TEST(Pr650ReplyComplete, LineRepliesEndAtTheirFirstLineEnd) {
  EXPECT_FALSE(reply_complete(ReplyShape::line, ""));
  EXPECT_FALSE(reply_complete(ReplyShape::line, "000"));
  EXPECT_FALSE(reply_complete(ReplyShape::line, "\r\n"));
  EXPECT_FALSE(reply_complete(ReplyShape::line, ">"));
  EXPECT_TRUE(reply_complete(ReplyShape::line, "000\r"));
  EXPECT_TRUE(reply_complete(ReplyShape::line, "000\n"));
  EXPECT_TRUE(reply_complete(ReplyShape::line, "000\r\n"));
  EXPECT_TRUE(reply_complete(ReplyShape::line, "00,60.02\r\n"));
}

TEST(Pr650ReplyComplete, TheSizeOfAReplyLeavesWhatFollowsIt) {
  EXPECT_EQ(reply_size(ReplyShape::line, "000"), 0u);
  EXPECT_EQ(reply_size(ReplyShape::line, "\r\n000\r\n00\r\n"), 7u);  // a leading empty line counts for nothing
  EXPECT_EQ(reply_size(ReplyShape::line, "000\r"), 4u);
  EXPECT_EQ(reply_size(ReplyShape::line, "000\n000\n"), 4u);
  const std::string twice = d5_a() + d5_a();
  EXPECT_EQ(reply_size(ReplyShape::spectral, twice), d5_a().size());
  EXPECT_EQ(reply_size(ReplyShape::spectral, d5_a().substr(0, 1000)), 0u);
}

TEST(Pr650ReplyComplete, SpectralRepliesNeedHeaderAndEveryDataLine) {
  const std::string h2 = m5_b();
  const std::string lf = replace_all(d5_a(), "\r\n", "\n");
  const std::string cr = replace_all(m5_b(), "\r\n", "\r");
  for (const std::string* reply : {&d5_a(), &h2, &lf, &cr}) {
    // Complete exactly once the last data line's first line-end byte has arrived.
    const std::size_t last_end = reply->find_last_of("\r\n", reply->size() - 1);
    const std::size_t complete_from =
        (*reply)[last_end] == '\n' && (*reply)[last_end - 1] == '\r' ? last_end : last_end + 1;
    for (std::size_t length = 0; length <= reply->size(); ++length) {
      ASSERT_EQ(reply_complete(ReplyShape::spectral, std::string_view(*reply).substr(0, length)),
                length >= complete_from)
          << length << " of " << reply->size();
    }
  }
  // The first line of a report is not the whole of it.
  EXPECT_FALSE(reply_complete(ReplyShape::spectral, "00,0\r3.019E-01\r\n0380.,5.882E-05\r\n"));
}

TEST(Pr650Echo, StripsEchoInEitherCaseWithOrWithoutItsTerminator) {
  for (const std::string echo : {"d5\r\n", "d5\n", "d5\r", "d5", "D5\r\n", ">d5\r\n", "> D5\n"}) {
    const std::string received = echo + d5_a() + ">";
    const std::string_view stripped = strip_echo(received, "d5\n");
    EXPECT_EQ(stripped, d5_a()) << printable(echo);
    EXPECT_TRUE(parse_spectral(stripped)) << printable(echo);
  }
  EXPECT_EQ(strip_echo("b3\r\n000\r\n>", "b3\n"), "000\r\n");
  EXPECT_EQ(strip_echo("S01,,,,,0,01,1\r\n00\r\n> ", "s01,,,,,0,01,1\n"), "00\r\n");
  EXPECT_EQ(strip_echo("000\r\n", "b3\n"), "000\r\n");  // no echo at all
  EXPECT_EQ(strip_echo("60912345\r\n", "d110\n"), "60912345\r\n");
}

TEST(Pr650Echo, APartialEchoIsNotAReply) {
  EXPECT_EQ(strip_echo("d", "d5\n"), "");
  EXPECT_EQ(strip_echo("> d", "d5\n"), "");
  EXPECT_EQ(strip_echo("", "d5\n"), "");
  // The echo's own line end must not make a line reply look complete.
  EXPECT_FALSE(reply_complete(ReplyShape::line, strip_echo("b3\n", "b3\n")));
  EXPECT_FALSE(reply_complete(ReplyShape::line, strip_echo("b3\r\n", "b3\n")));
  EXPECT_TRUE(reply_complete(ReplyShape::line, strip_echo("b3\r\n000\r\n", "b3\n")));
}

// ---- Reply formatting and round trips -----------------------------------------------------

TEST(Pr650Format, ValueFieldIsNineCharacters) {
  EXPECT_EQ(format_value(5.882e-05), "5.882E-05");
  EXPECT_EQ(format_value(5.882e-05, 'e'), "5.882e-05");
  EXPECT_EQ(format_value(0), "0.000E+00");
  EXPECT_EQ(format_value(1), "1.000E+00");
  EXPECT_EQ(format_value(100), "1.000E+02");
  EXPECT_EQ(format_value(123456), "1.235E+05");
  EXPECT_EQ(format_value(9.9996), "1.000E+01");
  EXPECT_EQ(format_value(1e-120), "0.000E+00");
  for (double value = 1e-99; value < 1e99; value *= 7.3) {
    const std::string text = format_value(value);
    ASSERT_EQ(text.size(), 9u) << text;
    ASSERT_NEAR(std::stod(text), value, value * 5e-4) << text;
  }
}

TEST(Pr650Format, SpectralReplySizesMatchTheReference) {
  SpectralReport report = parsed_a();
  EXPECT_EQ(format_spectral_reply(report).size(), 1733u);
  EXPECT_EQ(format_spectral_reply(report, {.header = HeaderVariant::h2_two_lines}).size(), 1734u);
  report.wavelength_nm.clear();  // the native grid is the default
  EXPECT_EQ(format_spectral_reply(report), d5_a());
  const std::string lower = format_spectral_reply(report, {.header = HeaderVariant::h1_bare_cr, .exponent = 'e'});
  EXPECT_EQ(lower, replace_all(d5_a(), "E", "e"));
}

TEST(Pr650RoundTrip, SpectralReportsOfRandomValues) {
  std::mt19937 random(4);
  std::lognormal_distribution<double> value(-9, 3);
  for (int trial = 0; trial < 50; ++trial) {
    SpectralReport report;
    report.quality = trial % 31;
    report.units = trial % 3;
    for (int i = 0; i < kSpectralPoints; ++i) {
      report.wavelength_nm.push_back(380 + 4 * i);
      report.values.push_back(i == trial ? 0.0 : value(random));
    }
    report.integrated = value(random);
    for (const auto header : {HeaderVariant::h1_bare_cr, HeaderVariant::h2_two_lines}) {
      for (const char exponent : {'E', 'e'}) {
        const std::string bytes = format_spectral_reply(report, {header, exponent});
        const auto parsed = parse_spectral(bytes);
        ASSERT_TRUE(parsed) << parsed.error().message;
        EXPECT_EQ(parsed->quality, report.quality);
        EXPECT_EQ(parsed->units, report.units);
        EXPECT_EQ(parsed->wavelength_nm, report.wavelength_nm);
        EXPECT_NEAR(parsed->integrated, report.integrated, report.integrated * 5e-4);
        for (int i = 0; i < kSpectralPoints; ++i) {
          ASSERT_NEAR(parsed->values[i], report.values[i], report.values[i] * 5e-4) << i;
        }
        EXPECT_EQ(format_spectral_reply(*parsed, {header, exponent}), bytes);
      }
    }
  }
}

TEST(Pr650RoundTrip, EveryColorimetricReport) {
  const std::vector<ColorimetricReport> reports = {
      {1, 0, 0, {100.0, 0.3355, 0.3270}},   {2, 18, 1, {102.6, 100.0, 103.2}},
      {3, 0, 2, {0.35, 0.2146, 0.4707}},    {4, 0, 0, {100.0, 6504.0, -0.0031}},
      {4, 10, 0, {1.0e-3, 2856.0, 0.0012}}, {6, 0, 0, {100.0, 0.3355, 0.3270, 0.2146, 0.4707}},
  };
  for (const auto& report : reports) {
    for (const char exponent : {'E', 'e'}) {
      const std::string bytes = format_colorimetric_reply(report, {.exponent = exponent});
      const auto parsed = parse_colorimetric(report.report, bytes);
      ASSERT_TRUE(parsed) << bytes << ": " << parsed.error().message;
      EXPECT_EQ(parsed->report, report.report);
      EXPECT_EQ(parsed->quality, report.quality);
      EXPECT_EQ(parsed->units, report.units);
      ASSERT_EQ(parsed->values.size(), report.values.size());
      for (std::size_t i = 0; i < report.values.size(); ++i) {
        EXPECT_NEAR(parsed->values[i], report.values[i], std::abs(report.values[i]) * 5e-4) << bytes;
      }
      EXPECT_EQ(format_colorimetric_reply(*parsed, {.exponent = exponent}), bytes);
    }
  }
  EXPECT_EQ(format_colorimetric_reply(reports[0]), "00,0,1.000E+02,.3355,.3270\r\n");
  EXPECT_EQ(format_colorimetric_reply(reports[3]), "00,0,1.000E+02,6.504E+03,-.0031\r\n");
}

TEST(Pr650RoundTrip, LineReplies) {
  for (const int status : {0, 1, 101}) EXPECT_EQ(parse_status(format_status_reply(status)), status);
  for (const int code : {0, 1, 8, 50}) EXPECT_EQ(parse_setup_reply(format_setup_reply(code)), code);
  for (const FlickerReply reply : {FlickerReply{0, 60.02}, FlickerReply{0, 50}, FlickerReply{7, 0}}) {
    const auto parsed = parse_flicker(format_flicker_reply(reply));
    ASSERT_TRUE(parsed) << parsed.error().message;
    EXPECT_EQ(parsed->quality, reply.quality);
    EXPECT_DOUBLE_EQ(parsed->frequency_hz, reply.frequency_hz);
  }
  EXPECT_EQ(format_flicker_reply({0, 60}), "00,60.00\r\n");
  for (const std::string serial : {"60912345", "1234"}) {
    EXPECT_EQ(parse_serial_number(format_serial_number_reply(serial)), serial);
  }
  const SpectralConfiguration configuration{201, 5.0, 380, 780, 2};
  const auto parsed = parse_spectral_configuration(format_spectral_configuration_reply(configuration));
  ASSERT_TRUE(parsed) << parsed.error().message;
  EXPECT_EQ(parsed->points, 201);
  EXPECT_EQ(parsed->bandwidth_nm, 5.0);
  EXPECT_EQ(parsed->step_nm, 2);
}

}  // namespace
}  // namespace skinspec::drivers::pr650
