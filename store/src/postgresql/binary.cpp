#include "postgresql/binary.hpp"

#include <fmt/format.h>

#include <bit>

#include "db.hpp"

namespace skinspec::store::postgresql {

namespace {

// PostgreSQL's epoch, 2000-01-01T00:00:00Z, in microseconds after the Unix epoch.
constexpr std::int64_t kEpochOffsetMicros = 946'684'800'000'000;

std::uint64_t get_unsigned(std::string_view bytes) {
  std::uint64_t value = 0;
  for (const char c : bytes) value = (value << 8) | static_cast<unsigned char>(c);
  return value;
}

[[noreturn]] void wrong_size(std::string_view type, std::size_t size) {
  detail::fail(StoreError::Kind::corrupt, fmt::format("a {} value of {} bytes", type, size));
}

}  // namespace

bool is_textual(TypeId type) {
  switch (type) {
    case TypeId::text:
    case TypeId::varchar:
    case TypeId::bpchar:
    case TypeId::name:
    case TypeId::json:
    case TypeId::unknown:
      return true;
    default:
      return false;
  }
}

void put_integer(std::string& out, std::int64_t value, std::size_t bytes) {
  const auto bits = static_cast<std::uint64_t>(value);
  for (std::size_t i = bytes; i-- > 0;) out.push_back(static_cast<char>((bits >> (8 * i)) & 0xff));
}

void put_double(std::string& out, double value) {
  put_integer(out, static_cast<std::int64_t>(std::bit_cast<std::uint64_t>(value)), 8);
}

void put_time(std::string& out, Time time) {
  put_integer(out, time.time_since_epoch().count() - kEpochOffsetMicros, 8);
}

std::int64_t get_integer(std::string_view bytes) {
  switch (bytes.size()) {
    case 1:
      return static_cast<std::int64_t>(static_cast<unsigned char>(bytes[0]));
    case 2:
      return static_cast<std::int16_t>(get_unsigned(bytes));
    case 4:
      return static_cast<std::int32_t>(get_unsigned(bytes));
    case 8:
      return static_cast<std::int64_t>(get_unsigned(bytes));
    default:
      wrong_size("integer", bytes.size());
  }
}

double get_double(std::string_view bytes) {
  if (bytes.size() == 8) return std::bit_cast<double>(get_unsigned(bytes));
  if (bytes.size() == 4)
    return static_cast<double>(std::bit_cast<float>(static_cast<std::uint32_t>(get_unsigned(bytes))));
  wrong_size("floating-point", bytes.size());
}

Time get_time(std::string_view bytes) {
  if (bytes.size() != 8) wrong_size("timestamp", bytes.size());
  return Time(std::chrono::microseconds(static_cast<std::int64_t>(get_unsigned(bytes)) + kEpochOffsetMicros));
}

}  // namespace skinspec::store::postgresql
