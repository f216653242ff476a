#pragma once
// Which family answers on a link (private to drivers/; docs/pr6xx-protocol.md,
// "Identification"): the PR-650's b3 inside its power-on window; then the newer meters' Q and
// PHOTO, with D111 (and D120 where D111 names several models) to choose the model; then the
// PR-650 again, for one switched on meanwhile. The driver of the family found takes the link
// over as it is, without a second contact.

#include <cstdint>
#include <expected>
#include <memory>
#include <mutex>

#include "common/remote_session.hpp"
#include "skinspec/drivers/open_instrument.hpp"

namespace skinspec::drivers::identify {

struct Found {
  std::unique_ptr<Instrument> driver;  // connected, on a BorrowedTransport of the probe's link
  bool model_unresolved = false;       // D111 named several models and D120's grid fits none of them
};

class Probe {
 public:
  // The link must stay alive as long as the driver found.
  Probe(Transport& link, const InstrumentOptions& options);
  ~Probe();
  Probe(const Probe&) = delete;
  Probe& operator=(const Probe&) = delete;

  std::expected<Found, InstrumentError> run();
  // Ends run() with `cancelled`. Any thread.
  void cancel();
  // Replies the probe's own commands received (not those of the driver it found).
  std::uint64_t replies() const;

 private:
  struct Choice {
    Model model;
    bool unresolved = false;
  };
  std::expected<Found, InstrumentError> find_newer_meter();
  std::expected<Choice, InstrumentError> choose_model(remote::Session& session);
  std::expected<Found, InstrumentError> take_pr650();
  bool cancelled() const;
  InstrumentError silent_everywhere() const;

  Transport& link_;
  InstrumentOptions options_;
  mutable std::mutex mutex_;  // the step objects, for cancel() and replies() from other threads
  bool cancelled_ = false;
  std::unique_ptr<Pr650> pr650_;
  std::unique_ptr<remote::Session> session_;
};

}  // namespace skinspec::drivers::identify
