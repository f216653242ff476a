// End-to-end tests of the skinspec program: each test runs the built binary as a child process
// and judges only what a user sees, its exit status, standard output and standard error.

#include <gmock/gmock.h>
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <random>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "skinspec/spectral/utf8.hpp"
#include "skinspec/testkit/process.hpp"
#include "support/reference_model.hpp"

namespace skinspec {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::IsEmpty;
using ::testing::StartsWith;
using Json = nlohmann::json;

constexpr int kBadInput = 2;  // the status skinspec documents for input it refuses

testing::ProcessResult skinspec(const std::vector<std::string>& args,
                                std::optional<std::string> stdin_bytes = std::nullopt) {
  testing::ProcessOptions options;
  options.stdin_bytes = std::move(stdin_bytes);
  return testing::run_process(SKINSPEC_TEST_BIN_DIR "/skinspec", args, options);
}

using testing::lines_of;

// Each line of stdout as JSON; a line that does not parse fails the test.
std::vector<Json> json_lines(const std::string& out) {
  std::vector<Json> parsed;
  for (const auto& line : lines_of(out)) {
    parsed.push_back(Json::parse(line, nullptr, false));
    EXPECT_FALSE(parsed.back().is_discarded()) << "not JSON: " << line;
  }
  return parsed;
}

std::vector<double> doubles(const Json& array) { return array.get<std::vector<double>>(); }

// A fresh directory under the system's temporary directory, removed with everything in it.
class TemporaryDirectory {
 public:
  TemporaryDirectory() {
    std::string pattern = (std::filesystem::temp_directory_path() / "skinspec-cli-XXXXXX").string();
    if (!::mkdtemp(pattern.data())) throw std::runtime_error("mkdtemp failed for " + pattern);
    path_ = pattern;
  }
  TemporaryDirectory(const TemporaryDirectory&) = delete;
  TemporaryDirectory& operator=(const TemporaryDirectory&) = delete;
  ~TemporaryDirectory() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }

  const std::filesystem::path& path() const { return path_; }

  // Writes `bytes` to `name` inside the directory and returns the file's path.
  std::string write(const std::string& name, const std::string& bytes) const {
    const auto file = path_ / name;
    std::ofstream(file, std::ios::binary) << bytes;
    return file.string();
  }

 private:
  std::filesystem::path path_;
};

class CliTest : public ::testing::Test {
 protected:
  void SetUp() override { directory_.emplace(); }
  void TearDown() override { directory_.reset(); }

  std::string write(const std::string& name, const std::string& bytes) const { return directory_->write(name, bytes); }
  std::string path_of(const std::string& name) const { return (directory_->path() / name).string(); }

 private:
  std::optional<TemporaryDirectory> directory_;
};

// A spectra file every command accepts: two flat spectra over 400-700 nm.
constexpr const char* kGoodSpectra = "wavelength_nm,a,b\n400,0.3,0.4\n550,0.35,0.45\n700,0.5,0.6\n";

// What may reach a terminal: UTF-8 without control characters other than line ends.
void expect_printable(const std::string& text) {
  EXPECT_TRUE(utf8::is_valid(text)) << "not UTF-8: " << printable(text);
  for (const char c : text) {
    const auto byte = static_cast<unsigned char>(c);
    EXPECT_TRUE(c == '\n' || (byte >= 0x20 && byte != 0x7f))
        << "control byte " << int(byte) << " in " << printable(text);
  }
}

// Refused input: the status, empty stdout (no partial output), and the message on stderr,
// printable whatever the input held.
void expect_refused(const testing::ProcessResult& run, const ::testing::Matcher<std::string>& message) {
  EXPECT_EQ(run.exit_status, kBadInput) << run.describe();
  EXPECT_THAT(run.out, IsEmpty()) << run.describe();
  EXPECT_THAT(run.err, message) << run.describe();
  expect_printable(run.err);
}

// ---------------------------------------------------------------------------------------------
// The process helper itself, on standard tools, so a failure above is never the helper's.

TEST(CliProcess, PassesLargeInputThroughAndSeparatesTheStreams) {
  std::string big(1 << 20, 'x');  // larger than a pipe's buffer in both directions
  for (std::size_t i = 0; i < big.size(); i += 97) big[i] = '\n';
  testing::ProcessOptions options;
  options.stdin_bytes = big;
  const auto run = testing::run_process("/bin/sh", {"-c", "cat; echo oops >&2; exit 3"}, options);
  EXPECT_EQ(run.exit_status, 3);
  EXPECT_TRUE(run.out == big) << "stdout differs from stdin (" << run.out.size() << " bytes)";
  EXPECT_EQ(run.err, "oops\n");
}

TEST(CliProcess, ToleratesAChildThatStopsReadingEarly) {
  testing::ProcessOptions options;
  options.stdin_bytes = std::string(4 << 20, 'y');
  const auto run = testing::run_process("/usr/bin/head", {"-c", "5"}, options);
  EXPECT_EQ(run.exit_status, 0) << run.describe();
  EXPECT_EQ(run.out, "yyyyy");
}

TEST(CliProcess, KillsAChildPastItsTimeout) {
  testing::ProcessOptions options;
  options.timeout = std::chrono::milliseconds(200);
  const auto started = std::chrono::steady_clock::now();
  const auto run = testing::run_process("/bin/sleep", {"30"}, options);
  EXPECT_TRUE(run.timed_out);
  EXPECT_EQ(run.signal, SIGKILL);
  EXPECT_FALSE(run.exited());
  EXPECT_LT(std::chrono::steady_clock::now() - started, std::chrono::seconds(10));
}

TEST(CliProcess, ReportsAProgramThatCannotStart) {
  const auto run = testing::run_process("/nonexistent/program", {});
  EXPECT_EQ(run.exit_status, 127);
  EXPECT_THAT(run.err, HasSubstr("/nonexistent/program"));
}

TEST(CliProcess, ChildWithoutInputReadsNothingAndSeesAddedEnvironment) {
  testing::ProcessOptions options;
  options.environment = {"SKINSPEC_CLI_TEST_MARK=present"};
  const auto run = testing::run_process("/bin/sh", {"-c", "cat; echo \"$SKINSPEC_CLI_TEST_MARK\""}, options);
  EXPECT_EQ(run.exit_status, 0) << run.describe();
  EXPECT_EQ(run.out, "present\n");
}

// ---------------------------------------------------------------------------------------------
// Malformed spectra files, for `fit` and `color`, read from a file and from standard input.

struct BadSpectra {
  const char* label;
  const char* bytes;
  const char* location;  // what follows the source name: ":line:column: ", ":line: " or ": "
  const char* message;   // a part of the message that says what is wrong
};

