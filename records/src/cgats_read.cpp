// Reading CGATS (cgats.hpp): tokens, tables, and the spectra of the spectral ones.

#include "skinspec/records/cgats.hpp"

#include <fmt/format.h>

#include <cmath>
#include <map>
#include <optional>

#include "finite_number.hpp"

namespace skinspec::records {

namespace {

// ---- reading ----

struct Token {
  std::string text;
  std::size_t line = 0;
  bool quoted = false;
};

// CGATS is whitespace-separated tokens, strings in double quotes, '#' to the end of a line a
// comment. Line ends are kept as tokens of their own (text "\n") for the keyword lines.
std::expected<std::vector<Token>, CgatsError> tokens_of(std::string_view text) {
  std::vector<Token> out;
  std::size_t line = 1;
  for (std::size_t i = 0; i < text.size();) {
    const char c = text[i];
    if (c == '\n') {
      out.push_back({"\n", line++, false});
      ++i;
    } else if (c == ' ' || c == '\t' || c == '\r') {
      ++i;
    } else if (c == '#') {
      while (i < text.size() && text[i] != '\n') ++i;
    } else if (c == '"') {
      const auto end = text.find('"', i + 1);
      if (end == std::string_view::npos || text.substr(i, end - i).find('\n') != std::string_view::npos)
        return std::unexpected(CgatsError{line, "a quoted string is not closed on its line"});
      out.push_back({std::string(text.substr(i + 1, end - i - 1)), line, true});
      i = end + 1;
    } else {
      std::size_t end = i;
      while (end < text.size() && text[end] != ' ' && text[end] != '\t' && text[end] != '\r' && text[end] != '\n' &&
             text[end] != '"')
        ++end;
      out.push_back({std::string(text.substr(i, end - i)), line, false});
      i = end;
    }
  }
  return out;
}

// One table as read: its keywords, its fields, its sets (each a run of tokens).
struct Table {
  std::size_t line = 0;
  std::map<std::string, Token> keywords;
  std::vector<std::string> fields;
  std::size_t fields_line = 0;
  std::optional<long> declared_fields, declared_sets;
  std::size_t declared_sets_line = 0;
  std::vector<std::vector<Token>> sets;
};

class Reader {
 public:
  explicit Reader(std::vector<Token> tokens) : tokens_(std::move(tokens)) {}

  std::expected<std::vector<Table>, CgatsError> tables() {
    std::vector<Table> out;
    skip_line_ends();
    while (more()) {
      auto table = read_table();
      if (!table) return std::unexpected(table.error());
      out.push_back(std::move(*table));
      skip_line_ends();
    }
    if (out.empty()) return std::unexpected(CgatsError{0, "no CGATS table: the text is empty"});
    return out;
  }

 private:
  bool more() const { return at_ < tokens_.size(); }
  const Token& peek() const { return tokens_[at_]; }
  void skip_line_ends() {
    while (more() && peek().text == "\n" && !peek().quoted) ++at_;
  }
  std::size_t line() const { return more() ? peek().line : (tokens_.empty() ? 1 : tokens_.back().line); }
  bool is(std::string_view word) const { return more() && !peek().quoted && peek().text == word; }

  // The tokens of the rest of the line, the line end consumed.
  std::vector<Token> rest_of_line() {
    std::vector<Token> out;
    while (more() && !(peek().text == "\n" && !peek().quoted)) out.push_back(tokens_[at_++]);
    if (more()) ++at_;
    return out;
  }

  // The tokens up to the word `end` (across lines), which is consumed.
  std::expected<std::vector<Token>, CgatsError> block_until(std::string_view end, std::size_t opened) {
    std::vector<Token> out;
    while (more() && !is(end)) out.push_back(tokens_[at_++]);
    if (!more()) return std::unexpected(CgatsError{opened, fmt::format("no {} after the block begun here", end)});
    ++at_;
    return out;
  }

  std::expected<long, CgatsError> count_after(const std::string& keyword, std::size_t at_line) {
    const auto values = rest_of_line();
    const auto value = values.size() == 1 ? detail::finite_number(values[0].text) : std::nullopt;
    if (!value || *value < 0 || *value > 1e9 || *value != std::floor(*value))
      return std::unexpected(
          CgatsError{at_line, fmt::format("{} must be followed by a whole number up to 10^9", keyword)});
    return static_cast<long>(*value);
  }

