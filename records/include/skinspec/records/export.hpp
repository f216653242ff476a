#pragma once
// Sessions written out for people and other programs: what `skinspec export` prints and the
// service's export routes send. Both formats are described in docs/store.md ("Export"); the
// records in the JSON are those of record_json.hpp, as the service shows them.

#include <iosfwd>

#include "skinspec/store/store.hpp"

namespace skinspec::records {

enum class ExportFormat { csv, json, cgats };

// The CSV header line (with its line end).
void write_csv_header(std::ostream& out);

// One session: CSV rows (one per wavelength of each measurement and each of its fits) without
// the header, one JSON object on one line (the session, its white standard, instruments,
// measurements with their spectra and fits), or its reflectance spectra as CGATS tables
// (cgats.hpp; invalid_argument for a grid CGATS cannot name). not_found for an unknown session.
store::Result<void> export_session(const store::Store& store, store::Id session_id, ExportFormat format,
                                   std::ostream& out);

// Every session, oldest first: the CSV header and all rows, one JSON line per session, or each
// session's CGATS tables.
store::Result<void> export_all(const store::Store& store, ExportFormat format, std::ostream& out);

// The audit trail (store/audit.hpp), oldest first: one JSON line per entry (record_json.hpp's
// fields) or CSV with a header line and the same columns. invalid_argument for CGATS.
store::Result<void> export_audit(const store::Store& store, ExportFormat format, std::ostream& out);

}  // namespace skinspec::records
