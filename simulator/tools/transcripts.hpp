#pragma once
// The example transcripts of the PR-650 protocol reference (its section 6, "Transcript A" to
// "Transcript D") read into recordings: TX/RX lines with C-escaped strings, timing notes in
// brackets, and the abbreviations "… 101 lines …" and "(same as transcript A's D5 reply)"
// filled in from transcript A.

#include <expected>
#include <map>
#include <string>
#include <string_view>

#include "skinspec/simulator/recording.hpp"

namespace skinspec::simulator::tools {

// Keyed by the transcript's letter. `source` names the reference in the headers.
std::expected<std::map<char, Recording>, std::string> transcripts_from_reference(std::string_view markdown,
                                                                                 std::string_view source);

}  // namespace skinspec::simulator::tools