const BadSpectra kBadSpectra[] = {
    {"non_numeric_cell", "wavelength_nm,a,b\n400,0.1,0.2\n550,0.3,abc\n700,0.2,0.3\n",
     ":3:9: ", "'abc' is not a number in column 'b'"},
    {"missing_header", "400,0.1\n550,0.2\n700,0.3\n", ":1:1: ", "the header is missing"},
    {"misnamed_first_column", "wavelength,a\n400,0.1\n700,0.3\n", ":1:1: ", "must be 'wavelength_nm'"},
    {"duplicated_header", "wavelength_nm,a,b,a\n400,0.1,0.1,0.1\n700,0.2,0.2,0.2\n",
     ":1:19: ", "duplicated column name 'a'"},
    {"single_column", "wavelength_nm\n400\n700\n", ":1: ", "names no spectrum"},
    {"ragged_row", "wavelength_nm,a\n400,0.1\n550,0.2,0.3\n700,0.3\n", ":3:9: ", "3 cells where the header has 2"},
    {"decreasing_wavelength", "wavelength_nm,a\n400,0.1\n700,0.2\n600,0.3\n",
     ":4:1: ", "wavelength 600 nm is below 700 nm"},
    {"repeated_wavelength", "wavelength_nm,a\n400,0.1\n550,0.2\n550,0.3\n700,0.3\n",
     ":4:1: ", "wavelength 550 nm repeats"},
    {"nan", "wavelength_nm,a\n400,0.1\n550,nan\n700,0.2\n", ":3:5: ", "'nan' is not a finite number"},
    {"inf", "wavelength_nm,a\n400,0.1\n550,inf\n700,0.2\n", ":3:5: ", "'inf' is not a finite number"},
    {"minus_inf_wavelength", "wavelength_nm,a\n400,0.1\n-inf,0.1\n700,0.2\n",
     ":3:1: ", "'-inf' is not a finite number"},
    {"negative_reflectance", "wavelength_nm,a\n400,0.1\n550,-0.01\n700,0.2\n",
     ":3:5: ", "value -0.01 in column 'a' is outside the allowed range [0, 1.5]"},
    {"reflectance_above_1_5", "wavelength_nm,a\n400,0.1\n550,1.51\n700,0.2\n",
     ":3:5: ", "value 1.51 in column 'a' is outside the allowed range [0, 1.5]"},
    {"one_row", "wavelength_nm,a\n400,0.1\n", ":2: ", "1 data row below the header"},
    {"empty", "", ":1: ", "the input is empty"},
    {"only_blank_lines", "\n  \n\n", ":1: ", "the input holds only blank"},
    // Bytes that are not UTF-8, anywhere: shown escaped, never raw.
    {"utf8_in_header", "wavelength_nm,\xff\xfe\n400,0.3\n500,0.3\n600,0.3\n700,0.3\n",
     ":1:15: ", "\\xff\\xfe is not UTF-8 text (after 'wavelength_nm,')"},
    {"utf8_in_name", "wavelength_nm,ok,b\xe9\n400,0.3,0.3\n700,0.3,0.3\n", ":1:19: ", "\\xe9 is not UTF-8 text"},
    {"utf8_in_comment", "# \xc0\xaf\nwavelength_nm,a\n400,0.3\n700,0.3\n", ":1:3: ", "\\xc0\\xaf is not UTF-8 text"},
    {"utf8_in_value", "wavelength_nm,a\n400,0.3\n700,0.3\xf4\x90\x80\x80\n",
     ":3:8: ", "\\xf4\\x90\\x80\\x80 is not UTF-8"},
    {"utf8_lone_continuation", "wavelength_nm,a\n400,\x80\n700,0.3\n", ":2:5: ", "\\x80 is not UTF-8 text"},
    {"utf8_overlong", "wavelength_nm,a\xc1\xbf\n400,0.3\n700,0.3\n", ":1:16: ", "\\xc1\\xbf is not UTF-8 text"},
    {"utf8_surrogate", "wavelength_nm,a\n400,0.3\n700,0.\xed\xa0\x80\n", ":3:7: ", "\\xed\\xa0\\x80 is not UTF-8"},
    {"escape_sequence_in_name", "wavelength_nm,\x1b[31mred,\x1b[31mred\n400,0.1,0.1\n700,0.2,0.2\n",
     ":1:24: ", "duplicated column name '\\x1b[31mred'"},
    {"vertical_tab_in_cell",
     "wavelength_nm,a\n400,0.1\n550,0\x0b"
     "2\n700,0.2\n",
     ":3:5: ", "'0\\x0b2' is not a number"},
};

struct BadSpectraRun {
  std::string command;  // "fit" or "colour"
  BadSpectra bad;
  bool from_stdin;
};

// Names the case in test listings instead of gtest's dump of the struct's bytes.
void PrintTo(const BadSpectraRun& run, std::ostream* out) {
  *out << run.command << ' ' << run.bad.label << (run.from_stdin ? " from stdin" : " from a file");
}

class CliBadSpectra : public CliTest, public ::testing::WithParamInterface<BadSpectraRun> {};

TEST_P(CliBadSpectra, IsRefusedWithStatus2AndTheLocation) {
  const auto& [command, bad, from_stdin] = GetParam();
  const auto file = from_stdin ? std::string("-") : write("bad.csv", bad.bytes);
  const auto source = from_stdin ? std::string("<stdin>") : file;
  const auto run = from_stdin ? skinspec({command, "-"}, bad.bytes) : skinspec({command, file});
  expect_refused(run, AllOf(StartsWith("skinspec: " + source + bad.location), HasSubstr(bad.message)));
}

// Grids too narrow for one command: `colour` needs 400-700 nm, `fit` 420-680 nm (docs/model.md).
const BadSpectra kNarrowForColour[] = {
    {"grid_starts_late", "wavelength_nm,a\n410,0.1\n700,0.2\n", ": ",
     "the wavelengths cover 410-700 nm but 400-700 nm is needed"},
    {"grid_ends_early", "wavelength_nm,a\n400,0.1\n690,0.2\n", ": ",
     "the wavelengths cover 400-690 nm but 400-700 nm is needed"},
};
const BadSpectra kNarrowForFit[] = {
    {"grid_450_650", "wavelength_nm,a\n450,0.1\n650,0.2\n", ": ",
     "the wavelengths cover 450-650 nm but 420-680 nm is needed"},
    {"grid_starts_late", "wavelength_nm,a\n425,0.1\n780,0.2\n", ": ",
     "the wavelengths cover 425-780 nm but 420-680 nm is needed"},
};

