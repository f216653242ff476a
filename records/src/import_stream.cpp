// Imports streamed (import.hpp, SpectrumStream): the file's bytes a piece of whole rows at a time,
// and a CSV file of one row per spectrum checked in one pass and handed over in a second.

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fmt/format.h>
#include <string>
#include <vector>

#include "import_csv.hpp"
#include "skinspec/records/import.hpp"
#include "skinspec/spectral/csv.hpp"
#include "skinspec/spectral/utf8.hpp"

namespace skinspec::records {

namespace {

// What a piece holds at least, but for the file's last: a few thousand rows of a spectrum each.
constexpr std::size_t kPieceBytes = 4 << 20;

// Where a run of whole rows ends in `text`: after its last line end outside quotes (RFC 4180:
// a quote opens or closes a quoted field, and a doubled one inside leaves it open), or 0.
std::size_t whole_rows(std::string_view text) {
  bool quoted = false;
  std::size_t end = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '"') quoted = !quoted;
    else if (text[i] == '\n' && !quoted) end = i + 1;
  }
  return end;
}

std::size_t lines_in(std::string_view text) { return static_cast<std::size_t>(std::ranges::count(text, '\n')); }

// A file's bytes as runs of whole rows, each at least kPieceBytes long but the last, checked to
// be UTF-8 without NUL as read_import checks the whole file.
class Pieces {
 public:
  Pieces(const ReadBytes& read, std::string_view source) : read_(read), source_(source) {}

  // The next run (empty at the end), valid until the next call; line() is where it starts.
  std::expected<std::string_view, InputError> next() {
    buffer_.erase(0, taken_);
    taken_ = 0;
    line_ = next_line_;
    for (std::size_t end = 0;;) {
      if (!ended_ && (buffer_.size() < kPieceBytes || end == 0)) {
        if (auto read = fill(); !read) return std::unexpected(read.error());
      }
      end = ended_ ? buffer_.size() : whole_rows(buffer_);
      if (end > 0 || ended_) break;
    }
    const std::string_view piece = std::string_view(buffer_).substr(0, ended_ ? buffer_.size() : whole_rows(buffer_));
    const auto defect = utf8::first_defect(piece);
    const auto nul = piece.find('\0');
    if (defect || nul != std::string_view::npos) {
      const auto at = std::min(defect ? defect->offset : piece.size(), nul);
      return std::unexpected(
          InputError{source_, line_ + lines_in(piece.substr(0, at)), 0, "not UTF-8 text: save the file as UTF-8"});
    }
    taken_ = piece.size();
    next_line_ = line_ + lines_in(piece);
    return piece;
  }

  std::size_t line() const { return line_; }

 private:
  std::expected<void, InputError> fill() {
    const std::size_t had = buffer_.size();
    buffer_.resize(had + kPieceBytes);
    const auto read = read_(offset_, std::span<char>(buffer_.data() + had, kPieceBytes));
    if (!read) return std::unexpected(InputError{source_, 0, 0, "cannot be read: " + read.error()});
    buffer_.resize(had + *read);
    // Spreadsheet programs put a byte order mark in front.
    if (offset_ == 0 && std::string_view(buffer_).starts_with("\xEF\xBB\xBF")) buffer_.erase(0, 3);
    offset_ += *read;
    ended_ = *read < kPieceBytes;
    return {};
  }

  const ReadBytes& read_;
  std::string source_;
  std::string buffer_;
  std::size_t taken_ = 0;  // of buffer_, handed over by the last next()
  std::uint64_t offset_ = 0;
  bool ended_ = false;
  std::size_t line_ = 1, next_line_ = 1;
};

// A CSV file's rows, their cells trimmed; lines starting with '#' before the first row (the
// header) are skipped, as read_import skips them.
class CsvRows {
 public:
  CsvRows(const ReadBytes& read, std::string_view source) : pieces_(read, source), source_(source) {}

  // The next row's line and cells (valid until the next call), or 0 at the end.
  std::expected<std::size_t, InputError> next(std::vector<std::string_view>& cells) {
    for (;;) {
      if (!reader_ || !reader_->peek()) {
        reader_.reset();
        auto piece = pieces_.next();
        if (!piece) return std::unexpected(piece.error());
        if (piece->empty()) return 0;
        reader_ = std::make_unique<csv::Reader>(*piece);
        continue;
      }
      if (first_ && detail::trimmed(reader_->peek()->text).starts_with('#')) {
        reader_->skip_line();
        continue;
      }
      auto read = reader_->read_row();
      if (!read)
        return std::unexpected(InputError{source_, pieces_.line() + read.error().line - 1, 0, read.error().message});
      first_ = false;
      cells.clear();
      for (const auto& cell : read->cells) cells.push_back(detail::trimmed(cell.text));
      return pieces_.line() + read->line - 1;
    }
  }

