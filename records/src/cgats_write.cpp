// Writing CGATS (cgats.hpp): a session's reflectances as CTI3 tables.

#include "skinspec/records/cgats.hpp"

#include <fmt/format.h>

#include <cmath>
#include <ostream>

#include "skinspec/records/record_json.hpp"

namespace skinspec::records {

namespace {

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
      << "# SPEC_nnn: reflectance at nnn nm in percent (over SPECTRAL_NORM: as a fraction)\n"
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

std::expected<void, std::string> write_cgats(const store::SessionDetail& detail, std::ostream& out) {
  // Tables in the order their grids first appear; sets in the order stored.
  std::vector<std::pair<std::vector<double>, std::vector<const store::Measurement*>>> tables;
  for (const auto& m : detail.measurements) {
    if (m.reflectance.empty()) continue;
    auto same = std::ranges::find(tables, m.reflectance.wavelength_nm, [](const auto& t) { return t.first; });
    if (same == tables.end()) same = tables.insert(tables.end(), {m.reflectance.wavelength_nm, {}});
    same->second.push_back(&m);
  }
  if (tables.empty())
    return std::unexpected(
        fmt::format("session {} holds no reflectance spectrum to write as CGATS", detail.session.id));
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
