#include "skinspec/drivers/instrument.hpp"

#include <fmt/format.h>

namespace skinspec::drivers {

InstrumentError another_meter_answers(std::string_view serial_now, std::string_view serial_before) {
  return {InstrumentError::Kind::lost,
          fmt::format("another meter answers: serial number {}, was {}", serial_now, serial_before),
          -1,
          {}};
}

std::string_view to_string(InstrumentError::Kind kind) {
  switch (kind) {
    case InstrumentError::Kind::no_contact:
      return "no_contact";
    case InstrumentError::Kind::lost:
      return "lost";
    case InstrumentError::Kind::protocol:
      return "protocol";
    case InstrumentError::Kind::bad_reading:
      return "bad_reading";
    case InstrumentError::Kind::rejected:
      return "rejected";
    case InstrumentError::Kind::cancelled:
      return "cancelled";
    case InstrumentError::Kind::transport:
      return "transport";
    case InstrumentError::Kind::identification:
      return "identification";
  }
  return "unknown";
}

}  // namespace skinspec::drivers
