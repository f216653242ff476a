#pragma once
// The reply to an exchange that a cancel cut short. The meter sends it whole whatever the host
// does: the rest of a spectrum already streaming, or the whole reply to a command that went out
// but was not waited for. Left on the line, the next command would read it as its own reply (a
// job after a cancelled one failing `protocol` on "82E-04", its setup's reply). So the driver
// notes it here and reads and drops it before the next command goes out.

#include <chrono>
#include <optional>

#include "skinspec/drivers/transport.hpp"

namespace skinspec::drivers {

class StrayReply {
 public:
  // A reply whose first byte came already (`start_by` in the past) or may still come until
  // `start_by`, and which is over by `end_by` at the latest.
  void expect(Deadline start_by, Deadline end_by);
  // The rest of a reply whose wait was interrupted: started (`whole_by`, its cap, set when its
  // first byte came) or due by `first_byte_by`, then taking at most `whole`.
  void expect_rest(std::optional<Deadline> whole_by, Deadline first_byte_by, std::chrono::milliseconds whole) {
    if (whole_by) expect(Clock::now(), *whole_by);
    else expect(first_byte_by, first_byte_by + whole);
  }
  // Reads and drops the expected reply: until `idle` passes without a byte once it has started,
  // or its end. Returns false when interrupted (a cancel): it is then still expected.
  bool drop(Transport& transport, std::chrono::milliseconds idle);
  void forget() { expected_.reset(); }
  bool expected() const { return expected_.has_value(); }

 private:
  struct Window {
    Deadline start_by;
    Deadline end_by;
  };
  std::optional<Window> expected_;
};

}  // namespace skinspec::drivers