 private:
  Pieces pieces_;
  std::string source_;
  std::unique_ptr<csv::Reader> reader_;
  bool first_ = true;
};

// A file read whole (read_import), its spectra handed over and let go one by one.
class HeldSpectra : public SpectrumStream {
 public:
  explicit HeldSpectra(std::vector<ImportedSpectrum> spectra) : spectra_(std::move(spectra)) {}
  std::size_t size() const override { return spectra_.size(); }
  std::optional<ReflectanceScale> scale() const override { return spectra_.front().scale; }
  std::expected<std::optional<ImportedSpectrum>, InputError> next() override {
    if (given_ == spectra_.size()) return std::nullopt;
    return std::move(spectra_[given_++]);
  }

 private:
  std::vector<ImportedSpectrum> spectra_;
  std::size_t given_ = 0;
};

// The first value out of range were the values divided by `divisor`.
struct Stray {
  std::size_t line = 0, column = 0;
  double value = 0;
};

// A CSV file of one row per spectrum: checked whole by open(), then handed over by next().
class RowSpectra : public SpectrumStream {
 public:
  RowSpectra(ReadBytes read, std::string_view source, ScaleRequest scale)
      : read_(std::move(read)), source_(source), request_(scale), rows_(std::make_unique<CsvRows>(read_, source_)) {}

  // Reads the header; false when it is not one of one row per spectrum (so the file is read whole).
  std::expected<bool, InputError> read_header() {
    std::vector<std::string_view> cells;
    auto line = rows_->next(cells);
    if (!line) return std::unexpected(line.error());
    if (*line == 0) return fail(0, 0, "no header and data rows");
    header_line_ = *line;
    if (detail::names_wavelengths(std::string(cells[0]))) return false;
    auto columns = detail::wavelength_columns(cells);
    if (!columns) return fail(*line, columns.error().column, columns.error().message);
    columns_ = std::move(*columns);
    width_ = cells.size();
    return true;
  }

  // The rest of the file checked, as read_import checks it.
  std::expected<void, InputError> check() {
    ScaleTally tally;
    std::optional<Stray> stray[2];                             // as fractions, in percent
    std::optional<std::pair<std::size_t, std::string>> below;  // the first spectrum at or below 1.5
    std::vector<std::string_view> cells;
    std::vector<double> values;
    for (;;) {
      auto line = rows_->next(cells);
      if (!line) return std::unexpected(line.error());
      if (*line == 0) break;
      ++count_;
      if (auto read = values_of(*line, cells, values); !read) return std::unexpected(read.error());
      if (tally.add(values) && !below) below.emplace(*line, sample_id(cells, count_));
      for (int s = 0; s < 2; ++s) {
        const double divisor = s == 0 ? 1.0 : 100.0;
        for (std::size_t k = 0; k < values.size() && !stray[s]; ++k)
          if (!detail::is_reflectance(values[k] / divisor)) stray[s] = Stray{*line, columns_.first + k + 1, values[k]};
      }
    }
    if (count_ == 0) return fail(header_line_, 0, "no header and data rows");
    const auto decided = tally.decide(request_);
    if (!decided) return fail(below->first, 0, describe_conflict(below->second));
    scale_ = *decided;
    if (const auto& s = stray[scale_.scale == ReflectanceScale::percent ? 1 : 0])
      return fail(s->line, s->column, detail::not_a_reflectance(s->value, scale_));
    rows_ = std::make_unique<CsvRows>(read_, source_);  // handed over from the start again
    return {};
  }

  std::size_t size() const override { return count_; }
  std::optional<ReflectanceScale> scale() const override { return scale_.scale; }

  std::expected<std::optional<ImportedSpectrum>, InputError> next() override {
    if (given_ == count_) return std::nullopt;
    std::vector<std::string_view> cells;
    if (!header_passed_) {
      auto header = rows_->next(cells);
      if (!header) return std::unexpected(header.error());
      header_passed_ = true;
    }
    auto line = rows_->next(cells);
    if (!line) return std::unexpected(line.error());
    if (*line == 0) return fail(0, 0, "the file changed while it was imported");
    ++given_;
    ImportedSpectrum spectrum;
    if (auto read = values_of(*line, cells, spectrum.reflectance.values); !read) return std::unexpected(read.error());
    spectrum.sample_id = sample_id(cells, given_);
    spectrum.line = *line;
    spectrum.scale = scale_.scale;
    spectrum.reflectance.wavelength_nm = columns_.grid;
    const double divisor = scale_.divisor();
    for (auto& value : spectrum.reflectance.values) {
      value /= divisor;
      if (!detail::is_reflectance(value)) return fail(*line, 0, "the file changed while it was imported");
    }
    return spectrum;
  }