  std::expected<Table, CgatsError> read_table() {
    Table table;
    table.line = line();
    rest_of_line();  // the file type: CTI3, CGATS.17, IT8.7/2 ...
    bool data_read = false;
    while (more() && !data_read) {
      skip_line_ends();
      if (!more()) break;
      const Token keyword = tokens_[at_++];
      if (keyword.text == "BEGIN_DATA_FORMAT") {
        auto fields = block_until("END_DATA_FORMAT", keyword.line);
        if (!fields) return std::unexpected(fields.error());
        for (auto& f : *fields)
          if (f.text != "\n" || f.quoted) table.fields.push_back(f.text);
        table.fields_line = keyword.line;
      } else if (keyword.text == "BEGIN_DATA") {
        if (auto sets = read_sets(table, keyword.line); !sets) return std::unexpected(sets.error());
        data_read = true;
      } else if (keyword.text == "NUMBER_OF_FIELDS" || keyword.text == "NUMBER_OF_SETS") {
        auto count = count_after(keyword.text, keyword.line);
        if (!count) return std::unexpected(count.error());
        if (keyword.text == "NUMBER_OF_FIELDS") {
          table.declared_fields = *count;
        } else {
          table.declared_sets = *count;
          table.declared_sets_line = keyword.line;
        }
      } else {
        const auto values = rest_of_line();
        table.keywords[keyword.text] = values.empty() ? Token{"", keyword.line, false} : values[0];
      }
    }
    if (!data_read) return std::unexpected(CgatsError{table.line, "the table begun here has no BEGIN_DATA"});
    if (table.declared_fields && static_cast<std::size_t>(*table.declared_fields) != table.fields.size())
      return std::unexpected(CgatsError{table.fields_line, fmt::format("NUMBER_OF_FIELDS is {} but {} fields are named",
                                                                       *table.declared_fields, table.fields.size())});
    if (table.declared_sets && static_cast<std::size_t>(*table.declared_sets) != table.sets.size())
      return std::unexpected(CgatsError{
          table.declared_sets_line,
          fmt::format("NUMBER_OF_SETS is {} but the data holds {} sets", *table.declared_sets, table.sets.size())});
    return table;
  }

  // Sets are one per line, as every writer puts them; a line with the wrong number of values is
  // the error, where it is.
  std::expected<void, CgatsError> read_sets(Table& table, std::size_t opened) {
    if (table.fields.empty()) return std::unexpected(CgatsError{opened, "BEGIN_DATA before BEGIN_DATA_FORMAT"});
    for (;;) {
      skip_line_ends();
      if (!more()) return std::unexpected(CgatsError{opened, "no END_DATA after the data begun here"});
      if (is("END_DATA")) {
        ++at_;
        return {};
      }
      const std::size_t set_line = line();
      auto set = rest_of_line();
      const bool last = !set.empty() && !set.back().quoted && set.back().text == "END_DATA";
      if (last) set.pop_back();
      if (set.size() != table.fields.size())
        return std::unexpected(CgatsError{
            set_line, fmt::format("{} values where the format names {} fields", set.size(), table.fields.size())});
      table.sets.push_back(std::move(set));
      if (last) return {};
    }
  }

