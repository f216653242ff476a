#include "descriptors.hpp"

#include <fcntl.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <system_error>

namespace skinspec::api::detail {

std::size_t descriptor_limit() {
  rlimit limit{};
  if (::getrlimit(RLIMIT_NOFILE, &limit) != 0 || limit.rlim_cur == RLIM_INFINITY) return SIZE_MAX;
  return static_cast<std::size_t>(limit.rlim_cur);
}

std::size_t open_descriptors() {
  std::error_code ec;
  std::size_t n = 0;
  for (std::filesystem::directory_iterator it("/proc/self/fd", ec), end; !ec && it != end; it.increment(ec)) ++n;
  return n > 0 ? n - 1 : 0;  // less the one the listing itself holds
}

std::size_t connection_cap(std::size_t requested, std::size_t limit, std::size_t open_now, std::size_t reserve) {
  const std::size_t set_aside = open_now + reserve;
  const std::size_t affordable = limit > set_aside ? limit - set_aside : 0;
  return std::max<std::size_t>(1, std::min(requested, affordable));
}

SpareDescriptor::SpareDescriptor() { restore(); }

SpareDescriptor::~SpareDescriptor() { release(); }

bool SpareDescriptor::release() {
  if (fd_ < 0) return false;
  ::close(fd_);
  fd_ = -1;
  return true;
}

bool SpareDescriptor::restore() {
  if (fd_ < 0) fd_ = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
  return fd_ >= 0;
}

}  // namespace skinspec::api::detail
