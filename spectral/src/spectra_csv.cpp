#include "skinspec/spectral/spectra_csv.hpp"

#include <algorithm>
#include <fmt/format.h>
#include <span>
#include <utility>

#include "skinspec/spectral/utf8.hpp"
#include "skinspec/spectral/csv.hpp"
#include "text.hpp"

namespace skinspec {
namespace {

constexpr std::string_view kByteOrderMark = "\xEF\xBB\xBF";
constexpr std::string_view kWavelengthColumn = "wavelength_nm";

// Spreadsheets saving "CSV UTF-8" write a byte order mark before the header; left in place it
// would become part of the first column name and the header would be refused.
std::string_view without_byte_order_mark(std::string_view bytes) {
  if (bytes.starts_with(kByteOrderMark)) bytes.remove_prefix(kByteOrderMark.size());
  return bytes;
}

// Blank lines and "#" comment lines (a file's provenance, as in skinspec's own tables) carry
// no data.
bool carries_no_data(std::string_view line) {
  const auto trimmed = text::trim(line);
  return trimmed.empty() || trimmed.starts_with('#');
}

using Outcome = std::expected<void, InputError>;

// Reads the file row by row into columns, then turns each value column into a Spectrum.
// Defects in a row are found while that row is read, so their location is still at hand.
class SpectraParser {
 public:
  SpectraParser(std::string_view source, const SpectraLimits& limits) : source_(source), limits_(limits) {}

  std::expected<SpectraFile, InputError> parse(std::string_view bytes) {
    const auto content = without_byte_order_mark(bytes);
    csv::Reader reader(content, csv::LoneCr::ends_line);
    while (const auto line = reader.peek()) {
      // Before anything else, comments included: a name or cell that is not text cannot be shown.
      if (auto defect = text::utf8_error(line->text, line->number, source_)) return std::unexpected(*defect);
      if (carries_no_data(line->text)) {
        reader.skip_line();
        continue;
      }
      const auto row = text::read_utf8_row(reader, source_);
      if (!row) return std::unexpected(row.error());
      const auto read = has_header() ? read_row(*row) : read_header(*row);
      if (!read) return std::unexpected(read.error());
    }
    if (!has_header()) {
      const auto* what = content.empty() ? "the input is empty" : "the input holds only blank or comment lines";
      return fail(1, 0, fmt::format("{}; expected a header starting with '{}'", what, kWavelengthColumn));
    }
    const auto scale = decide();
    if (!scale) return std::unexpected(scale.error());
    if (const auto values = to_fractions(*scale); !values) return std::unexpected(values.error());
    if (const auto rows = check_row_count(); !rows) return std::unexpected(rows.error());
    if (const auto grid = check_coverage(); !grid) return std::unexpected(grid.error());
    auto spectra = build_spectra();
    if (!spectra) return std::unexpected(std::move(spectra.error()));
    return SpectraFile{std::move(*spectra), *scale};
  }

 private:
  // Where a cell was read: its line and column.
  struct Spot {
    std::size_t line = 0, column = 0;
  };

  std::unexpected<InputError> fail(std::size_t line, std::size_t column, std::string message) const {
    return std::unexpected(InputError{source_, line, column, std::move(message)});
  }
  std::unexpected<InputError> fail(const csv::Cell& cell, std::string message) const {
    return fail(cell.line, cell.column, std::move(message));
  }
  std::unexpected<InputError> fail(const Spot& spot, std::string message) const {
    return fail(spot.line, spot.column, std::move(message));
  }

  bool has_header() const { return !names_.empty(); }
  std::size_t row_count() const { return columns_.front().size(); }

  Outcome read_header(const csv::Row& row) {
    const auto& cells = row.cells;
    const auto& first = cells.front();
    const auto first_name = text::trim(first.text);
    // Data pasted without its header starts with a wavelength; "not named wavelength_nm"
    // would send the reader looking for a typo instead of the missing line.
    if (text::parse_number(first.text))
      return fail(first, fmt::format("the header is missing: this line starts with the number {} where a "
                                     "header starting with '{}' is expected",
                                     first_name, kWavelengthColumn));
    if (first_name != kWavelengthColumn)
      return fail(first,
                  fmt::format("the first column is named {}; it must be '{}'", quote(first_name), kWavelengthColumn));
    if (cells.size() < 2)
      return fail(row.line, 0,
                  fmt::format("the header names no spectrum: '{}' must be followed by at least "
                              "one column",
                              kWavelengthColumn));
    std::vector<std::string> names;
    for (const auto& cell : cells) {
      std::string name(text::trim(cell.text));
      if (name.empty()) return fail(cell, fmt::format("column {} has an empty name", names.size() + 1));
      if (const auto earlier = std::ranges::find(names, name); earlier != names.end())
        return fail(
            cell, fmt::format("duplicated column name {} (also column {})", quote(name), earlier - names.begin() + 1));
      names.push_back(std::move(name));
    }
    names_ = std::move(names);
    columns_.resize(names_.size());
    for (const auto& cell : cells) header_.push_back({cell.line, cell.column});
    last_content_line_ = row.line;
    return {};
  }

  Outcome read_row(const csv::Row& row) {
    const auto& cells = row.cells;
    if (const auto shape = check_cell_count(row); !shape) return shape;
    std::vector<Spot> spots;
    for (std::size_t c = 0; c < cells.size(); ++c) {
      const auto value = read_number(cells[c], names_[c]);
      if (!value) return std::unexpected(value.error());
      if (c == 0)
        if (const auto valid = check_wavelength_increases(*value, cells[c]); !valid) return valid;
      columns_[c].push_back(*value);
      spots.push_back({cells[c].line, cells[c].column});
    }
    rows_.push_back(std::move(spots));
    last_content_line_ = row.line;
    return {};
  }

