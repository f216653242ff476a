#pragma once
// Recorded meter sessions: the JSON-lines format of docs/recording-format.md, and a Transport
// decorator that records whatever a driver sends and receives through it.
//
//   {"format":"skinspec-meter-recording","version":2,"model":"pr650","captured":"...","by":"...", ...}
//   {"tx":"d5\n","rx":"00,0\r3.019E-01\r\n0380.,...","delay_ms":120,"byte_interval_ms":1.04}
//
// Bytes are kept exactly: every byte of tx and rx is one character U+0000-U+00FF of the JSON
// string, so line noise (bytes 0x80-0xFF, control characters) survives a round trip.

#include <expected>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "skinspec/drivers/meter_profile.hpp"
#include "skinspec/drivers/transport.hpp"
#include "skinspec/simulator/faults.hpp"

namespace skinspec::simulator {

inline constexpr std::string_view kRecordingFormat = "skinspec-meter-recording";
inline constexpr int kRecordingVersion = 2;
// Version 1, still read: PR-650 sessions only.
inline constexpr std::string_view kRecordingFormatV1 = "skinspec-pr650-recording";
// One byte at 9600 baud, 8N1: ten bits.
inline constexpr double kLineByteIntervalMs = 10000.0 / 9600.0;

struct RecordingHeader {
  std::string captured;     // when and how: a date and the capture path, or "synthesized ..."
  std::string by;           // who or what captured it
  std::string description;  // optional
  // Session settings, as far as they are known (descriptive: replay sends the bytes as they are).
  std::optional<double> boot_window_s;
  std::optional<std::string> header_variant;  // "H1" or "H2"
  std::optional<char> exponent;               // 'E' or 'e'
  std::optional<bool> echo;
  drivers::Model model = drivers::Model::pr650;  // "model"; version 1 files are PR-650 sessions
};

struct Exchange {
  std::string tx;                                 // what the host sent; empty: the meter spoke unprompted
  std::string rx;                                 // what the meter sent back; empty: no answer
  double delay_ms = 0;                            // from the end of tx to the first byte of rx
  double byte_interval_ms = kLineByteIntervalMs;  // between the bytes of rx
  std::vector<Fault> faults;                      // applied when replayed
  std::string note;                               // free text
};

struct Recording {
  RecordingHeader header;
  std::vector<Exchange> exchanges;
};

// `source` names the input in errors ("file.jsonl:3: ...").
std::expected<Recording, std::string> parse_recording(std::string_view text, std::string_view source);
// One header line, then one line per exchange; parse_recording(format_recording(r)) == r.
std::string format_recording(const Recording& recording);

struct RecordingOptions {
  // Recorded times are divided by this: for a session run against a simulator running at
  // this time scale, so that the recording holds the meter's real-time behaviour.
  double time_scale = 1;
};

// Passes everything to `inner` and records the traffic as exchanges. A write after the previous
// command is whole (its terminator; on the newer models also PHOTO or Q) starts a new exchange; what is read (and what
// flush_input() discards, which the meter did send) belongs to the current one. Thread-safe.
class RecordingTransport final : public drivers::Transport {
 public:
  RecordingTransport(std::unique_ptr<drivers::Transport> inner, RecordingHeader header, RecordingOptions options = {});

  // A copy of what has been recorded so far.
  Recording recording() const;

  std::expected<void, drivers::TransportError> open() override;
  void close() override;
  bool is_open() const override;
  std::expected<void, drivers::TransportError> flush_input() override;
  std::expected<void, drivers::TransportError> write(std::string_view bytes, drivers::Deadline deadline) override;
  std::expected<std::size_t, drivers::TransportError> read(char* buffer, std::size_t size,
                                                           drivers::Deadline deadline) override;
  std::expected<void, drivers::TransportError> set_modem_lines(bool dtr, bool rts) override;
  bool peer_closed() override;
  void interrupt() override;
  void clear_interrupt() override;
  std::string describe() const override;

 private:
  void received(std::string_view bytes);

  std::unique_ptr<drivers::Transport> inner_;
  RecordingOptions options_;
  mutable std::mutex mutex_;
  Recording recording_;
  struct Timing {
    drivers::Clock::time_point sent, first, last;
    std::size_t bytes = 0, first_chunk = 0;
  };
  std::vector<Timing> timing_;  // per exchange
};

}  // namespace skinspec::simulator
