#pragma once
// Copying a whole skinspec database into another of either engine (skinspec migrate-db): every
// record with its id, in one transaction that is committed only once what the destination then
// holds has been read back and found equal to the source, table by table.

#include <cstdint>
#include <string>
#include <vector>

#include "skinspec/store/store.hpp"

namespace skinspec::store {

struct TableCopy {
  std::string table;
  std::int64_t rows = 0;
  // 16 hex digits (FNV-1a, 64 bits) over every value of every row in key order (the id, or a
  // map's id and the piece or ordinal), as typed values: equal on two databases, of whichever
  // engines, exactly when they hold the same rows.
  std::string digest;
};

struct CopyReport {
  std::vector<TableCopy> tables;  // in the order copied: each table after those it refers to
  bool already_copied = false;    // the destination held exactly these rows: nothing was written
};

// Copies everything `from` holds into `to`. `to` must hold no records, or exactly those of
// `from` (a copy run again: already_copied, nothing written); other records are refused as
// `conflict`. `from` is read in one snapshot (it may be served meanwhile); `to` gets all of it
// or nothing.
Result<CopyReport> copy_database(const Store& from, Store& to);

}  // namespace skinspec::store