std::vector<BadSpectraRun> all_bad_spectra_runs() {
  std::vector<BadSpectraRun> runs;
  for (const bool from_stdin : {false, true}) {
    for (const char* command : {"fit", "colour"})
      for (const auto& bad : kBadSpectra) runs.push_back({command, bad, from_stdin});
    for (const auto& bad : kNarrowForColour) runs.push_back({"colour", bad, from_stdin});
    for (const auto& bad : kNarrowForFit) runs.push_back({"fit", bad, from_stdin});
  }
  return runs;
}

std::string run_name(const ::testing::TestParamInfo<BadSpectraRun>& run) {
  return run.param.command + "_" + run.param.bad.label + (run.param.from_stdin ? "_stdin" : "_file");
}

INSTANTIATE_TEST_SUITE_P(Spectra, CliBadSpectra, ::testing::ValuesIn(all_bad_spectra_runs()), run_name);

// ---------------------------------------------------------------------------------------------
// Other refused invocations.

class CliRefuses : public CliTest {};

TEST_F(CliRefuses, NonexistentFile) {
  for (const char* command : {"fit", "colour"}) {
    const auto missing = path_of("no_such_file.csv");
    expect_refused(skinspec({command, missing}),
                   AllOf(StartsWith("skinspec: " + missing + ":"), HasSubstr("cannot open")));
  }
}

TEST_F(CliRefuses, DirectoryGivenAsFile) {
  const auto directory = path_of("");
  for (const char* command : {"fit", "colour"})
    expect_refused(skinspec({command, directory}), HasSubstr("is a directory"));
}

TEST_F(CliRefuses, ArgumentsAreEchoedPrintably) {
  const auto file = write("good.csv", kGoodSpectra);
  expect_refused(skinspec({"fi\x1bt", file}), HasSubstr("unknown command 'fi\\x1bt'"));
  expect_refused(skinspec({"fit", "--format", "\xff\x1b[2J", file}), HasSubstr("\\xff\\x1b[2J"));
  expect_refused(skinspec({"fit", "--site", "arm\xff", file}), HasSubstr("unknown site 'arm\\xff'"));
  expect_refused(skinspec({"fit", "--bogus\x07", file}), HasSubstr("--bogus\\x07"));
  expect_refused(skinspec({"model", "--grid", "\t\x1b"}), HasSubstr("--grid '\\t\\x1b'"));
  expect_refused(skinspec({"model", "--melanin",
                           "\x9b"
                           "2J"}),
                 HasSubstr("\\x9b2J"));
  expect_refused(skinspec({"colour", "--illuminant", "nosuch\x1b", file}), HasSubstr("'nosuch\\x1b'"));
  const auto missing = path_of("no\x1b[2Jsuch.csv");
  expect_refused(skinspec({"fit", missing}), HasSubstr("no\\x1b[2Jsuch.csv"));
  // Text sent to skinspecd must be UTF-8: refused before any connection is tried.
  expect_refused(
      skinspec({"session", "new", "--site", "forearm", "--subject", "S\xff", "--server", "http://127.0.0.1:1"}),
      HasSubstr("'S\\xff' is not UTF-8 text"));
  expect_refused(
      skinspec({"session", "measure", "1", "--kind", "white", "--label", "\xc0\x80", "--server", "http://127.0.0.1:1"}),
      HasSubstr("is not UTF-8 text"));
}

TEST_F(CliRefuses, UnknownSiteListingTheKnownOnes) {
  const auto file = write("good.csv", kGoodSpectra);
  const auto known_sites = AllOf(HasSubstr("unknown site 'elbow'"), HasSubstr("forearm"), HasSubstr("back_of_hand"),
                                 HasSubstr("cheek"), HasSubstr("forehead"), HasSubstr("palm"));
  expect_refused(skinspec({"fit", "--site", "elbow", file}), known_sites);
  expect_refused(skinspec({"model", "--site", "elbow"}), known_sites);
  expect_refused(skinspec({"optics", "--site", "elbow"}), known_sites);
}

TEST_F(CliRefuses, UnknownSubcommandOrOption) {
  const auto file = write("good.csv", kGoodSpectra);
  const std::vector<std::vector<std::string>> invocations = {
      {},
      {"frobnicate"},
      {"--bogus"},
      {"fit", "--bogus", file},
      {"fit"},  // FILE is required
      {"fit", file, "extra.csv"},
      {"colour", "--site", "forearm", file},
      {"model", "--grid"},  // the option's value is missing
      {"optics", "--melanin", "1"},
  };
  for (const auto& args : invocations) {
    SCOPED_TRACE(::testing::PrintToString(args));
    expect_refused(skinspec(args), ::testing::Not(IsEmpty()));
  }
}

// ---------------------------------------------------------------------------------------------
// fit on spectra the model itself made: the fit must give back the parameters.

struct ModelSpectrum {
  std::vector<std::string> wavelength, reflectance;  // as printed, so no digit is lost
};

// Runs `skinspec model` and splits its two-column CSV.
ModelSpectrum model_output(const std::vector<std::string>& args) {
  const auto run = skinspec(args);
  EXPECT_EQ(run.exit_status, 0) << run.describe();
  const auto lines = lines_of(run.out);
  EXPECT_FALSE(lines.empty());
  if (lines.empty()) return {};
  EXPECT_EQ(lines.front(), "wavelength_nm,reflectance");
  ModelSpectrum spectrum;
  for (std::size_t i = 1; i < lines.size(); ++i) {
    const auto comma = lines[i].find(',');
    spectrum.wavelength.push_back(lines[i].substr(0, comma));
    spectrum.reflectance.push_back(lines[i].substr(comma + 1));
  }
  return spectrum;
}

struct TrueSkin {
  const char* column;
  double surface_reflectance, melanin, oxyhemoglobin, deoxyhemoglobin, bilirubin;

  std::vector<std::string> model_args(const std::string& grid) const {
    return {"model",
            "--model",
            "paper",
            "--site",
            "forearm",
            "--grid",
            grid,
            "--surface-reflectance",
            text(surface_reflectance),
            "--melanin",
            text(melanin),
            "--oxyhemoglobin",
            text(oxyhemoglobin),
            "--deoxyhemoglobin",
            text(deoxyhemoglobin),
            "--bilirubin",
            text(bilirubin)};
  }
  static std::string text(double v) {
    std::ostringstream out;
    out << v;
    return out.str();
  }
};

// Named out of alphabetical order, so output sorted by name would not pass for input order.
constexpr TrueSkin kSkins[] = {
    {"zeta", 0.04, 5, 3, 1, 2},
    {"alpha", 0.02, 1.5, 1, 0.4, 0.5},
};

constexpr const char* kParamKeys[] = {"surface_reflectance", "melanin", "oxyhemoglobin", "deoxyhemoglobin",
                                      "bilirubin"};

