#include "common.hpp"

#include <filesystem>
#include <fmt/format.h>
#include <iostream>
#include <iterator>

#include "data_dir.hpp"
#include "fitter_loader.hpp"

namespace skinspec::cli {

std::string input_name(const std::string& path) { return path == "-" ? "<stdin>" : path; }

std::string read_input(const std::string& path) {
  if (path == "-") return {std::istreambuf_iterator<char>(std::cin), std::istreambuf_iterator<char>()};
  // A directory opens and reads as zero bytes, which would be reported as an empty file.
  if (std::error_code ec; std::filesystem::is_directory(path, ec))
    throw Failure{kBadInput, path + ": is a directory, not a file"};
  auto bytes = read_file(path);
  if (!bytes) throw Failure{kBadInput, bytes.error()};
  return *bytes;
}

SpectraFile read_spectra_file(const std::string& path, const SpectraLimits& limits) {
  auto file = parse_spectra_file(read_input(path), input_name(path), limits);
  if (!file) throw Failure{kBadInput, file.error().what()};
  return std::move(*file);
}

std::vector<NamedSpectrum> read_spectra(const std::string& path, const SpectraLimits& limits) {
  return read_spectra_file(path, limits).spectra;
}

Spectrum illuminant_from(const std::string& name) {
  const auto builtin = fitter().colorimetry().illuminant(name);
  if (builtin) return *builtin;
  SpectraLimits limits;
  limits.max_value = 1e9;
  limits.must_cover_from_nm = 380;
  limits.must_cover_to_nm = 780;
  std::string bytes;
  try {
    bytes = read_input(name);
  } catch (const Failure& unreadable) {
    // A misspelt built-in name ("d65") is likelier than a missing file: say both.
    throw Failure{kBadInput, "--illuminant: " + builtin.error() + ", and " + unreadable.message};
  }
  auto spectra = parse_spectra_csv(bytes, input_name(name), limits);
  if (!spectra) throw Failure{kBadInput, spectra.error().what()};
  // Colours are relative to the illuminant's white; with no power where the observer sees,
  // that white is black and every XYZ and Lab would come out as NaN.
  const Spectrum& power = spectra->front().spectrum;
  if (!(fitter().colorimetry().white(power).y > 0))
    throw Failure{kBadInput, input_name(name) + ": the illuminant has no power within the observer's 360-830 nm"};
  return power;
}

// Like CLI::Range, but NaN is refused: Range only rejects values below or above its bounds, and
// every comparison with NaN is false, so `--melanin nan` would print a NaN spectrum.
CLI::Validator finite_range(double min, double max) {
  const auto check = [min, max](std::string& text) -> std::string {
    double value = 0;
    if (!CLI::detail::lexical_cast(text, value)) return quote(text) + " is not a number";
    if (value >= min && value <= max) return {};
    return fmt::format("must be a number in [{}, {}], not {}", min, max, printable(text));
  };
  return CLI::Validator(check, fmt::format("FLOAT in [{} - {}]", min, max));
}

CLI::Validator utf8_text() {
  const auto check = [](std::string& text) -> std::string {
    const auto defect = utf8::first_defect(text);
    if (!defect) return {};
    return fmt::format("{} is not UTF-8 text (at byte {})", quote(text), defect->offset + 1);
  };
  return CLI::Validator(check, "TEXT");
}

std::string printable_message(std::string_view message) {
  std::string out;
  for (std::size_t start = 0; start <= message.size();) {
    const auto end = std::min(message.find('\n', start), message.size());
    out += printable(message.substr(start, end - start));
    if (end == message.size()) break;
    out += '\n';
    start = end + 1;
  }
  return out;
}

const Fitter& fitter() {
  static const Fitter instance = [] {
    auto loaded = load_fitter();
    if (!loaded) throw Failure{kBadInput, loaded.error()};
    return std::move(*loaded);
  }();
  return instance;
}

CLI::Option* add_site_option(CLI::App& app, std::string& site) {
  return app.add_option("--site", site, "body site: forearm, back_of_hand, cheek, forehead, palm")
      ->capture_default_str();
}

CLI::Option* add_scale_option(CLI::App& app, ScaleRequest& scale, std::string_view more) {
  const auto check = [](std::string& text) -> std::string {
    if (parse_scale_request(text)) return {};
    return fmt::format("must be {}, not {}", scale_request_names(), quote(text));
  };
  return app
      .add_option_function<std::string>(
          "--scale", [&scale](const std::string& text) { scale = *parse_scale_request(text); },
          fmt::format("how the file writes reflectance: {}; auto reads percent when at least half its values "
                      "exceed {}{}",
                      scale_request_names(), kPercentAbove, more))
      ->check(CLI::Validator(check, fmt::format("{{{},{},{}}}", to_string(ScaleRequest::automatic),
                                                to_string(ScaleRequest::fraction), to_string(ScaleRequest::percent))))
      ->default_str(std::string(to_string(scale)));
}

Failure store_failure(const store::StoreError& error) {
  return Failure{store::is_bad_target(error.kind) ? kBadInput : kFailure, error.message};
}

}  // namespace skinspec::cli
