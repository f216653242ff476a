#pragma once
// How identification tells the meter families apart by their answers (docs/pr6xx-protocol.md,
// "Identification"). The PR-650's contact command (b3) and the newer meters' PHOTO both reach
// a meter of the other family, which answers in its own way or not at all. Pure functions of
// the received bytes.

#include <string_view>

namespace skinspec::drivers::identification {

// The answer to b3, its echo removed.
enum class ContactAnswer {
  pr650,        // "000", "00" or "0"
  newer_meter,  // one already in remote mode: "Backlight set to 3 %", a 4- or 5-digit status, a negative code
  other,        // no Photo Research meter answers so (or line noise)
};
ContactAnswer classify_contact(std::string_view reply);

// What came after PHOTO, or in reply to the D111 sent when PHOTO met silence.
enum class PhotoAnswer {
  silence,
  banner,       // " REMOTE MODE", with or without a line end, alone or before a reply
  newer_meter,  // a reply of the "00000,..." form or a newer meter's status: the banner was lost or glued
  pr650,        // an echo of the command, a '>' prompt or a PR-650 status: a PR-650 in echo mode
  other,
};
PhotoAnswer classify_photo(std::string_view received);

}  // namespace skinspec::drivers::identification
