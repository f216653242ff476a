#include "skinspec/records/import.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <span>

#include "import_csv.hpp"
#include "skinspec/records/cgats.hpp"
#include "skinspec/spectral/csv.hpp"
#include "skinspec/spectral/enum_names.hpp"
#include "skinspec/spectral/utf8.hpp"

namespace skinspec::records {

namespace {

using detail::is_reflectance;
using detail::kLowestReflectance;
using detail::names_wavelengths;
using detail::trimmed;

constexpr EnumNames<ImportFormat, 2> kFormats = {{
    {ImportFormat::csv, "csv"},
    {ImportFormat::cgats, "cgats"},
}};

struct Row {
  std::size_t line = 0;
  std::vector<std::string_view> cells;  // trimmed, into the file or into its csv::Reader
};

// The file's rows. Lines starting with '#' before the header are skipped (a comment there is
// not parsed for quotes); after the header such a line is data, where '#12' may well be a
// sample's name.
std::expected<std::vector<Row>, InputError> rows_of(csv::Reader& reader, std::string_view source) {
  std::vector<Row> rows;
  while (const auto line = reader.peek()) {
    if (rows.empty() && trimmed(line->text).starts_with('#')) {
      reader.skip_line();
      continue;
    }
    auto read = reader.read_row();
    if (!read) return std::unexpected(InputError{std::string(source), read.error().line, 0, read.error().message});
    Row row{read->line, {}};
    row.cells.reserve(read->cells.size());
    for (const auto& cell : read->cells) row.cells.push_back(trimmed(cell.text));
    rows.push_back(std::move(row));
  }
  return rows;
}

class CsvReader {
 public:
  CsvReader(std::vector<Row> rows, std::string_view source, ScaleRequest scale)
      : rows_(std::move(rows)), source_(source), scale_(scale) {}

  std::expected<std::vector<ImportedSpectrum>, InputError> read() {
    if (rows_.size() < 2) return fail(rows_.empty() ? 0 : rows_[0].line, 0, "no header and data rows");
    by_columns_ = names_wavelengths(std::string(rows_[0].cells[0]));
    auto spectra = by_columns_ ? by_columns() : by_rows();
    if (!spectra) return spectra;
    if (auto scaled = to_fractions(*spectra); !scaled) return std::unexpected(scaled.error());
    return spectra;
  }

 private:
  std::unexpected<InputError> fail(std::size_t line, std::size_t column, std::string message) const {
    return std::unexpected(InputError{std::string(source_), line, column, std::move(message)});
  }

  std::expected<double, InputError> value_at(const Row& row, std::size_t column) const {
    if (column >= row.cells.size())
      return fail(row.line, 0, fmt::format("{} fields where the header has more", row.cells.size()));
    const auto value = detail::finite_number(row.cells[column]);
    if (!value) return fail(row.line, column + 1, fmt::format("'{}' is not a number", row.cells[column]));
    return *value;
  }

  std::expected<void, InputError> check_width(const Row& row) const {
    if (row.cells.size() != rows_[0].cells.size())
      return fail(row.line, 0,
                  fmt::format("{} fields where the header has {}", row.cells.size(), rows_[0].cells.size()));
    return {};
  }

  // One column per spectrum, one row per wavelength.
  std::expected<std::vector<ImportedSpectrum>, InputError> by_columns() {
    const auto& header = rows_[0].cells;
    if (header.size() < 2) return fail(rows_[0].line, 0, "no spectrum column after the wavelength column");
    std::vector<ImportedSpectrum> out(header.size() - 1);
    for (std::size_t c = 1; c < header.size(); ++c) {
      if (header[c].empty()) return fail(rows_[0].line, c + 1, "a spectrum column without a name");
      out[c - 1].sample_id = std::string(header[c]);
      out[c - 1].line = rows_[1].line;
    }
    for (std::size_t r = 1; r < rows_.size(); ++r) {
      if (auto width = check_width(rows_[r]); !width) return std::unexpected(width.error());
      const auto wavelength = value_at(rows_[r], 0);
      if (!wavelength) return std::unexpected(wavelength.error());
      if (r > 1 && !(*wavelength > out[0].reflectance.wavelength_nm.back()))
        return fail(rows_[r].line, 1, "the wavelengths must increase from row to row");
      for (std::size_t c = 1; c < header.size(); ++c) {
        const auto value = value_at(rows_[r], c);
        if (!value) return std::unexpected(value.error());
        out[c - 1].reflectance.wavelength_nm.push_back(*wavelength);
        out[c - 1].reflectance.values.push_back(*value);
      }
    }
    return out;
  }

  // One row per spectrum: text columns (the first the sample id), then wavelength columns.
  std::expected<std::vector<ImportedSpectrum>, InputError> by_rows() {
    const auto& header = rows_[0].cells;
    auto columns = detail::wavelength_columns(header);
    if (!columns) return fail(rows_[0].line, columns.error().column, columns.error().message);
    const std::size_t first = columns->first;
    const auto& grid = columns->grid;
    first_value_column_ = first;
    std::vector<ImportedSpectrum> out;
    for (std::size_t r = 1; r < rows_.size(); ++r) {
      if (auto width = check_width(rows_[r]); !width) return std::unexpected(width.error());
      ImportedSpectrum spectrum;
      spectrum.sample_id = first > 0 && !rows_[r].cells[0].empty() ? std::string(rows_[r].cells[0]) : std::to_string(r);
      spectrum.line = rows_[r].line;
      spectrum.reflectance.wavelength_nm = grid;
      for (std::size_t c = first; c < header.size(); ++c) {
        const auto value = value_at(rows_[r], c);
        if (!value) return std::unexpected(value.error());
        spectrum.reflectance.values.push_back(*value);
      }
      out.push_back(std::move(spectrum));
    }
    return out;
  }

