#include "skinspec/spectral/table.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fmt/format.h>

#include "skinspec/spectral/utf8.hpp"
#include "skinspec/spectral/csv.hpp"
#include "text.hpp"

namespace skinspec {

std::string InputError::what() const {
  std::string where = printable(source);
  if (line > 0) where += fmt::format(":{}", line);
  if (line > 0 && column > 0) where += fmt::format(":{}", column);
  return where + ": " + message;
}

std::string Table::meta(std::string_view key) const {
  const auto it = meta_.find(key);
  return it == meta_.end() ? std::string() : it->second;
}

bool Table::has_column(std::string_view name) const { return std::ranges::find(columns_, name) != columns_.end(); }

std::span<const double> Table::column(std::string_view name) const {
  const auto it = std::ranges::find(columns_, name);
  if (it == columns_.end()) return {};
  return values_[static_cast<std::size_t>(it - columns_.begin())];
}

namespace {

constexpr std::string_view kRequiredMeta[] = {"title", "source", "licence", "units"};

}  // namespace

std::expected<Table, InputError> parse_table(std::string_view bytes, std::string_view source,
                                             std::span<const std::string_view> required_columns) {
  Table table;
  table.source_ = source;
  auto fail = [&](std::size_t line, std::size_t column, std::string message) {
    return std::unexpected(InputError{std::string(source), line, column, std::move(message)});
  };

  csv::Reader reader(bytes, csv::LoneCr::ends_line);
  bool have_header = false;
  while (const auto line = reader.peek()) {
    if (auto defect = text::utf8_error(line->text, line->number, source)) return std::unexpected(*defect);
    if (line->text.starts_with('#')) {
      if (have_header) return fail(line->number, 1, "metadata line after the header row");
      const auto colon = line->text.find(':');
      if (colon == std::string_view::npos) return fail(line->number, 1, "metadata line without 'key: value'");
      table.meta_[std::string(text::trim(line->text.substr(1, colon - 1)))] =
          std::string(text::trim(line->text.substr(colon + 1)));
      reader.skip_line();
      continue;
    }
    const auto row = text::read_utf8_row(reader, source);
    if (!row) return std::unexpected(row.error());
    const auto& cells = row->cells;
    const auto line_no = row->line;
    if (!have_header) {
      for (const auto& cell : cells) {
        const std::string name(text::trim(cell.text));
        if (name.empty()) return fail(cell.line, cell.column, "empty column name");
        if (table.has_column(name)) return fail(cell.line, cell.column, "duplicated column " + quote(name));
        table.columns_.push_back(name);
      }
      table.values_.resize(table.columns_.size());
      have_header = true;
      continue;
    }
    if (cells.size() != table.columns_.size())
      return fail(line_no, 0, fmt::format("{} cells where the header has {}", cells.size(), table.columns_.size()));
    const bool keyed = table.columns_.front() != "wavelength_nm";
    if (keyed) {
      const std::string key(text::trim(cells.front().text));
      if (key.empty()) return fail(line_no, 1, "empty key");
      if (std::ranges::find(table.keys_, key) != table.keys_.end())
        return fail(line_no, 1, "duplicated key " + quote(key));
      table.keys_.push_back(key);
    }
    for (std::size_t c = keyed ? 1 : 0; c < cells.size(); ++c) {
      const auto value = text::parse_number(cells[c].text);
      if (!value) return fail(cells[c].line, cells[c].column, value.error());
      table.values_[c].push_back(*value);
    }
    ++table.rows_;
  }

  for (const auto key : kRequiredMeta)
    if (table.meta(key).empty()) return fail(0, 0, fmt::format("missing '# {}:' line", key));
  if (!have_header) return fail(0, 0, "no header row");
  if (table.rows_ == 0) return fail(0, 0, "no data rows");
  for (const auto name : required_columns)
    if (!table.has_column(name)) return fail(0, 0, fmt::format("missing column '{}'", name));
  if (table.columns_.front() == "wavelength_nm") {
    const auto& w = table.values_.front();
    for (std::size_t i = 1; i < w.size(); ++i)
      if (!(w[i] > w[i - 1]))
        return fail(0, 0, fmt::format("wavelength {} nm does not increase after {} nm", w[i], w[i - 1]));
  }
  return table;
}

}  // namespace skinspec
