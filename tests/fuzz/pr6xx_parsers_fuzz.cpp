// libFuzzer target: arbitrary bytes into every PR-6xx/7xx reply parser, the banner split, the
// echo strip, reply_size and the model lookup. Besides not crashing, whatever a parser accepts
// must be something a meter could have sent: a spectrum exactly on the grid it was given with
// finite values, statuses of at most five digits that are 0, 1 or negative, printable text, a
// consistent grid, and a spectrum that prints back to bytes that read the same.
// Build and run with scripts/fuzz.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <expected>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "skinspec/drivers/meter_profile.hpp"
#include "skinspec/drivers/pr6xx_protocol.hpp"
#include "skinspec/drivers/pr7xx_protocol.hpp"

namespace drivers = skinspec::drivers;
namespace pr6xx = skinspec::drivers::pr6xx;
namespace pr7xx = skinspec::drivers::pr7xx;

namespace {

// Stops the run so that libFuzzer keeps the input that broke an invariant.
void require(bool condition, const char* invariant) {
  if (!condition) {
    std::fprintf(stderr, "pr6xx invariant broken: %s\n", invariant);
    std::abort();
  }
}

bool printable(std::string_view text) {
  return std::all_of(text.begin(), text.end(), [](char c) { return c >= 0x20 && c <= 0x7e; });
}

// An error names a line that exists (or the one after the last) and says something.
void check_error(const drivers::ProtocolError& error, std::string_view bytes) {
  const auto line_ends = static_cast<std::size_t>(
      std::count_if(bytes.begin(), bytes.end(), [](char c) { return c == '\r' || c == '\n'; }));
  require(!error.message.empty(), "an error has a message");
  require(error.line <= line_ends + 1, "an error names a line of the reply");
}

void check_status(const pr6xx::Status& status) {
  require(status.code <= 1 && status.code >= -99999, "a status is 0, 1 or negative, of at most five digits");
  require(status.digits >= 1 && status.digits <= 5, "a status has 1-5 digits");
  require(!pr6xx::error_message(status.code).empty(), "every code has a message");
  pr6xx::classify(status.code);
}

template <typename T, typename Check>
void check(const std::expected<T, drivers::ProtocolError>& result, std::string_view bytes, Check check_value) {
  if (result) {
    check_value(*result);
  } else {
    check_error(result.error(), bytes);
  }
}

void check_spectral(std::string_view bytes, const drivers::Grid& grid) {
  const auto report = pr6xx::parse_spectral(bytes, grid);
  check(report, bytes, [&](const pr6xx::SpectralReport& r) {
    check_status(r.status);
    require(pr6xx::reply_size(pr6xx::ReplyShape::spectral, bytes, grid.points) > 0, "an accepted report is whole");
    if (r.status.code != 0) {
      require(r.values.empty() && r.wavelength_nm.empty(), "a failed measurement has no data");
      return;
    }
    require(r.values.size() == static_cast<std::size_t>(grid.points), "one value per grid point");
    require(r.wavelength_nm.size() == r.values.size(), "one wavelength per value");
    for (std::size_t i = 0; i < r.values.size(); ++i) {
      require(r.wavelength_nm[i] == grid.first_nm + grid.step_nm * static_cast<int>(i), "wavelengths on the grid");
      require(std::isfinite(r.values[i]), "values finite");
    }
    require(r.exponent_digits == 2 || r.exponent_digits == 3, "two or three exponent digits");
    require(std::isfinite(r.peak_nm) && std::isfinite(r.integrated) && std::isfinite(r.integrated_photon),
            "header values finite");
    pr6xx::ReplyStyle style;
    style.data_exponent_digits = r.exponent_digits;
    const auto again = pr6xx::parse_spectral(pr6xx::format_spectral_reply(r, style), grid);
    require(again.has_value(), "a printed report reads back");
    require(again->values == r.values && again->wavelength_nm == r.wavelength_nm && again->units == r.units,
            "a printed report reads back the same");
  });
}

// Every grid a newer meter measures on (its own and the variants the sources give), each once:
// models share grids, and a spectrum parsed twice on one grid finds nothing new.
const std::vector<drivers::Grid>& newer_meters_grids() {
  static const std::vector<drivers::Grid> grids = [] {
    std::vector<drivers::Grid> all;
    const auto add = [&](const drivers::Grid& grid) {
      if (std::ranges::find(all, grid) == all.end()) all.push_back(grid);
    };
    for (const drivers::MeterProfile& profile : drivers::all_profiles()) {
      if (profile.family == drivers::Family::pr650) continue;
      add(*profile.simulator_grid);
      for (const auto& variant : profile.grid_variants) {
        if (variant) add(*variant);
      }
    }
    return all;
  }();
  return grids;
}

void check_spectra(std::string_view bytes) {
  for (const drivers::Grid& grid : newer_meters_grids()) check_spectral(bytes, grid);
}

void check_line_replies(std::string_view bytes) {
  check(pr6xx::parse_status(bytes), bytes, check_status);
  check(pr6xx::parse_text_report(bytes), bytes, [](const pr6xx::TextReport& r) {
    check_status(r.status);
    require(printable(r.text), "printable text");
    require(r.text.empty() == (r.status.code != 0), "text exactly when the status is 0");
    require(r.text.empty() || r.text.back() != ' ', "no trailing blank");
    const auto candidates = drivers::match_reported_model(r.text).candidates;
    for (std::size_t i = 0; i < candidates.size(); ++i) {
      require(std::count(candidates.begin(), candidates.end(), candidates[i]) == 1, "each candidate once");
    }
  });
  check(pr6xx::parse_hardware_configuration(bytes), bytes, [](const pr6xx::HardwareConfiguration& r) {
    check_status(r.status);
    require(r.status.code != 0 || r.grid.consistent(), "a configuration's grid is consistent");
    require(std::isfinite(r.bandwidth_nm) && r.bandwidth_nm >= 0, "bandwidth finite and non-negative");
  });
  check(pr6xx::parse_flicker(bytes), bytes, [](const pr6xx::FlickerReply& r) {
    check_status(r.status);
    require(!r.hz || (std::isfinite(*r.hz) && *r.hz >= 0), "frequency finite and non-negative");
  });
  check(pr6xx::parse_apertures(bytes), bytes, [](const pr6xx::ApertureList& r) {
    check_status(r.status);
    for (const auto& aperture : r.apertures) {
      require(printable(aperture.name) && !aperture.name.empty(), "aperture names printable");
      require(std::isfinite(aperture.bandwidth_nm), "aperture bandwidth finite");
    }
  });
  check(pr6xx::parse_exposure_report(bytes), bytes, [](const pr6xx::ExposureReport& r) {
    check_status(r.status);
    require(r.exposure_ms >= 0 && r.exposure_ms <= 999999, "exposure of at most six digits");
  });
  for (const int code : {1, 2, 3, 4, 5, 6}) {
    check(pr6xx::parse_colorimetric(code, bytes), bytes, [&](const pr6xx::ColorimetricReport& r) {
      require(code != 5, "report 5 is not colorimetric");
      check_status(r.status);
      const std::size_t count = r.status.code != 0 ? 0 : code == 6 ? 5 : 3;
      require(r.values.size() == count, "the report's number of values");
      for (const double value : r.values) require(std::isfinite(value), "colorimetric values finite");
    });
  }
}

void check_pr7xx(std::string_view bytes) {
  check(pr7xx::parse_trigger(bytes), bytes, [](const std::optional<pr6xx::Status>& s) {
    if (s) check_status(*s);
  });
  check(pr7xx::parse_poll(bytes), bytes, [](const pr7xx::PollReply& r) {
    require(printable(r.tail), "printable tail");
    require(r.state == pr7xx::PollReply::State::done || !r.code, "no code while measuring");
  });
  check(pr7xx::parse_abort(bytes), bytes, [](const pr7xx::AbortReply& r) {
    require((r.result == pr7xx::AbortReply::Result::refused) == (r.code < 0), "refused exactly with an error");
  });
  check(pr7xx::parse_last_error(bytes), bytes, check_status);
}

void check_framing(std::string_view bytes) {
  const auto split = pr6xx::split_banner(bytes);
  require(split.rest.size() <= bytes.size(), "split_banner only removes");
  require(bytes.ends_with(split.rest), "the rest is what follows the banner");
  require(split.found == pr6xx::BannerSplit::Found::whole || split.rest == bytes, "nothing removed without a banner");
  if (split.found == pr6xx::BannerSplit::Found::whole) check_line_replies(split.rest);
  for (const std::string_view command : {"D5\r", "D111\r", "M5\r", "P\r", ""}) {
    const std::string_view stripped = pr6xx::strip_echo(bytes, command);
    require(stripped.empty() ||
                (stripped.data() >= bytes.data() && stripped.data() + stripped.size() <= bytes.data() + bytes.size()),
            "strip_echo returns part of the reply");
  }
  for (const auto shape : {pr6xx::ReplyShape::line, pr6xx::ReplyShape::spectral, pr6xx::ReplyShape::listing}) {
    require(pr6xx::reply_size(shape, bytes, 201) <= bytes.size(), "a reply fits in the bytes");
  }
  pr6xx::command_complete(bytes);
  drivers::match_reported_model(bytes);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  check_spectra(bytes);
  check_line_replies(bytes);
  check_pr7xx(bytes);
  check_framing(bytes);
  return 0;
}