// The fit-result fields of `skinspec fit`, all present and of the documented types.
void expect_fit_fields(const Json& line) {
  for (const char* key : {"name", "site"}) EXPECT_TRUE(line.contains(key) && line[key].is_string()) << key;
  for (const char* group : {"params", "stderr"}) {
    ASSERT_TRUE(line.contains(group) && line[group].is_object()) << group;
    EXPECT_EQ(line[group].size(), std::size(kParamKeys)) << line[group];
    for (const char* key : kParamKeys) {
      ASSERT_TRUE(line[group].contains(key)) << group << "." << key;
      const auto& value = line[group][key];
      // An undetermined standard error is null; a parameter is always a number.
      EXPECT_TRUE(value.is_number() || (value.is_null() && std::string(group) == "stderr")) << group << "." << key;
    }
  }
  for (const char* key : {"rmse", "max_abs_error", "delta_e00_d65"})
    EXPECT_TRUE(line.contains(key) && line[key].is_number()) << key;
  EXPECT_TRUE(line.contains("iterations") && line["iterations"].is_number_integer());
  EXPECT_TRUE(line.contains("converged") && line["converged"].is_boolean());
  for (const char* key : {"wavelength_nm", "measured", "fitted"})
    EXPECT_TRUE(line.contains(key) && line[key].is_array()) << key;
}

class CliFit : public CliTest {};

TEST_F(CliFit, RecoversTheParametersOfModelSpectra) {
  const std::string grid = "400:700:5";
  std::vector<ModelSpectrum> spectra;
  for (const auto& skin : kSkins) spectra.push_back(model_output(skin.model_args(grid)));
  ASSERT_EQ(spectra[0].wavelength.size(), 61u);

  std::string csv = "wavelength_nm," + std::string(kSkins[0].column) + "," + kSkins[1].column + "\n";
  for (std::size_t i = 0; i < spectra[0].wavelength.size(); ++i)
    csv += spectra[0].wavelength[i] + "," + spectra[0].reflectance[i] + "," + spectra[1].reflectance[i] + "\n";
  const auto run = skinspec({"fit", "--model", "paper", write("skins.csv", csv)});
  ASSERT_EQ(run.exit_status, 0) << run.describe();
  const auto results = json_lines(run.out);
  ASSERT_EQ(results.size(), std::size(kSkins)) << run.out;

  for (std::size_t s = 0; s < std::size(kSkins); ++s) {
    const auto& skin = kSkins[s];
    const auto& result = results[s];
    SCOPED_TRACE(skin.column);
    expect_fit_fields(result);
    EXPECT_EQ(result["name"], skin.column);
    EXPECT_EQ(result["model"], "paper");
    EXPECT_EQ(result["site"], "forearm");

    const auto wavelengths = doubles(result["wavelength_nm"]);
    const auto measured = doubles(result["measured"]);
    ASSERT_EQ(wavelengths.size(), spectra[s].wavelength.size());
    ASSERT_EQ(measured.size(), wavelengths.size());
    EXPECT_EQ(result["fitted"].size(), wavelengths.size());
    for (std::size_t i = 0; i < wavelengths.size(); ++i) {
      EXPECT_DOUBLE_EQ(wavelengths[i], std::stod(spectra[s].wavelength[i]));
      EXPECT_DOUBLE_EQ(measured[i], std::stod(spectra[s].reflectance[i]));
    }

    const auto& p = result["params"];
    EXPECT_NEAR(p["melanin"].get<double>(), skin.melanin, 0.01 * skin.melanin);
    EXPECT_NEAR(p["surface_reflectance"].get<double>(), skin.surface_reflectance, 1e-3);
    EXPECT_NEAR(p["oxyhemoglobin"].get<double>(), skin.oxyhemoglobin, 0.01 * skin.oxyhemoglobin);
    EXPECT_NEAR(p["deoxyhemoglobin"].get<double>(), skin.deoxyhemoglobin, 0.01 * skin.deoxyhemoglobin);
    EXPECT_NEAR(p["bilirubin"].get<double>(), skin.bilirubin, 0.01 * skin.bilirubin);
    EXPECT_LT(result["rmse"].get<double>(), 1e-4);
    EXPECT_LT(result["max_abs_error"].get<double>(), 1e-3);
    EXPECT_LT(result["delta_e00_d65"].get<double>(), 0.1);
    EXPECT_TRUE(result["converged"].get<bool>());
  }
}

// The default model: the extended one, with what each fit determines.

// Two columns of `skinspec model` output on one grid as a spectra CSV.
std::string spectra_csv(const std::vector<std::pair<std::string, ModelSpectrum>>& columns) {
  std::string csv = "wavelength_nm";
  for (const auto& [name, spectrum] : columns) csv += "," + name;
  csv += "\n";
  for (std::size_t i = 0; i < columns.front().second.wavelength.size(); ++i) {
    csv += columns.front().second.wavelength[i];
    for (const auto& column : columns) csv += "," + column.second.reflectance[i];
    csv += "\n";
  }
  return csv;
}

const std::vector<std::string> kExtendedSkin = {
    "--surface-reflectance",     "0.04", "--melanin",   "4", "--total-hemoglobin",  "4",
    "--oxygen-saturation",       "0.75", "--bilirubin", "1", "--dermis-scattering", "30",
    "--dermis-scattering-power", "1.3"};

std::vector<std::string> extended_model_args(const std::string& grid) {
  std::vector<std::string> args = {"model", "--grid", grid};
  args.insert(args.end(), kExtendedSkin.begin(), kExtendedSkin.end());
  return args;
}

TEST_F(CliFit, TheExtendedModelIsTheDefaultAndRecoversItsOwnSpectra) {
  const auto spectrum = model_output(extended_model_args("380:780:4"));
  const auto run = skinspec({"fit", write("skin.csv", spectra_csv({{"skin", spectrum}}))});
  ASSERT_EQ(run.exit_status, 0) << run.describe();
  const auto results = json_lines(run.out);
  ASSERT_EQ(results.size(), 1u);
  const Json& r = results.front();
  EXPECT_EQ(r["model"], "extended");
  EXPECT_EQ(r["samples_ignored"], 0);
  EXPECT_FALSE(r.contains("note"));
  for (std::size_t i = 0; i < kExtendedSkin.size(); i += 2) {
    std::string name = kExtendedSkin[i].substr(2);
    std::ranges::replace(name, '-', '_');
    const double truth = std::stod(kExtendedSkin[i + 1]);
    EXPECT_NEAR(r["params"][name].get<double>(), truth, 1e-3 * truth) << name;
    EXPECT_TRUE(r["determination"][name]["determined"].get<bool>()) << name << " " << r["determination"];
    EXPECT_TRUE(r["stderr"][name].is_number()) << name;
  }
  EXPECT_NEAR(r["derived"]["oxygen_saturation"]["value"].get<double>(), 0.75, 1e-3);
  EXPECT_NEAR(r["derived"]["blood_volume_fraction"]["value"].get<double>(), 4 * 0.002, 1e-5);
  ASSERT_EQ(r["correlation"]["params"].size(), 7u);
  ASSERT_EQ(r["correlation"]["matrix"].size(), 7u);
  EXPECT_EQ(r["correlation"]["matrix"][1][1], 1.0);
}

