// Copying a database: the tables as data (their columns and each column's type), one generic
// copy and digest over them, and what an engine needs after rows were inserted with their ids.

#include "skinspec/store/copy.hpp"

#include <fmt/format.h>

#include <array>
#include <bit>
#include <cstring>
#include <limits>
#include <optional>
#include <string_view>

#include "rows.hpp"
#include "store_impl.hpp"

namespace skinspec::store {

namespace {

using detail::Connection;
using detail::Param;
using Kind = StoreError::Kind;

enum class Column { integer, real, boolean, text, blob, time };

struct Table {
  std::string_view name;
  std::string_view columns;  // as rows.hpp lists them, the key's columns first
  std::vector<Column> types;
  std::string_view key = "id";  // its rows' order: its primary key, integers
  int page_rows = 256;          // read at a time, so that a large table is never held whole
  std::string_view where = {};  // the rows copied, when not all: those every read may see
};

// Each table after those its rows refer to; a measurement refers to an earlier one (its white),
// so rows go in key order. A page of a map's data is a few MiB.
const std::array<Table, 11>& tables() {
  using enum Column;
  // An import not yet published is no record of the database (staged_imports.hpp): neither its
  // measurements nor their fits are copied.
  static const std::string kFitPublished =
      fmt::format("EXISTS (SELECT 1 FROM measurements WHERE id = fits.measurement_id AND {})", detail::kPublished);
  static const std::array<Table, 11> kTables = {{
      {"instruments", detail::kInstrumentColumns, {integer, text, text, text, text, time, time}},
      {"white_standards", detail::kWhiteStandardColumns, {integer, text, text, blob, time}},
      {"sessions",
       detail::kSessionColumns,
       {integer, text, text, text, text, integer, text, time, time, time, text, text}},
      {"jobs",
       detail::kJobColumns,
       {integer, text, text, text, integer, text, text, text, text, time, time, time, text}},
      {"measurements",
       detail::kMeasurementColumns,
       {integer, integer, text, text, integer, integer, integer, boolean, integer, text, text,
        text,    integer, blob, blob, blob,    text,    blob,    time,    time,    time},
       "id",
       256,
       detail::kPublished},
      {"fits",
       detail::kFitColumns,
       {integer, integer, text, text, text, text, real, real, real,    integer,
        boolean, text,    text, text, text, text, blob, blob, integer, time},
       "id",
       256,
       kFitPublished},
      {"rejected_readings",
       detail::kRejectedReadingColumns,
       {integer, integer, integer, integer, integer, integer, text, text, blob, time, time}},
      {"maps", detail::kMapColumns, {integer, integer, integer, text, text, text, integer, integer, time}},
      {"map_data", detail::kMapDataColumns, {integer, integer, integer, blob}, "map_id, part, piece", 4},
      {"map_pictures", detail::kMapPictureColumns, {integer, integer, text, blob}, "map_id, ordinal"},
      {"audit", detail::kAuditColumns, {integer, time, text, text, text, text}},
  }};
  return kTables;
}

std::size_t column_count(std::string_view columns) {
  return static_cast<std::size_t>(std::count(columns.begin(), columns.end(), ',')) + 1;
}

// One row's values, owning the bytes the Params point into.
struct Row {
  std::vector<Param> values;
  std::vector<std::string> bytes;
};

void read_row(const detail::Statement& row, const Table& table, Row& out) {
  out.values.clear();
  out.bytes.clear();
  out.bytes.reserve(table.types.size());  // no reallocation: the views below stay valid
  for (int c = 0; c < static_cast<int>(table.types.size()); ++c) {
    if (row.is_null(c)) {
      out.values.emplace_back(detail::Null{});
      continue;
    }
    switch (table.types[static_cast<std::size_t>(c)]) {
      case Column::integer:
        out.values.emplace_back(row.integer(c));
        break;
      case Column::real:
        out.values.emplace_back(row.real(c));
        break;
      case Column::boolean:
        out.values.emplace_back(row.boolean(c));
        break;
      case Column::text:
        out.values.emplace_back(std::string_view(out.bytes.emplace_back(row.text(c))));
        break;
      case Column::blob:
        out.values.emplace_back(detail::Blob{out.bytes.emplace_back(row.blob(c))});
        break;
      case Column::time:
        out.values.emplace_back(row.time(c));
        break;
    }
  }
}

// FNV-1a over typed values: a tag per type, then the value's bytes (lengths before text).
class Digest {
 public:
  void add(const Param& value) {
    std::visit(
        [&](const auto& v) {
          using T = std::decay_t<decltype(v)>;
          if constexpr (std::is_same_v<T, detail::Null>) {
            tag(0);
          } else if constexpr (std::is_same_v<T, std::int64_t>) {
            tag(1), number(static_cast<std::uint64_t>(v));
          } else if constexpr (std::is_same_v<T, double>) {
            tag(2), number(std::bit_cast<std::uint64_t>(v));
          } else if constexpr (std::is_same_v<T, bool>) {
            tag(3), tag(v ? 1 : 0);
          } else if constexpr (std::is_same_v<T, std::string_view>) {
            tag(4), number(v.size()), text(v);
          } else if constexpr (std::is_same_v<T, detail::Blob>) {
            tag(5), number(v.bytes.size()), text(v.bytes);
          } else {
            tag(6), number(static_cast<std::uint64_t>(v.time_since_epoch().count()));
          }
        },
        value);
  }
  std::string hex() const { return fmt::format("{:016x}", hash_); }

