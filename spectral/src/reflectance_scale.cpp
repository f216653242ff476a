#include "skinspec/spectral/reflectance_scale.hpp"

#include <algorithm>
#include <fmt/format.h>

#include "skinspec/spectral/enum_names.hpp"
#include "skinspec/spectral/utf8.hpp"

namespace skinspec {

namespace {

constexpr EnumNames<ScaleRequest, 3> kRequests = {{
    {ScaleRequest::automatic, "auto"},
    {ScaleRequest::fraction, "fraction"},
    {ScaleRequest::percent, "percent"},
}};

bool above_fraction(double value) { return value > kPercentAbove; }

}  // namespace

std::string_view to_string(ReflectanceScale scale) {
  return scale == ReflectanceScale::percent ? "percent" : "fraction";
}

std::string_view to_string(ScaleRequest request) { return name_of(kRequests, request); }

std::optional<ScaleRequest> parse_scale_request(std::string_view text) { return value_named(kRequests, text); }

std::string scale_request_names() {
  return fmt::format("{}, {} or {}", kRequests[0].second, kRequests[1].second, kRequests[2].second);
}

std::string describe(const ScaleDecision& decision) {
  return fmt::format("{}{}", to_string(decision.scale), decision.automatic ? " (auto)" : "");
}

std::string out_of_range_note(const ScaleDecision& decision, double value) {
  if (!decision.automatic && decision.scale == ReflectanceScale::fraction) return {};
  auto note = fmt::format("; values read as {}", describe(decision));
  if (decision.automatic && decision.scale == ReflectanceScale::fraction && above_fraction(value))
    note += fmt::format(", as fewer than half of them exceed {}", kPercentAbove);
  return note;
}

std::string describe_conflict(std::string_view spectrum_name) {
  return fmt::format(
      "spectrum {} stays at or below {} while the file holds percent elsewhere: its values are on another scale",
      quote(spectrum_name), kPercentAbove);
}

bool ScaleTally::add(std::span<const double> spectrum) {
  const auto above = static_cast<std::size_t>(std::ranges::count_if(spectrum, above_fraction));
  if (above == 0 && !first_below_) first_below_ = spectra_;
  ++spectra_;
  values_ += spectrum.size();
  above_ += above;
  return above == 0;
}

std::expected<ScaleDecision, ScaleConflict> ScaleTally::decide(ScaleRequest request) const {
  if (request == ScaleRequest::fraction) return ScaleDecision{ReflectanceScale::fraction, false};
  if (request == ScaleRequest::percent) return ScaleDecision{ReflectanceScale::percent, false};
  if (values_ == 0 || 2 * above_ < values_) return ScaleDecision{ReflectanceScale::fraction, true};
  if (first_below_) return std::unexpected(ScaleConflict{*first_below_});
  return ScaleDecision{ReflectanceScale::percent, true};
}

std::expected<ScaleDecision, ScaleConflict> decide_scale(ScaleRequest request,
                                                         std::span<const std::span<const double>> spectra) {
  ScaleTally tally;
  for (const auto& spectrum : spectra) tally.add(spectrum);
  return tally.decide(request);
}

}  // namespace skinspec
