#include "skinspec/drivers/protocol_error.hpp"

namespace skinspec::drivers {

std::string_view to_string(ProtocolError::Kind kind) {
  switch (kind) {
    case ProtocolError::Kind::truncated:
      return "truncated";
    case ProtocolError::Kind::garbled:
      return "garbled";
    case ProtocolError::Kind::surplus:
      return "surplus";
    case ProtocolError::Kind::wrong_count:
      return "wrong_count";
    case ProtocolError::Kind::wrong_wavelength:
      return "wrong_wavelength";
    case ProtocolError::Kind::wrong_grid:
      return "wrong_grid";
  }
  return "unknown";
}

}  // namespace skinspec::drivers
