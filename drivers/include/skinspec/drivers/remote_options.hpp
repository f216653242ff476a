#pragma once
// How a driver of the newer meters (PR-655 and later) paces its commands and how long it waits
// for each reply. The defaults follow docs/pr6xx-protocol.md; tests shorten them.

#include <chrono>
#include <optional>

#include "skinspec/drivers/pr6xx_protocol.hpp"

namespace skinspec::drivers {

struct RemoteTiming {
  using ms = std::chrono::milliseconds;
  ms banner{3000};                // PHOTO to the first byte of " REMOTE MODE"
  ms confirm{7000};               // a silent PHOTO: the D111 that tells whether the banner was glued to it
  ms quit_pause{500};             // after the Q that precedes PHOTO, for a meter that was left remote
  ms retry_pause{1000};           // after the Q that precedes the second PHOTO
  ms reply{2000};                 // setups and reports
  ms flicker{10000};              // F
  ms measurement_overhead{5000};  // beyond the exposures of a measurement
  ms idle{250};                   // the longest pause inside a reply
  ms poll_interval{500};          // between the P polls of a PR-7xx measurement
  // A command a stop or cancel cut short is sent whole, then its reply waited for this long at
  // most before anything else goes out (docs/meters.md, "Q alone").
  ms settle{500};
  double line_bytes_per_second = 960;  // 9600 baud: the cap on a whole reply grows with its size
};

struct RemoteOptions {
  std::optional<std::chrono::milliseconds> pacing;  // between the bytes of a command; nullopt: the profile's
  pr6xx::CommandStyle style;                        // CR after each command but PHOTO and Q
  std::chrono::milliseconds modem_settle{500};      // after raising DTR/RTS
  RemoteTiming timing;
};

}  // namespace skinspec::drivers