 private:
  void tag(unsigned char byte) { hash_ = (hash_ ^ byte) * 0x100000001b3ULL; }
  void number(std::uint64_t value) {
    for (int i = 0; i < 8; ++i) tag(static_cast<unsigned char>(value >> (8 * i)));
  }
  void text(std::string_view bytes) {
    for (const char c : bytes) tag(static_cast<unsigned char>(c));
  }
  std::uint64_t hash_ = 0xcbf29ce484222325ULL;
};

// A page of rows at a time, after the key ?1... of the page before (PostgreSQL hands over all
// of a statement's rows at once).
std::string select_page(const Table& table) {
  const auto key_columns = static_cast<int>(column_count(table.key));
  return fmt::format("SELECT {} FROM {} WHERE ({}) > ({}){}{} ORDER BY {} LIMIT {}", table.columns, table.name,
                     table.key, detail::placeholders(1, key_columns), table.where.empty() ? "" : " AND ", table.where,
                     table.key, table.page_rows);
}

void check_listed(const Table& table) {
  if (column_count(table.columns) != table.types.size() || !table.columns.starts_with(table.key))
    detail::fail(Kind::internal, fmt::format("the copy lists {} types and the key ({}) for the columns of {}",
                                             table.types.size(), table.key, table.name));
}

// Every row of `table` on `c`, in key order: their count and digest, each row also handed to
// `each` when given.
TableCopy scan(Connection& c, const Table& table, const std::function<void(const Row&)>& each = {}) {
  check_listed(table);
  TableCopy out{std::string(table.name), 0, ""};
  Digest digest;
  Row row;
  std::vector<Id> after(column_count(table.key), std::numeric_limits<Id>::min());
  for (int in_page = table.page_rows; in_page == table.page_rows;) {
    auto rows = c.prepare(select_page(table));
    for (std::size_t k = 0; k < after.size(); ++k) rows.bind_at(static_cast<int>(k) + 1, after[k]);
    for (in_page = 0; rows.step(); ++in_page) {
      read_row(rows, table, row);
      for (const auto& value : row.values) digest.add(value);
      if (each) each(row);
      ++out.rows;
      for (std::size_t k = 0; k < after.size(); ++k) after[k] = rows.integer(static_cast<int>(k));
    }
  }
  out.digest = digest.hex();
  return out;
}

std::string insert_all(const Table& table) {
  std::string placeholders;
  for (std::size_t i = 1; i <= table.types.size(); ++i) placeholders += fmt::format("{}?{}", i > 1 ? ", " : "", i);
  return fmt::format("INSERT INTO {} ({}) VALUES ({})", table.name, table.columns, placeholders);
}

std::int64_t rows_in(Connection& c, const Table& table) {
  return c.query_integer(fmt::format("SELECT count(*) FROM {}", table.name));
}

// Rows inserted with their ids leave PostgreSQL's identity sequences behind: the next id must
// follow the largest copied one. (SQLite takes the largest id plus one by itself.)
void continue_ids_after_copied_ones(Connection& c) {
  if (c.dialect() != detail::Dialect::postgresql) return;
  for (const auto& table : tables()) {
    if (table.key != "id") continue;  // a table without ids of its own
    c.execute(
        fmt::format("SELECT setval(pg_get_serial_sequence('{0}', 'id'), max(id)) FROM {0} HAVING max(id) IS "
                    "NOT NULL",
                    table.name));
  }
}

void require_same(const std::vector<TableCopy>& source, Connection& destination, std::string_view when) {
  for (std::size_t i = 0; i < source.size(); ++i) {
    const auto there = scan(destination, tables()[i]);
    if (there.rows != source[i].rows || there.digest != source[i].digest) {
      detail::fail(Kind::conflict,
                   fmt::format("{}: {} holds {} rows (digest {}) where the source has {} (digest {})", when,
                               source[i].table, there.rows, there.digest, source[i].rows, source[i].digest));
    }
  }
}

// Source and destination both open, each in its transaction: the report, and in the
// destination's transaction a copy read back and verified, or nothing.
CopyReport copy_between(Connection& source, Connection& destination) {
  CopyReport report;
  bool empty = true;
  for (const auto& table : tables()) empty = empty && rows_in(destination, table) == 0;
  if (!empty) {
    for (const auto& table : tables()) report.tables.push_back(scan(source, table));
    require_same(report.tables, destination, "the destination already holds records");
    report.already_copied = true;
    return report;
  }
  for (const auto& table : tables()) {
    const auto insert = insert_all(table);
    report.tables.push_back(scan(source, table, [&](const Row& row) {
      auto statement = destination.prepare(insert);
      for (std::size_t i = 0; i < row.values.size(); ++i) statement.bind_at(static_cast<int>(i) + 1, row.values[i]);
      statement.run();
    }));
  }
  continue_ids_after_copied_ones(destination);
  require_same(report.tables, destination, "the copy read back differs");
  return report;
}

}  // namespace

Result<CopyReport> copy_database(const Store& from, Store& to) {
  const auto what = fmt::format("copying {} into {}", display_target(from.path()), display_target(to.path()));
  return detail::guarded(what, [&] {
    auto source = from.impl_->engine->reader();
    detail::Transaction snapshot(*source, detail::TransactionKind::read);
    auto destination = to.impl_->engine->writer();
    detail::Transaction transaction(*destination, detail::TransactionKind::write);
    auto report = copy_between(*source, *destination);
    from.impl_->engine->after_read();  // a SQLite file read as immutable must not have changed meanwhile
    if (!report.already_copied) transaction.commit();  // else rolled back: nothing was written
    snapshot.commit();
    return report;
  });
}

}  // namespace skinspec::store
