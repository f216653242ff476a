#pragma once
// PostgreSQL's binary format for the types the store uses: the type ids (pg_type), integers
// and doubles big-endian, booleans as one byte, timestamptz as microseconds since 2000-01-01,
// text, json and bytea as their bytes.

#include <cstdint>
#include <string>
#include <string_view>

#include "skinspec/store/types.hpp"

namespace skinspec::store::postgresql {

enum class TypeId : unsigned {
  boolean = 16,
  bytea = 17,
  name = 19,
  int8 = 20,
  int2 = 21,
  int4 = 23,
  text = 25,
  oid = 26,
  json = 114,
  float4 = 700,
  float8 = 701,
  unknown = 705,
  bpchar = 1042,
  varchar = 1043,
  timestamp = 1114,
  timestamptz = 1184,
};

// Types whose binary form is their text's bytes.
bool is_textual(TypeId type);

void put_integer(std::string& out, std::int64_t value, std::size_t bytes);  // 2, 4 or 8 bytes
void put_double(std::string& out, double value);
void put_time(std::string& out, Time time);

// Each reads the whole of `bytes`, which must be of the type's size (else throws `corrupt`).
std::int64_t get_integer(std::string_view bytes);  // 1 (boolean), 2, 4 or 8 bytes, signed
double get_double(std::string_view bytes);         // 4 or 8 bytes
Time get_time(std::string_view bytes);

}  // namespace skinspec::store::postgresql