  // Where value k of spectrum i was read (1-based line and column).
  std::pair<std::size_t, std::size_t> position(std::size_t i, std::size_t k) const {
    if (by_columns_) return {rows_[k + 1].line, i + 2};
    return {rows_[i + 1].line, first_value_column_ + k + 1};
  }

  // Every value divided as the file's scale says (reflectance_scale.hpp), then held to a
  // reflectance.
  std::expected<void, InputError> to_fractions(std::vector<ImportedSpectrum>& spectra) const {
    std::vector<std::span<const double>> values;
    for (const auto& s : spectra) {
      if (s.reflectance.values.size() < 2) return fail(s.line, 0, "a spectrum needs at least two wavelengths");
      values.emplace_back(s.reflectance.values);
    }
    const auto scale = decide_scale(scale_, values);
    if (!scale) {
      const auto& stray = spectra[scale.error().spectrum];
      return fail(stray.line, 0, describe_conflict(stray.sample_id));
    }
    const double divisor = scale->divisor();
    for (std::size_t i = 0; i < spectra.size(); ++i) {
      spectra[i].scale = scale->scale;
      for (std::size_t k = 0; k < spectra[i].reflectance.values.size(); ++k) {
        double& value = spectra[i].reflectance.values[k];
        if (is_reflectance(value / divisor)) {
          value /= divisor;
          continue;
        }
        const auto [line, column] = position(i, k);
        return fail(line, column, detail::not_a_reflectance(value, *scale));
      }
    }
    return {};
  }

  std::vector<Row> rows_;
  std::string_view source_;
  ScaleRequest scale_;
  bool by_columns_ = false;
  std::size_t first_value_column_ = 0;  // of the rows layout: the first wavelength column
};

std::expected<std::vector<ImportedSpectrum>, InputError> read_cgats(std::string_view bytes, std::string_view source) {
  auto read = parse_cgats(bytes);
  if (!read) return std::unexpected(InputError{std::string(source), read.error().line, 0, read.error().message});
  std::vector<ImportedSpectrum> out;
  for (auto& s : *read) {
    for (std::size_t k = 0; k < s.reflectance.size(); ++k)
      if (!is_reflectance(s.reflectance[k]))
        return std::unexpected(
            InputError{std::string(source), s.line, 0,
                       fmt::format("{} at {} nm is not a reflectance ({} to {}, over SPECTRAL_NORM)", s.reflectance[k],
                                   s.wavelength_nm[k], kLowestReflectance, kPercentAbove)});
    out.push_back({std::move(s.sample_id), s.line, std::move(s.instrument),
                   store::SpectralSamples{std::move(s.wavelength_nm), std::move(s.reflectance)}, std::nullopt});
  }
  return out;
}

}  // namespace

std::string_view to_string(ImportFormat format) { return name_of(kFormats, format); }

std::optional<ImportFormat> parse_import_format(std::string_view text) { return value_named(kFormats, text); }

ImportFormat recognise_import_format(std::string_view bytes) {
  if (bytes.starts_with("\xEF\xBB\xBF")) bytes.remove_prefix(3);
  const auto start = bytes.find_first_not_of(" \t\r\n");
  if (start == std::string_view::npos) return ImportFormat::csv;
  const auto first_word = bytes.substr(start, bytes.find_first_of(" \t\r\n,", start) - start);
  const bool cgats_type = first_word.starts_with("CGATS") || first_word == "CTI1" || first_word == "CTI2" ||
                          first_word == "CTI3" || first_word == "SPECT" || first_word.starts_with("IT8") ||
                          first_word == "LGOROWLENGTH" || first_word == "ECI2002";
  return cgats_type && bytes.find("BEGIN_DATA") != std::string_view::npos ? ImportFormat::cgats : ImportFormat::csv;
}

std::expected<std::vector<ImportedSpectrum>, InputError> read_import(std::string_view bytes, std::string_view source,
                                                                     ImportFormat format, ScaleRequest scale) {
  // Spreadsheet programs put a byte order mark in front; the store keeps UTF-8 text without NUL.
  if (bytes.starts_with("\xEF\xBB\xBF")) bytes.remove_prefix(3);
  const auto defect = utf8::first_defect(bytes);
  const auto nul = bytes.find('\0');
  if (defect || nul != std::string_view::npos) {
    const auto at = std::min(defect ? defect->offset : bytes.size(), nul);
    const auto line =
        static_cast<std::size_t>(std::count(bytes.begin(), bytes.begin() + static_cast<long>(at), '\n')) + 1;
    return std::unexpected(InputError{std::string(source), line, 0, "not UTF-8 text: save the file as UTF-8"});
  }
  std::expected<std::vector<ImportedSpectrum>, InputError> spectra;
  if (format == ImportFormat::cgats) {
    if (scale != ScaleRequest::automatic)
      return std::unexpected(InputError{std::string(source), 0, 0,
                                        fmt::format("scale {} is for CSV files: a CGATS file gives its own "
                                                    "(SPECTRAL_NORM)",
                                                    to_string(scale))});
    spectra = read_cgats(bytes, source);
  } else {
    csv::Reader reader(bytes);  // holds the text of quoted cells while they are read
    auto rows = rows_of(reader, source);
    if (!rows) return std::unexpected(rows.error());
    spectra = CsvReader(std::move(*rows), source, scale).read();
  }
  if (spectra && spectra->empty()) return std::unexpected(InputError{std::string(source), 0, 0, "no spectra in it"});
  return spectra;
}

}  // namespace skinspec::records
