#pragma once
// How a file writes reflectance: as fractions of 1 (0.35) or in percent (35), and the one rule by
// which `auto` tells them apart. `skinspec fit` (spectra_csv.hpp) and imports
// (skinspec/records/import.hpp) both read by it.
//
// auto reads a file as percent when at least half of its values exceed 1.5, and as fractions
// otherwise. No fraction of reflected light exceeds 1.5, while skin in percent lies above 1.5
// nearly everywhere: dark skin may dip below it at short wavelengths, but not over half of a
// spectrum. A fraction file with a few values above 1.5 (typing errors) is thus still read as
// fractions, and refused by its range check at the first of them. In a file read as percent by
// auto, every spectrum must exceed 1.5 somewhere: one that stays at or below it throughout is on
// another scale than the rest (a column of fractions among percent). Asked for percent, every
// value is divided by 100 and nothing else is checked here; asked for fractions, the values are
// taken as they are. Either way the reader's range check applies to the values as fractions.

#include <cstddef>
#include <expected>
#include <optional>
#include <span>
#include <string>
#include <string_view>

namespace skinspec {

enum class ReflectanceScale { fraction, percent };

// What a reader is told: one of the scales, or `auto`.
enum class ScaleRequest { automatic, fraction, percent };

// Above this a value is no fraction of reflected light (docs: "auto" above).
inline constexpr double kPercentAbove = 1.5;

std::string_view to_string(ReflectanceScale scale);  // "fraction", "percent"
std::string_view to_string(ScaleRequest request);    // "auto", "fraction", "percent"
std::optional<ScaleRequest> parse_scale_request(std::string_view text);
// "auto, fraction or percent": for messages and help.
std::string scale_request_names();

// How a file's values were read.
struct ScaleDecision {
  ReflectanceScale scale = ReflectanceScale::fraction;
  bool automatic = false;  // decided by auto from the values, not asked for

  // What a value of the file is divided by to become a fraction: 1 or 100.
  double divisor() const { return scale == ReflectanceScale::percent ? 100.0 : 1.0; }
};

// "percent (auto)", "fraction": for notes and messages.
std::string describe(const ScaleDecision& decision);
// What a message about `value`, out of range, adds: how the file was read ("; values read as
// percent (auto)"), and why not as percent where auto read fractions; nothing where fractions
// were asked for.
std::string out_of_range_note(const ScaleDecision& decision, double value);

// A file that auto reads as percent, holding a spectrum that stays at or below 1.5 throughout.
struct ScaleConflict {
  std::size_t spectrum = 0;  // its index among the spectra given
};
// Why that spectrum refuses the file, naming it (quoted, printable).
std::string describe_conflict(std::string_view spectrum_name);

// decide_scale's rule over spectra given one at a time, for a file too large to hold whole.
class ScaleTally {
 public:
  // Whether the spectrum stays at or below kPercentAbove throughout.
  bool add(std::span<const double> spectrum);
  std::expected<ScaleDecision, ScaleConflict> decide(ScaleRequest request) const;

 private:
  std::size_t spectra_ = 0, values_ = 0, above_ = 0;
  std::optional<std::size_t> first_below_;  // the first spectrum with no value above kPercentAbove
};

// The scale of a file's values, one span per spectrum, for `request` (auto above).
std::expected<ScaleDecision, ScaleConflict> decide_scale(ScaleRequest request,
                                                         std::span<const std::span<const double>> spectra);

}  // namespace skinspec
