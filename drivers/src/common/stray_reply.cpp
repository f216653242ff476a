#include "skinspec/drivers/stray_reply.hpp"

#include <algorithm>

namespace skinspec::drivers {

void StrayReply::expect(Deadline start_by, Deadline end_by) {
  // Two cut exchanges in a row: the line is quiet only when both are over.
  if (expected_) {
    start_by = std::max(start_by, expected_->start_by);
    end_by = std::max(end_by, expected_->end_by);
  }
  expected_ = Window{start_by, std::max(start_by, end_by)};
}

bool StrayReply::drop(Transport& transport, std::chrono::milliseconds idle) {
  if (!expected_) return true;
  char buffer[512];
  const Deadline end = expected_->end_by;
  Deadline next = std::max(expected_->start_by, deadline_in(idle));
  for (;;) {
    auto n = transport.read(buffer, sizeof buffer, std::min(next, end));
    if (!n) {
      if (n.error().kind == TransportError::Kind::interrupted) return false;
      break;  // silence: the reply is over; a broken link is the next command's to report
    }
    next = deadline_in(idle);
  }
  expected_.reset();
  return true;
}

}  // namespace skinspec::drivers