TEST_F(CliFit, ANotDeterminedParameterHasANullStandardErrorAndAReason) {
  // Melanin 80 hides the dermis: the blood's saturation cannot be told.
  auto args = extended_model_args("380:780:4");
  *(std::ranges::find(args, "--melanin") + 1) = "80";
  auto dark = model_output(args);
  // As measured: with noise (sigma 0.002, seeded), from which the fit estimates its precision.
  std::mt19937 random(14);
  std::normal_distribution<double> noise(0, 0.002);
  for (auto& value : dark.reflectance) value = std::to_string(std::stod(value) + noise(random));
  const auto file = write("dark.csv", spectra_csv({{"dark", dark}}));
  const auto run = skinspec({"fit", file});
  ASSERT_EQ(run.exit_status, 0) << run.describe();
  const Json r = json_lines(run.out).at(0);
  const Json& saturation = r["determination"]["oxygen_saturation"];
  EXPECT_FALSE(saturation["determined"].get<bool>()) << r["determination"];
  EXPECT_TRUE(saturation["reason"].is_string());
  EXPECT_TRUE(r["stderr"]["oxygen_saturation"].is_null());
  EXPECT_TRUE(r["params"]["oxygen_saturation"].is_number());
  EXPECT_FALSE(r["derived"]["oxygen_saturation"]["determined"].get<bool>());
  EXPECT_TRUE(r["derived"]["oxygen_saturation"]["stderr"].is_null());

  const auto table = skinspec({"fit", "--format", "table", file});
  ASSERT_EQ(table.exit_status, 0) << table.describe();
  EXPECT_THAT(table.out, HasSubstr("oxygen_saturation"));
  EXPECT_THAT(table.out, HasSubstr("n.d."));
}

TEST_F(CliFit, HeldParametersAreShownAsHeld) {
  const auto spectrum = model_output(extended_model_args("380:780:4"));
  const auto file = write("skin.csv", spectra_csv({{"skin", spectrum}}));
  const auto run = skinspec({"fit", "--fix", "bilirubin=1", "--fix", "dermis_scattering_power", file});
  ASSERT_EQ(run.exit_status, 0) << run.describe();
  const Json r = json_lines(run.out).at(0);
  EXPECT_EQ(r["params"]["bilirubin"], 1.0);
  EXPECT_EQ(r["params"]["dermis_scattering_power"], 1.292);  // its default
  EXPECT_EQ(r["determination"]["bilirubin"]["reason"], "held");
  expect_refused(skinspec({"fit", "--fix", "oxyhemoglobin=1", file}), HasSubstr("oxyhemoglobin"));
  expect_refused(skinspec({"fit", "--fix", "bilirubin=lots", file}), HasSubstr("lots"));
  expect_refused(skinspec({"fit", "--fix", "oxygen_saturation=0.995", file}), HasSubstr("oxygen_saturation"));
}

// The same spectrum in percent, as many instruments write it: auto reads it as percent, as does
// --scale percent, and both give the fit of its fractions; --scale fraction refuses it.
TEST_F(CliFit, APercentFileIsFittedAsItsFractions) {
  const auto spectrum = model_output(extended_model_args("380:780:4"));
  auto in_percent = spectrum;
  for (auto& value : in_percent.reflectance) {
    std::ostringstream percent;
    percent << std::setprecision(15) << std::stod(value) * 100;
    value = percent.str();
  }
  const auto fraction_file = write("fraction.csv", spectra_csv({{"skin", spectrum}}));
  const auto percent_file = write("percent.csv", spectra_csv({{"skin", in_percent}}));

  const auto as_fractions = skinspec({"fit", fraction_file});
  ASSERT_EQ(as_fractions.exit_status, 0) << as_fractions.describe();
  EXPECT_THAT(as_fractions.err, IsEmpty()) << "fractions need no note";
  const Json expected = json_lines(as_fractions.out).at(0);
  EXPECT_EQ(expected["scale"], "fraction");

  const std::pair<std::string, std::string> scales[] = {{"auto", "percent (auto)"}, {"percent", "percent"}};
  for (const auto& [scale, note] : scales) {
    SCOPED_TRACE(scale);
    const auto run =
        scale == "auto" ? skinspec({"fit", percent_file}) : skinspec({"fit", "--scale", scale, percent_file});
    ASSERT_EQ(run.exit_status, 0) << run.describe();
    EXPECT_EQ(run.err, "skinspec: " + percent_file + ": values read as " + note + "\n");
    const Json r = json_lines(run.out).at(0);
    EXPECT_EQ(r["scale"], "percent");
    const auto measured = doubles(r["measured"]), expected_measured = doubles(expected["measured"]);
    ASSERT_EQ(measured.size(), expected_measured.size());
    for (std::size_t i = 0; i < measured.size(); ++i) EXPECT_DOUBLE_EQ(measured[i], expected_measured[i]) << i;
    for (const auto& [name, value] : expected["params"].items())
      EXPECT_NEAR(r["params"][name].get<double>(), value.get<double>(), 1e-6 * std::abs(value.get<double>())) << name;
    EXPECT_NEAR(r["rmse"].get<double>(), expected["rmse"].get<double>(), 1e-9);
  }

  // The first value of the file, at 380 nm, is above 1.5: refused there, file and line named.
  expect_refused(skinspec({"fit", "--scale", "fraction", percent_file}),
                 AllOf(StartsWith("skinspec: " + percent_file + ":2:5: value "),
                       HasSubstr("is outside the allowed range [0, 1.5]")));
}

TEST_F(CliRefuses, AnUnknownScale) {
  const auto file = write("good.csv", kGoodSpectra);
  for (const char* scale : {"percentage", "", "Auto"}) {
    SCOPED_TRACE(scale);
    expect_refused(skinspec({"fit", "--scale", scale, file}),
                   AllOf(HasSubstr("--scale"), HasSubstr("auto, fraction or percent")));
    expect_refused(skinspec({"import", "--scale", scale, "--session", "1", "--server", "http://127.0.0.1:1", file}),
                   AllOf(HasSubstr("--scale"), HasSubstr("auto, fraction or percent")));
  }
}