 private:
  std::unexpected<InputError> fail(std::size_t line, std::size_t column, std::string message) const {
    return std::unexpected(InputError{source_, line, column, std::move(message)});
  }

  // The sample id of data row `number` (from 1): its first text column, or that number.
  std::string sample_id(const std::vector<std::string_view>& cells, std::size_t number) const {
    return columns_.first > 0 && !cells[0].empty() ? std::string(cells[0]) : std::to_string(number);
  }

  std::expected<void, InputError> values_of(std::size_t line, const std::vector<std::string_view>& cells,
                                            std::vector<double>& values) const {
    if (cells.size() != width_)
      return fail(line, 0, fmt::format("{} fields where the header has {}", cells.size(), width_));
    values.clear();
    for (std::size_t c = columns_.first; c < cells.size(); ++c) {
      const auto value = detail::finite_number(cells[c]);
      if (!value) return fail(line, c + 1, fmt::format("'{}' is not a number", cells[c]));
      values.push_back(*value);
    }
    return {};
  }

  ReadBytes read_;
  std::string source_;
  ScaleRequest request_;
  std::unique_ptr<CsvRows> rows_;
  std::size_t header_line_ = 0, width_ = 0;
  detail::WavelengthColumns columns_;
  ScaleDecision scale_;
  std::size_t count_ = 0, given_ = 0;
  bool header_passed_ = false;
};

// The whole file in memory, for the layouts read whole.
std::expected<std::string, InputError> whole(const ReadBytes& read, std::string_view source) {
  std::string bytes;
  for (;;) {
    const std::size_t had = bytes.size();
    bytes.resize(had + kPieceBytes);
    const auto got = read(had, std::span<char>(bytes.data() + had, kPieceBytes));
    if (!got) return std::unexpected(InputError{std::string(source), 0, 0, "cannot be read: " + got.error()});
    bytes.resize(had + *got);
    if (*got < kPieceBytes) return bytes;
  }
}

}  // namespace

ReadBytes bytes_in_memory(std::string_view bytes) {
  return [bytes](std::uint64_t offset, std::span<char> into) -> std::expected<std::size_t, std::string> {
    if (offset >= bytes.size()) return 0;
    const auto part = bytes.substr(static_cast<std::size_t>(offset), into.size());
    std::ranges::copy(part, into.begin());
    return part.size();
  };
}

std::expected<ReadBytes, std::string> bytes_of_file(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return std::unexpected(std::string(std::strerror(errno)));
  const auto file = std::shared_ptr<int>(new int(fd), [](const int* f) {
    ::close(*f);
    delete f;
  });
  return [file](std::uint64_t offset, std::span<char> into) -> std::expected<std::size_t, std::string> {
    std::size_t done = 0;
    while (done < into.size()) {
      const auto got = ::pread(*file, into.data() + done, into.size() - done, static_cast<off_t>(offset + done));
      if (got < 0 && errno == EINTR) continue;
      if (got < 0) return std::unexpected(std::string(std::strerror(errno)));
      if (got == 0) break;
      done += static_cast<std::size_t>(got);
    }
    return done;
  };
}

std::expected<std::unique_ptr<SpectrumStream>, InputError> stream_import(const ReadBytes& bytes,
                                                                         std::string_view source, ImportFormat format,
                                                                         ScaleRequest scale) {
  if (format == ImportFormat::csv) {
    auto rows = std::make_unique<RowSpectra>(bytes, source, scale);
    const auto by_rows = rows->read_header();
    if (!by_rows) return std::unexpected(by_rows.error());
    if (*by_rows) {
      if (auto checked = rows->check(); !checked) return std::unexpected(checked.error());
      return rows;
    }
  }
  const auto text = whole(bytes, source);
  if (!text) return std::unexpected(text.error());
  auto spectra = read_import(*text, source, format, scale);
  if (!spectra) return std::unexpected(spectra.error());
  return std::make_unique<HeldSpectra>(std::move(*spectra));
}

}  // namespace skinspec::records
