#include "skinspec/spectral/parallel.hpp"

#include <sys/resource.h>
#include <unistd.h>

namespace skinspec::detail {

// On Linux, PRIO_PROCESS with a thread's id changes that thread alone.
void lower_this_threads_priority(int steps) {
  const auto self = static_cast<id_t>(::gettid());
  (void)::setpriority(PRIO_PROCESS, self, ::getpriority(PRIO_PROCESS, self) + steps);
}

}  // namespace skinspec::detail