TEST_F(CliFit, TheTableGivesItsUnitsAndSaysWhatNdMeans) {
  const auto spectrum = model_output(extended_model_args("380:780:4"));
  const auto file = write("skin.csv", spectra_csv({{"skin", spectrum}}));
  const auto run = skinspec({"fit", "--format", "table", "--fix", "bilirubin", file});
  ASSERT_EQ(run.exit_status, 0) << run.describe();
  const auto lines = lines_of(run.out);
  ASSERT_EQ(lines.size(), 4u) << run.out;
  // Every column's unit, in the columns' order; the parameters' as the model states them.
  EXPECT_THAT(lines[0], StartsWith("units: surface_reflectance [fraction]; melanin [x 1 % melanosomes in the "
                                   "epidermis]; total_hemoglobin [x 0.2 % blood (150 g/L haemoglobin) in the dermis]; "
                                   "oxygen_saturation [fraction]; bilirubin [x 0.005 g/L in the dermis]; "
                                   "dermis_scattering ["));
  EXPECT_THAT(lines[0], HasSubstr("cm-1"));
  EXPECT_THAT(lines[0], HasSubstr("]; dermis_scattering_power ["));
  EXPECT_THAT(lines[0], ::testing::EndsWith("]; rmse [reflectance, as a fraction]; dE00 [CIEDE2000 of measured and "
                                            "fitted colour under D65]; ITA° [degrees]; M, E [100 log10 of a "
                                            "reflectance ratio (Diffey 1984)]"));
  EXPECT_THAT(lines[1], AllOf(StartsWith("spectrum"), HasSubstr(" ITA° class ")));
  // The skin tone's cells, as the JSON gives them.
  const auto json_run = skinspec({"fit", "--fix", "bilirubin", file});
  ASSERT_EQ(json_run.exit_status, 0) << json_run.describe();
  const auto tone = nlohmann::json::parse(json_run.out)["skin_tone"];  // one JSON line per spectrum
  EXPECT_THAT(lines[2],
              AllOf(StartsWith("skin"), HasSubstr("1 held"),
                    HasSubstr(fmt::format(" {:>5.1f} {:<12} {:>5.1f} {:>5.1f} ", tone["ita_deg"].get<double>(),
                                          tone["ita_class"].get<std::string>(), tone["melanin_index"].get<double>(),
                                          tone["erythema_index"].get<double>()))));
  EXPECT_EQ(lines[3],
            "n.d.: not determined by this spectrum (reason in --format json; docs/model.md, \"What the spectrum "
            "determines\")");
}

TEST_F(CliFit, AParameterOfTheOtherModelIsRefused) {
  expect_refused(skinspec({"model", "--oxyhemoglobin", "3"}),
                 AllOf(HasSubstr("--oxyhemoglobin"), HasSubstr("extended")));
  expect_refused(skinspec({"model", "--model", "paper", "--total-hemoglobin", "3"}),
                 AllOf(HasSubstr("--total-hemoglobin"), HasSubstr("paper")));
  expect_refused(skinspec({"model", "--model", "papier"}), HasSubstr("--model"));
}

// A hyperspectral camera's 415-950 nm and a 400-700 nm instrument: fitted over what they cover
// inside the model's 380-780 nm, with a note; 450-650 nm is refused (kNarrowForFit above).
TEST_F(CliFit, PartialCoverageIsFittedWithANote) {
  const auto inside = model_output(extended_model_args("415:780:5"));
  std::string camera = "wavelength_nm,camera\n";
  for (std::size_t i = 0; i < inside.wavelength.size(); ++i)
    camera += inside.wavelength[i] + "," + inside.reflectance[i] + "\n";
  for (int w = 785; w <= 950; w += 5) camera += std::to_string(w) + ",0.6\n";
  const auto run = skinspec({"fit", write("camera.csv", camera)});
  ASSERT_EQ(run.exit_status, 0) << run.describe();
  const Json r = json_lines(run.out).at(0);
  EXPECT_EQ(r["samples_ignored"], 34);
  EXPECT_THAT(r["note"].get<std::string>(), HasSubstr("415-780 nm"));
  EXPECT_THAT(run.err, HasSubstr("34 samples outside the model's 380-780 nm"));
  EXPECT_NEAR(r["params"]["melanin"].get<double>(), 4, 4e-3);

  const auto visible = model_output(extended_model_args("400:700:5"));
  const auto narrow = skinspec({"fit", write("visible.csv", spectra_csv({{"visible", visible}}))});
  ASSERT_EQ(narrow.exit_status, 0) << narrow.describe();
  EXPECT_THAT(json_lines(narrow.out).at(0)["note"].get<std::string>(), HasSubstr("400-700 nm"));
  EXPECT_THAT(narrow.err, HasSubstr("400-700 nm"));
}

TEST(CliTune, RefusesAConstantTheModelDoesNotHave) {
  const auto run = skinspec(
      {"tune", SKINSPEC_TEST_DATA_DIR "/examples/forearm.csv", "--hold-constant", "dermis_scattering_scale=1"});
  EXPECT_EQ(run.exit_status, kBadInput) << run.describe();
  EXPECT_THAT(run.err, HasSubstr("dermis_scattering_scale"));
}

// ---------------------------------------------------------------------------------------------
// optics and model: eq. 1 of Doi, Tanaka & Tominaga, computed here from the printed constants in
// its textbook hyperbolic form, must be what `model` prints.

using testing::reference::Weights;

// Eq. 1 (support/reference_model.hpp) at wavelength index i of the `optics` JSON, over a white
// hypodermis (reflectance 1).
double eq1_reflectance(const Json& optics, std::size_t i, const Weights& w) {
  const auto at = [&](const char* key) { return optics[key][i].get<double>(); };
  return testing::reference::eq1({at("Ke"), at("Se"), at("Kd"), at("Sd"), at("Km"), at("Kh"), at("Kdh"), at("Kb")},
                                 optics["epidermis_thickness_mm"].get<double>(),
                                 optics["dermis_thickness_mm"].get<double>(), w);
}

class CliOptics : public CliTest {};

