#pragma once
// Small text helpers shared by the table and spectra parsers (private to spectral/).

#include <cstddef>
#include <expected>
#include <optional>
#include <string>
#include <string_view>

#include "skinspec/spectral/csv.hpp"
#include "skinspec/spectral/table.hpp"

namespace skinspec::text {

std::string_view trim(std::string_view s);

// Where text stops being UTF-8, as an error of `source` naming the line (counted from
// `first_line`: a row of CSV runs over several lines where quotes keep line ends) and the
// column in it, and quoting the bytes (escaped) and the text before them on that line; nullopt
// when it is all UTF-8.
std::optional<InputError> utf8_error(std::string_view text, std::size_t first_line, std::string_view source);

// The row at reader.peek(), all of it UTF-8: else the reader's error or the first defect.
std::expected<csv::Row, InputError> read_utf8_row(csv::Reader& reader, std::string_view source);

// A finite decimal number (leading/trailing blanks allowed), or a message saying why not.
std::expected<double, std::string> parse_number(std::string_view cell);

}  // namespace skinspec::text
