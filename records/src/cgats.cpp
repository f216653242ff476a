#include "skinspec/records/cgats.hpp"

#include <fmt/format.h>

#include <charconv>
#include <cmath>
#include <map>
#include <optional>
#include <ostream>

#include "skinspec/records/record_json.hpp"

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

std::optional<double> number_of(const std::string& text) {
  double value = 0;
  const auto* first = text.data() + (text.starts_with('+') ? 1 : 0);
  const auto [end, error] = std::from_chars(first, text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || !std::isfinite(value)) return std::nullopt;
  return value;
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
    const auto value = values.size() == 1 ? number_of(values[0].text) : std::nullopt;
    if (!value || *value < 0 || *value != std::floor(*value))
      return std::unexpected(CgatsError{at_line, fmt::format("{} must be followed by a whole number", keyword)});
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
  const auto value = number_of(found->second.text);
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
  const auto id_column = field_index(table, "SAMPLE_ID");
  const auto name_column = field_index(table, "SAMPLE_NAME");
  for (std::size_t s = 0; s < table.sets.size(); ++s) {
    const auto& set = table.sets[s];
    CgatsSpectrum spectrum;
    spectrum.line = set.front().line;
    spectrum.wavelength_nm = *grid;
    for (std::size_t b = 0; b < columns.size(); ++b) {
      const auto& token = set[columns[b]];
      const auto value = token.quoted ? std::nullopt : number_of(token.text);
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

// ---- writing ----

std::string cgats_string(std::string_view text) {
  std::string out = "\"";
  for (const char c : text) out += (c == '"' || c == '\n' || c == '\r') ? '\'' : c;
  return out + '"';
}

// The SPEC_nnn names of an even grid on whole nanometres, or why it has none.
std::expected<std::vector<std::string>, std::string> band_names(const std::vector<double>& grid) {
  if (grid.size() < 2) return std::unexpected("fewer than two wavelengths");
  const double step = (grid.back() - grid.front()) / static_cast<double>(grid.size() - 1);
  std::vector<std::string> names;
  for (std::size_t i = 0; i < grid.size(); ++i) {
    const double expected = grid.front() + step * static_cast<double>(i);
    if (std::abs(grid[i] - expected) > 1e-6 * step)
      return std::unexpected(fmt::format("the wavelengths are not evenly spaced (at {} nm)", grid[i]));
    if (std::abs(grid[i] - std::round(grid[i])) > 1e-9)
      return std::unexpected(fmt::format("{} nm is not a whole number of nanometres", grid[i]));
    names.push_back(fmt::format("SPEC_{:03}", std::lround(grid[i])));
  }
  return names;
}

void write_table(const store::Session& session, const std::vector<double>& grid, const std::vector<std::string>& names,
                 const std::vector<const store::Measurement*>& sets, std::ostream& out) {
  out << "CTI3\n\n"
      << "DESCRIPTOR "
      << cgats_string(
             fmt::format("skinspec session {}: subject {}, site {}", session.id, session.subject, session.site))
      << "\nORIGINATOR \"skinspec\"\n"
      << "CREATED " << cgats_string(json_time(session.created_at))
      << '\n'
      // ArgyllCMS's tools need a device class; measured reflective samples are what its INPUT
      // (scanner and camera) references hold.
      << "DEVICE_CLASS \"INPUT\"\n"
      << "KEYWORD \"SAMPLE_NAME\"\n"
      << "INSTRUMENT_TYPE_SPECTRAL \"YES\"\n"
      << fmt::format("SPECTRAL_BANDS \"{}\"\nSPECTRAL_START_NM \"{}\"\nSPECTRAL_END_NM \"{}\"\n", grid.size(),
                     grid.front(), grid.back())
      << "SPECTRAL_NORM \"100\"\n\n"
      << "NUMBER_OF_FIELDS " << names.size() + 2 << "\nBEGIN_DATA_FORMAT\nSAMPLE_ID SAMPLE_NAME";
  for (const auto& name : names) out << ' ' << name;
  out << "\nEND_DATA_FORMAT\n\nNUMBER_OF_SETS " << sets.size() << "\nBEGIN_DATA\n";
  for (const auto* m : sets) {
    out << m->id << ' ' << cgats_string(m->label);
    for (const double v : m->reflectance.values) out << ' ' << fmt::format("{}", v * 100);
    out << '\n';
  }
  out << "END_DATA\n";
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

std::expected<void, std::string> write_cgats(const store::SessionDetail& detail, std::ostream& out) {
  // Tables in the order their grids first appear; sets in the order stored.
  std::vector<std::pair<std::vector<double>, std::vector<const store::Measurement*>>> tables;
  for (const auto& m : detail.measurements) {
    if (m.reflectance.empty()) continue;
    auto same = std::ranges::find(tables, m.reflectance.wavelength_nm, [](const auto& t) { return t.first; });
    if (same == tables.end()) same = tables.insert(tables.end(), {m.reflectance.wavelength_nm, {}});
    same->second.push_back(&m);
  }
  for (std::size_t t = 0; t < tables.size(); ++t) {
    const auto& [grid, sets] = tables[t];
    const auto names = band_names(grid);
    if (!names)
      return std::unexpected(fmt::format("measurement {}: its reflectance cannot be written as CGATS: {}",
                                         sets.front()->id, names.error()));
    if (t > 0) out << '\n';
    write_table(detail.session, grid, *names, sets, out);
  }
  return {};
}

}  // namespace skinspec::records
