#pragma once
// skinspec's data-table format: CSV with "# key: value" metadata lines first, then a header
// row and numeric rows. Every table must say where its numbers come from (title, source,
// licence, units); a table that does not is refused, as is any malformed row.
//
// Parsing takes bytes, never a path: the caller reads the file (skinspec_spectral does no I/O;
// the programs read data/ through spectral/io/data_dir.hpp).

#include <expected>
#include <functional>
#include <map>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace skinspec {

// An error located in a text input: file name, 1-based line and (where known) column.
struct InputError {
  std::string source;
  std::size_t line = 0;    // 0 when the error concerns the whole input
  std::size_t column = 0;  // 0 when the error concerns the whole line
  std::string message;

  // "source:line:column: message", leaving out what is unknown.
  std::string what() const;
};

class Table {
 public:
  const std::string& source() const { return source_; }
  const std::vector<std::string>& columns() const { return columns_; }
  std::size_t rows() const { return rows_; }
  // The metadata value for key ("title", "source", ...), empty when absent.
  std::string meta(std::string_view key) const;
  bool has_column(std::string_view name) const;
  // Values of a numeric column; empty when there is no such column.
  std::span<const double> column(std::string_view name) const;
  // A keyed table (first column not wavelength_nm) holds text in its first column: the row keys.
  const std::vector<std::string>& keys() const { return keys_; }

 private:
  friend std::expected<Table, InputError> parse_table(std::string_view, std::string_view,
                                                      std::span<const std::string_view>);
  std::string source_;
  std::map<std::string, std::string, std::less<>> meta_;
  std::vector<std::string> columns_;
  std::vector<std::vector<double>> values_;  // one vector per column (the key column's is empty)
  std::vector<std::string> keys_;
  std::size_t rows_ = 0;
};

// Parses a table. A spectral table's first column is "wavelength_nm", strictly increasing; any
// other first column holds unique text keys (a site name, a constant's name). Every other cell
// is a finite number. required_columns must all be there.
std::expected<Table, InputError> parse_table(std::string_view bytes, std::string_view source,
                                             std::span<const std::string_view> required_columns);

// Reads a file of the data directory by its relative path ("optics/hemoglobin_prahl.csv").
// Supplied by the program, so that the model code itself never touches the file system.
using DataReader = std::function<std::expected<std::string, std::string>(std::string_view)>;

}  // namespace skinspec