TEST_F(CliOptics, ModelIsEquation1OfThePrintedConstants) {
  const auto optics_run = skinspec({"optics", "--model", "paper", "--site", "cheek"});
  ASSERT_EQ(optics_run.exit_status, 0) << optics_run.describe();
  const auto optics = json_lines(optics_run.out);
  ASSERT_EQ(optics.size(), 1u);
  const Json& o = optics.front();
  EXPECT_EQ(o["site"], "cheek");
  EXPECT_GT(o["epidermis_thickness_mm"].get<double>(), 0);
  EXPECT_GT(o["dermis_thickness_mm"].get<double>(), 0);
  const auto wavelengths = doubles(o["wavelength_nm"]);
  ASSERT_EQ(wavelengths.size(), 401u);  // 380-780 nm every 1 nm
  for (const char* key : {"Ke", "Se", "Kd", "Sd", "Km", "Kh", "Kdh", "Kb"})
    ASSERT_EQ(o[key].size(), wavelengths.size()) << key;

  const Weights w{0.05, 2.5, 1.5, 0.6, 0.8};
  const auto model = model_output({"model", "--model", "paper", "--site", "cheek", "--no-lateral-diffusion",
                                   "--surface-reflectance", "0.05", "--melanin", "2.5", "--oxyhemoglobin", "1.5",
                                   "--deoxyhemoglobin", "0.6", "--bilirubin", "0.8"});
  ASSERT_EQ(model.wavelength.size(), wavelengths.size());
  for (std::size_t i = 0; i < wavelengths.size(); ++i) {
    SCOPED_TRACE(wavelengths[i]);
    ASSERT_DOUBLE_EQ(std::stod(model.wavelength[i]), wavelengths[i]);
    const double expected = eq1_reflectance(o, i, w);
    ASSERT_TRUE(std::isfinite(expected));
    EXPECT_NEAR(std::stod(model.reflectance[i]), expected, 1e-9);
  }
}

// ---------------------------------------------------------------------------------------------
// model's own arguments.

class CliModel : public CliTest {};

TEST_F(CliModel, PrintsTheRequestedGrid) {
  const auto model = model_output({"model", "--grid", "400:700:5"});
  ASSERT_EQ(model.wavelength.size(), 61u);
  EXPECT_EQ(model.wavelength.front(), "400");
  EXPECT_EQ(model.wavelength.back(), "700");
  for (const auto& r : model.reflectance) {
    EXPECT_GT(std::stod(r), 0);
    EXPECT_LT(std::stod(r), 1);
  }
}

TEST_F(CliModel, RefusesABadGrid) {
  for (const char* grid : {"400:700", "400-700-5", "700:400:5", "300:700:5", "400:800:5", "400:700:0", "400:700:-5",
                           "400:700:nan", "a:b:c", "400:700:5x", ""}) {
    SCOPED_TRACE(grid);
    expect_refused(skinspec({"model", "--grid", grid}), HasSubstr("--grid"));
  }
}

TEST_F(CliModel, RefusesWeightsOutOfRange) {
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"--melanin", "-1"},
      {"--oxyhemoglobin", "-0.5"},
      {"--deoxyhemoglobin", "-1e-3"},
      {"--bilirubin", "-2"},
      {"--melanin", "nan"},
      {"--bilirubin", "inf"},
      {"--surface-reflectance", "-0.1"},
      {"--surface-reflectance", "1.5"},
      {"--surface-reflectance", "nan"},
      {"--melanin", "lots"},
  };
  for (const auto& [option, value] : bad) {
    SCOPED_TRACE(option + " " + value);
    expect_refused(skinspec({"model", "--model", "paper", option, value}), HasSubstr(option));
  }
}

// ---------------------------------------------------------------------------------------------
// colour (alias color).

struct Chromaticity {
  double x, y;
};

Chromaticity chromaticity(const Json& xyz) {
  const double X = xyz[0].get<double>(), Y = xyz[1].get<double>(), Z = xyz[2].get<double>();
  return {X / (X + Y + Z), Y / (X + Y + Z)};
}

// A perfect white and a flat 50% grey, over the whole visible range.
constexpr const char* kWhiteAndGrey = "wavelength_nm,white,grey\n380,1.0,0.5\n780,1.0,0.5\n";

class CliColour : public CliTest {
 protected:
  void expect_white_under_equal_energy(const std::string& illuminant, const std::string& shown);
};

TEST_F(CliColour, ColorIsAnAliasGivingTheSameAnswer) {
  const auto colour = skinspec({"colour", "-"}, kWhiteAndGrey);
  const auto color = skinspec({"color", "-"}, kWhiteAndGrey);
  ASSERT_EQ(colour.exit_status, 0) << colour.describe();
  ASSERT_EQ(color.exit_status, 0) << color.describe();
  EXPECT_EQ(json_lines(color.out).size(), 2u);
  EXPECT_EQ(color.out, colour.out);
}

TEST_F(CliColour, WhiteUnderD65IsTheD65WhitePoint) {
  const auto run = skinspec({"colour", "-"}, kWhiteAndGrey);
  ASSERT_EQ(run.exit_status, 0) << run.describe();
  const auto results = json_lines(run.out);
  ASSERT_EQ(results.size(), 2u);

  const auto& white = results[0];
  EXPECT_EQ(white["name"], "white");
  EXPECT_EQ(white["illuminant"], "D65");
  EXPECT_NEAR(white["XYZ"][0].get<double>(), 0.9505, 2e-4);
  EXPECT_NEAR(white["XYZ"][1].get<double>(), 1.0, 1e-9);
  EXPECT_NEAR(white["XYZ"][2].get<double>(), 1.0888, 2e-4);
  EXPECT_NEAR(white["Lab"][0].get<double>(), 100, 1e-6);
  EXPECT_NEAR(white["Lab"][1].get<double>(), 0, 1e-6);
  EXPECT_NEAR(white["Lab"][2].get<double>(), 0, 1e-6);
  EXPECT_EQ(white["sRGB8"], Json::array({255, 255, 255}));

  // A flat reflectance scales the tristimulus values and keeps the chromaticity.
  const auto& grey = results[1];
  EXPECT_EQ(grey["name"], "grey");
  for (std::size_t k = 0; k < 3; ++k)
    EXPECT_NEAR(grey["XYZ"][k].get<double>(), 0.5 * white["XYZ"][k].get<double>(), 1e-9);
  EXPECT_NEAR(grey["Lab"][0].get<double>(), 116 * std::cbrt(0.5) - 16, 1e-6);
}

TEST_F(CliColour, WhiteUnderAHasTheChromaticityOfA) {
  const auto run = skinspec({"colour", "--illuminant", "A", write("white.csv", kWhiteAndGrey)});
  ASSERT_EQ(run.exit_status, 0) << run.describe();
  const auto results = json_lines(run.out);
  ASSERT_EQ(results.size(), 2u);
  EXPECT_EQ(results[0]["illuminant"], "A");
  const auto xy = chromaticity(results[0]["XYZ"]);
  EXPECT_NEAR(xy.x, 0.4476, 2e-4);
  EXPECT_NEAR(xy.y, 0.4074, 2e-4);
}