  Outcome check_cell_count(const csv::Row& row) const {
    const auto& cells = row.cells;
    if (cells.size() > names_.size())
      return fail(cells[names_.size()], fmt::format("{} cells where the header has {}", cells.size(), names_.size()));
    if (cells.size() < names_.size())
      return fail(row.line, 0,
                  fmt::format("{} cells where the header has {}; the first without a value is {}", cells.size(),
                              names_.size(), quote(names_[cells.size()])));
    return {};
  }

  std::expected<double, InputError> read_number(const csv::Cell& cell, const std::string& column_name) const {
    const auto value = text::parse_number(cell.text);
    if (!value) return fail(cell, fmt::format("{} in column {}", value.error(), quote(column_name)));
    return *value;
  }

  Outcome check_wavelength_increases(double wavelength, const csv::Cell& cell) const {
    if (row_count() == 0) return {};
    const double previous = columns_.front().back();
    if (wavelength > previous) return {};
    const auto* relation = wavelength == previous ? "repeats" : "is below";
    return fail(cell, fmt::format("wavelength {} nm {} {} nm on line {}; wavelengths must strictly increase",
                                  wavelength, relation, previous, last_content_line_));
  }

  // The scale of the values, once all are read: auto looks at them all.
  std::expected<ScaleDecision, InputError> decide() const {
    std::vector<std::span<const double>> spectra(columns_.begin() + 1, columns_.end());
    const auto decided = decide_scale(limits_.scale, spectra);
    if (decided) return *decided;
    const std::size_t c = decided.error().spectrum + 1;
    return fail(header_[c], describe_conflict(names_[c]));
  }

  // Every value divided as the scale says, then held to the limits; the first outside them, in
  // the file's order, refuses the file.
  Outcome to_fractions(const ScaleDecision& scale) {
    const double divisor = scale.divisor();
    for (std::size_t r = 0; r < rows_.size(); ++r)
      for (std::size_t c = 1; c < names_.size(); ++c) {
        double& value = columns_[c][r];
        const double fraction = value / divisor;
        if (!(fraction >= limits_.min_value && fraction <= limits_.max_value))
          return fail(rows_[r][c], out_of_range(value, names_[c], scale));
        value = fraction;
      }
    return {};
  }

  // The range in the file's own scale.
  std::string out_of_range(double value, const std::string& column_name, const ScaleDecision& scale) const {
    const double divisor = scale.divisor();
    return fmt::format("value {} in column {} is outside the allowed range [{}, {}]{}", value, quote(column_name),
                       limits_.min_value * divisor, limits_.max_value * divisor, out_of_range_note(scale, value));
  }

  // Points at the header, or at the single row, so the reader sees where the data stops.
  Outcome check_row_count() const {
    if (row_count() >= 2) return {};
    return fail(last_content_line_, 0,
                fmt::format("{} data row{} below the header; a spectrum needs at least two", row_count(),
                            row_count() == 1 ? "" : "s"));
  }

  // Concerns the whole grid rather than one line, hence line 0.
  Outcome check_coverage() const {
    const auto& wavelengths = columns_.front();
    if (wavelengths.front() <= limits_.must_cover_from_nm && wavelengths.back() >= limits_.must_cover_to_nm) return {};
    return fail(0, 0,
                fmt::format("the wavelengths cover {}-{} nm but {}-{} nm is needed", wavelengths.front(),
                            wavelengths.back(), limits_.must_cover_from_nm, limits_.must_cover_to_nm));
  }

  std::expected<std::vector<NamedSpectrum>, InputError> build_spectra() {
    std::vector<NamedSpectrum> spectra;
    spectra.reserve(names_.size() - 1);
    for (std::size_t c = 1; c < names_.size(); ++c) {
      // The rows were checked above, so this only fails if Spectrum's rules grow stricter.
      auto spectrum = Spectrum::create(columns_.front(), std::move(columns_[c]));
      if (!spectrum) return fail(0, 0, fmt::format("column {}: {}", quote(names_[c]), spectrum.error()));
      spectra.push_back({std::move(names_[c]), std::move(*spectrum)});
    }
    return spectra;
  }

  std::string source_;
  SpectraLimits limits_;
  std::vector<std::string> names_;            // header order; names_[0] is wavelength_nm
  std::vector<std::vector<double>> columns_;  // columns_[c] holds the values under names_[c]
  std::vector<Spot> header_;                  // header_[c] is where names_[c] was read
  std::vector<std::vector<Spot>> rows_;       // rows_[r][c] is where columns_[c][r] was read
  std::size_t last_content_line_ = 0;         // the header's or the latest row's line
};

}  // namespace

std::expected<SpectraFile, InputError> parse_spectra_file(std::string_view bytes, std::string_view source,
                                                          const SpectraLimits& limits) {
  return SpectraParser(source, limits).parse(bytes);
}

std::expected<std::vector<NamedSpectrum>, InputError> parse_spectra_csv(std::string_view bytes, std::string_view source,
                                                                        const SpectraLimits& limits) {
  auto file = parse_spectra_file(bytes, source, limits);
  if (!file) return std::unexpected(std::move(file.error()));
  return std::move(file->spectra);
}

}  // namespace skinspec
