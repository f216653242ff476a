#pragma once
// What faults do to the bytes of a reply (private to simulator/). Pure functions of the reply
// and a seeded random generator, so that a fault always does the same thing to the same reply.

#include <random>
#include <string>
#include <string_view>

#include "skinspec/drivers/pr650_protocol.hpp"

namespace skinspec::simulator::detail {

// The reply with its leading "qq," code replaced (reports and the F reply); others unchanged.
std::string with_quality(std::string reply, int code);
// Every value's exponent letter (the E of "5.882E-05") set to `letter`.
std::string with_exponent(std::string reply, char letter);
// A spectral report's header laid out as H1 ("qq,U\r<value>\r\n") or H2 (two lines).
std::string with_header(std::string reply, drivers::pr650::HeaderVariant variant);
// A spectral report cut to, or extended (784, 788, ... nm repeating the last value) to, `lines` data lines.
std::string with_line_count(std::string reply, int lines);
// Without its `line`th line (1-based, counting LF-ended lines); 0: a random data line of a
// spectral report, else the only line.
std::string without_line(std::string reply, int line, std::mt19937_64& rng);
// With `count` bytes of line noise (never CR or LF, never digits) inserted before the last line end.
std::string with_garbage(std::string reply, int count, std::mt19937_64& rng);
// With `count` single-bit errors at random places.
std::string with_bitflips(std::string reply, int count, std::mt19937_64& rng);

// True when the reply holds the data lines of a spectral report.
bool is_spectral(std::string_view reply);

}  // namespace skinspec::simulator::detail
