#pragma once
// What every reply parser of every meter family returns for bytes the meter cannot have sent.
// A meter's own error codes (a negative status, a quality code) are not ProtocolErrors: they
// are valid replies, and the driver decides what they mean.

#include <cstddef>
#include <string>
#include <string_view>

namespace skinspec::drivers {

struct ProtocolError {
  enum class Kind {
    truncated,         // the reply stopped before it was complete
    garbled,           // bytes that cannot be what the meter sends
    surplus,           // more than the reply should hold
    wrong_count,       // a spectral report without exactly the expected number of data lines
    wrong_wavelength,  // a data line for an unexpected wavelength
    wrong_grid,        // a regular spectral report on a grid other than the one expected
  };
  Kind kind;
  std::string message;
  std::size_t line = 0;  // 1-based line of the reply at fault, 0 when the whole reply is
};

// "truncated", "garbled", ...: the kind's name, for logs and test messages.
std::string_view to_string(ProtocolError::Kind kind);

}  // namespace skinspec::drivers
