#pragma once
// Runs fn(i) for i in [0, n) on up to `threads` threads (0 = one per core); each index once.

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <thread>
#include <utility>
#include <vector>

namespace skinspec {

namespace detail {

// Calls fn(i) for the indices it takes from `next` until none is left below n.
template <typename Fn>
void take_indices(std::atomic<std::size_t>& next, std::size_t n, Fn& fn) {
  for (std::size_t i; (i = next.fetch_add(1)) < n;) fn(i);
}

// Lowers the calling thread's scheduling priority by `steps` of nice(2), if it may.
void lower_this_threads_priority(int steps);

inline unsigned thread_count(unsigned threads) {
  return threads != 0 ? threads : std::max(1u, std::thread::hardware_concurrency());
}

}  // namespace detail

// The calling thread among them.
template <typename Fn>
void parallel_for(std::size_t n, unsigned threads, Fn&& fn) {
  std::atomic<std::size_t> next{0};
  const auto worker = [&] { detail::take_indices(next, n, fn); };
  std::vector<std::jthread> helpers;
  for (std::size_t t = 1; t < std::min<std::size_t>(detail::thread_count(threads), n); ++t)
    helpers.emplace_back(worker);
  worker();
}

// How far below the rest of the program bulk work runs, in nice(2) steps (of 40).
inline constexpr int kBackgroundNiceness = 10;

// As parallel_for, but on threads of their own whose scheduling priority is kBackgroundNiceness
// lower than the caller's, for bulk work (an import's or a refit's fits) beside work that must
// not wait for it: storing the batch fitted before, answering requests. On Linux a thread's
// niceness is its own, and one lowered cannot be raised again without privilege: so the caller
// keeps its own, and runs `meanwhile()` while the threads work. Lowering is a preference: where
// it is refused, the work runs as it is.
template <typename Fn, typename Meanwhile>
void parallel_for_in_background(std::size_t n, unsigned threads, Fn&& fn, Meanwhile&& meanwhile) {
  std::atomic<std::size_t> next{0};
  const auto worker = [&] {
    detail::lower_this_threads_priority(kBackgroundNiceness);
    detail::take_indices(next, n, fn);
  };
  std::vector<std::jthread> workers;
  for (std::size_t t = 0; t < std::min<std::size_t>(detail::thread_count(threads), n); ++t)
    workers.emplace_back(worker);
  meanwhile();
}

template <typename Fn>
void parallel_for_in_background(std::size_t n, unsigned threads, Fn&& fn) {
  parallel_for_in_background(n, threads, std::forward<Fn>(fn), [] {});
}

}  // namespace skinspec
