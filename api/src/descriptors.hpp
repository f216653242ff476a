#pragma once
// File descriptors: how many connections the process can afford, and one kept spare so that a
// connection can still be refused politely when the process has none left.

#include <cstddef>

namespace skinspec::api::detail {

// RLIMIT_NOFILE's soft limit (SIZE_MAX when unlimited), and how many descriptors are open now.
std::size_t descriptor_limit();
std::size_t open_descriptors();

// The connections the server can hold: `requested`, but no more than the descriptor limit
// leaves once the descriptors open now and `reserve` (database readers, logs, the instrument,
// streams) are set aside; at least 1.
std::size_t connection_cap(std::size_t requested, std::size_t limit, std::size_t open_now, std::size_t reserve);

// A descriptor held open on /dev/null. When accept() fails for want of descriptors, giving it
// up lets one pending connection be accepted, answered 503 and closed; then it is taken again.
class SpareDescriptor {
 public:
  SpareDescriptor();
  ~SpareDescriptor();
  SpareDescriptor(const SpareDescriptor&) = delete;
  SpareDescriptor& operator=(const SpareDescriptor&) = delete;

  // Closes it; false when it was not held.
  bool release();
  // Opens it again if it is not held; false when that failed.
  bool restore();

 private:
  int fd_ = -1;
};

}  // namespace skinspec::api::detail