  std::vector<Token> tokens_;
  std::size_t at_ = 0;
};

std::expected<double, CgatsError> keyword_number(const Table& table, const std::string& name) {
  const auto found = table.keywords.find(name);
  if (found == table.keywords.end())
    return std::unexpected(CgatsError{table.line, fmt::format("the spectral table begun here has no {}", name)});
  const auto value = detail::finite_number(found->second.text);
  if (!value) return std::unexpected(CgatsError{found->second.line, fmt::format("{} is not a number", name)});
  return *value;
}

// The grid SPECTRAL_BANDS, _START_NM and _END_NM describe.
std::expected<std::vector<double>, CgatsError> grid_of(const Table& table) {
  auto bands = keyword_number(table, "SPECTRAL_BANDS");
  auto start = keyword_number(table, "SPECTRAL_START_NM");
  auto end = keyword_number(table, "SPECTRAL_END_NM");
  for (const auto* value : {&bands, &start, &end})
    if (!*value) return std::unexpected(value->error());
  if (*bands < 2 || *bands > 10000 || *bands != std::floor(*bands) || !(*end > *start))
    return std::unexpected(CgatsError{table.keywords.at("SPECTRAL_BANDS").line,
                                      "SPECTRAL_BANDS must be 2 or more over SPECTRAL_START_NM < SPECTRAL_END_NM"});
  const auto n = static_cast<std::size_t>(*bands);
  std::vector<double> out(n);
  for (std::size_t i = 0; i < n; ++i) out[i] = *start + (*end - *start) * static_cast<double>(i) / (n - 1.0);
  return out;
}

std::size_t field_index(const Table& table, std::string_view name) {
  for (std::size_t i = 0; i < table.fields.size(); ++i)
    if (table.fields[i] == name) return i;
  return table.fields.size();
}

std::expected<void, CgatsError> spectra_of(const Table& table, std::vector<CgatsSpectrum>& out) {
  auto grid = grid_of(table);
  if (!grid) return std::unexpected(grid.error());
  double norm = 1;
  if (table.keywords.contains("SPECTRAL_NORM")) {
    auto given = keyword_number(table, "SPECTRAL_NORM");
    if (!given) return std::unexpected(given.error());
    if (!(*given > 0))
      return std::unexpected(CgatsError{table.keywords.at("SPECTRAL_NORM").line, "SPECTRAL_NORM must be above 0"});
    norm = *given;
  }
  std::vector<std::size_t> columns;
  for (const double wavelength : *grid) {
    const auto name = fmt::format("SPEC_{:03}", std::lround(wavelength));
    columns.push_back(field_index(table, name));
    if (columns.back() == table.fields.size())
      return std::unexpected(CgatsError{table.fields_line, fmt::format("no field {} for the band at {} nm of "
                                                                       "SPECTRAL_BANDS",
                                                                       name, wavelength)});
  }
  std::string instrument;
  for (const char* keyword : {"TARGET_INSTRUMENT", "INSTRUMENT"})
    if (const auto found = table.keywords.find(keyword); found != table.keywords.end() && instrument.empty())
      instrument = found->second.text;
  const auto id_column = field_index(table, "SAMPLE_ID");
  const auto name_column = field_index(table, "SAMPLE_NAME");
  for (std::size_t s = 0; s < table.sets.size(); ++s) {
    const auto& set = table.sets[s];
    CgatsSpectrum spectrum;
    spectrum.line = set.front().line;
    spectrum.instrument = instrument;
    spectrum.wavelength_nm = *grid;
    for (std::size_t b = 0; b < columns.size(); ++b) {
      const auto& token = set[columns[b]];
      const auto value = token.quoted ? std::nullopt : detail::finite_number(token.text);
      if (!value)
        return std::unexpected(
            CgatsError{token.line, fmt::format("{} is '{}', not a number", table.fields[columns[b]], token.text)});
      spectrum.reflectance.push_back(*value / norm);
    }
    for (std::size_t f = 0; f < set.size(); ++f) spectrum.fields.emplace_back(table.fields[f], set[f].text);
    if (name_column < set.size()) spectrum.sample_name = set[name_column].text;
    spectrum.sample_id = id_column < set.size()          ? set[id_column].text
                         : !spectrum.sample_name.empty() ? spectrum.sample_name
                                                         : std::to_string(s + 1);
    out.push_back(std::move(spectrum));
  }
  return {};
}

}  // namespace

std::expected<std::vector<CgatsSpectrum>, CgatsError> parse_cgats(std::string_view text) {
  auto tokens = tokens_of(text);
  if (!tokens) return std::unexpected(tokens.error());
  auto tables = Reader(std::move(*tokens)).tables();
  if (!tables) return std::unexpected(tables.error());
  std::vector<CgatsSpectrum> out;
  for (const auto& table : *tables) {
    if (!table.keywords.contains("SPECTRAL_BANDS")) continue;
    if (auto read = spectra_of(table, out); !read) return std::unexpected(read.error());
  }
  return out;
}

}  // namespace skinspec::records