TEST_F(CliColour, IlluminantFromAFile) {
  // A path is bytes: one that is not UTF-8 names an illuminant too, and the JSON that echoes it
  // shows U+FFFD for what cannot be text (it used to end the program by an uncaught exception).
  for (const auto& [name, shown] :
       {std::pair{"equal_energy.csv", "equal_energy.csv"}, std::pair{"lamp\xff.csv", "lamp\xef\xbf\xbd.csv"}}) {
    SCOPED_TRACE(printable(name));
    expect_white_under_equal_energy(write(name, "wavelength_nm,power\n380,100\n780,100\n"), path_of(shown));
  }
}

void CliColour::expect_white_under_equal_energy(const std::string& illuminant, const std::string& shown) {
  const auto run = skinspec({"colour", "--illuminant", illuminant, write("white.csv", kWhiteAndGrey)});
  ASSERT_EQ(run.exit_status, 0) << run.describe();
  const auto results = json_lines(run.out);
  ASSERT_EQ(results.size(), 2u);
  EXPECT_EQ(results[0]["illuminant"], shown);
  // The CIE 1931 functions have (nearly) equal areas, so white under E sits at x = y = 1/3.
  const auto xy = chromaticity(results[0]["XYZ"]);
  EXPECT_NEAR(xy.x, 1.0 / 3, 1e-3);
  EXPECT_NEAR(xy.y, 1.0 / 3, 1e-3);
  EXPECT_NEAR(results[0]["XYZ"][1].get<double>(), 1.0, 1e-9);
}

TEST_F(CliColour, RefusesAnUnknownIlluminant) {
  const auto white = write("white.csv", kWhiteAndGrey);
  expect_refused(skinspec({"colour", "--illuminant", "nosuch", white}), AllOf(HasSubstr("'nosuch'"), HasSubstr("D65")));
  // A file that does not span 380-780 nm cannot weight the whole observer range.
  const auto narrow = write("narrow.csv", "wavelength_nm,power\n400,1\n700,1\n");
  expect_refused(skinspec({"colour", "--illuminant", narrow, white}),
                 AllOf(StartsWith("skinspec: " + narrow), HasSubstr("380-780 nm is needed")));
  // Without power there is no white to be relative to.
  const auto dark = write("dark.csv", "wavelength_nm,power\n380,0\n780,0\n");
  expect_refused(skinspec({"colour", "--illuminant", dark, white}),
                 AllOf(StartsWith("skinspec: " + dark), HasSubstr("no power")));
}

// ---------------------------------------------------------------------------------------------
// --help

struct HelpCase {
  std::string subcommand;
  std::vector<std::string> mentions;
};

TEST(CliHelp, EverySubcommandDescribesItsOptions) {
  const std::vector<HelpCase> cases = {
      {"fit", {"FILE", "--model", "--site", "--no-lateral-diffusion", "--fix"}},
      {"model",
       {"--model", "--site", "--surface-reflectance", "--melanin", "--oxyhemoglobin", "--deoxyhemoglobin",
        "--bilirubin", "--total-hemoglobin", "--oxygen-saturation", "--dermis-scattering", "--dermis-scattering-power",
        "--no-lateral-diffusion", "--grid"}},
      {"optics", {"--model", "--site"}},
      {"colour", {"FILE", "--illuminant"}},
      {"tune", {"FILE", "--model", "--site", "--fix", "--hold-constant", "--cross-validate", "--fold-out"}},
      {"render", {"--model", "--fit", "--total-hemoglobin"}},
  };
  for (const auto& [subcommand, mentions] : cases) {
    SCOPED_TRACE(subcommand);
    const auto run = skinspec({subcommand, "--help"});
    EXPECT_EQ(run.exit_status, 0) << run.describe();
    EXPECT_THAT(run.err, IsEmpty());
    for (const auto& option : mentions) EXPECT_THAT(run.out, HasSubstr(option));
  }
}

TEST(CliHelp, TopLevelHelpListsTheSubcommands) {
  const auto run = skinspec({"--help"});
  EXPECT_EQ(run.exit_status, 0) << run.describe();
  for (const char* subcommand : {"fit", "model", "optics", "colour", "tune"})
    EXPECT_THAT(run.out, HasSubstr(subcommand));
}

}  // namespace
}  // namespace skinspec

namespace skinspec {
namespace {

// measure: what is wrong with the request is bad input (2); an instrument that cannot be
// reached is an instrument error (3). The simulator's tests cover measuring itself.
TEST(CliMeasure, RefusesABadDeviceUriWithStatus2) {
  const auto run = skinspec({"measure", "--device", "tcp:localhost"});
  EXPECT_EQ(run.exit_status, 2) << run.describe();
  EXPECT_THAT(run.err, ::testing::HasSubstr("--device 'tcp:localhost'"));
}

// An exposure outside the forced model's range, or outside every model's with auto, and a model
// skinspec does not know are refused before anything is sent.
TEST(CliMeasure, RefusesAnExposureOrModelItCannotUseWithStatus2) {
  const auto pr650 = skinspec({"measure", "--device", "tcp:127.0.0.1:9", "--model", "pr650", "--integration-ms", "5"});
  EXPECT_EQ(pr650.exit_status, 2) << pr650.describe();
  EXPECT_THAT(pr650.err, ::testing::HasSubstr("expected 10-6000 (the PR-650's range)"));
  const auto pr730 = skinspec({"measure", "--device", "tcp:127.0.0.1:9", "--model", "PR730", "--integration-ms", "10"});
  EXPECT_EQ(pr730.exit_status, 2) << pr730.describe();
  EXPECT_THAT(pr730.err, ::testing::HasSubstr("expected 12-120000 (the PR-730's range)"));
  const auto any = skinspec({"measure", "--device", "tcp:127.0.0.1:9", "--integration-ms", "2"});
  EXPECT_EQ(any.exit_status, 2) << any.describe();
  EXPECT_THAT(any.err, ::testing::HasSubstr("what any model takes"));
  const auto model = skinspec({"measure", "--device", "tcp:127.0.0.1:9", "--model", "pr999"});
  EXPECT_EQ(model.exit_status, 2) << model.describe();
  EXPECT_THAT(model.err, ::testing::HasSubstr("--model: unknown model 'pr999' (one of: auto, pr650"));
  EXPECT_EQ(model.out, "");
}

TEST(CliMeasure, AnUnreachableInstrumentIsStatus3) {
  // Port 1 on loopback: nothing listens there, so the connection is refused at once.
  const auto run = skinspec({"measure", "--device", "tcp:127.0.0.1:1"});
  EXPECT_EQ(run.exit_status, 3) << run.describe();
  EXPECT_THAT(run.err, ::testing::HasSubstr("instrument error"));
  EXPECT_EQ(run.out, "");
}

}  // namespace
}  // namespace skinspec
