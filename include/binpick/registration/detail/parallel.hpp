#pragma once
/// \file parallel.hpp
/// The registration module's OpenMP seam: builds and runs without OpenMP. Every parallel call takes a
/// `num_threads` (0 = all cores) passed to its own parallel region; process-wide OpenMP state is never
/// changed. Reductions use one accumulator per thread over a fixed contiguous block of the index range,
/// summed in thread order, so a result depends on the thread count only, never on scheduling.

#include <cstddef>
#include <vector>

#ifdef _OPENMP
#include <omp.h>
#endif

#include "binpick/core/parallel.hpp"

namespace binpick {
namespace registration_detail {

/// Threads to use for a requested count (0 = all cores); 1 without OpenMP. The project-wide rule,
/// kept under this name for the registration headers.
inline int resolve_threads(int requested) { return detail::resolve_num_threads(requested); }

/// Calls f(i) for i in [0, n) on `threads` threads (independent iterations). Ranges of
/// `min_parallel` items or fewer run on the calling thread (lower it when an item is a whole row).
template <typename F>
void parallel_for(std::ptrdiff_t n, int threads, F&& f, std::ptrdiff_t min_parallel = 1024) {
#ifdef _OPENMP
  if (threads > 1 && n > min_parallel) {
#pragma omp parallel for schedule(static) num_threads(threads)
    for (std::ptrdiff_t i = 0; i < n; ++i) f(i);
    return;
  }
#else
  (void)threads;
  (void)min_parallel;
#endif
  for (std::ptrdiff_t i = 0; i < n; ++i) f(i);
}

/// Deterministic reduction: thread t accumulates block [n t / T, n (t+1) / T) into its own copy of
/// `zero` via f(acc, i); the copies are then merged in thread order with merge(total, acc). Ranges of
/// `min_parallel` items or fewer run on the calling thread.
template <typename Acc, typename F, typename Merge>
Acc parallel_reduce(std::ptrdiff_t n, int threads, const Acc& zero, F&& f, Merge&& merge,
                    std::ptrdiff_t min_parallel = 1024) {
#ifdef _OPENMP
  if (threads > 1 && n > min_parallel) {
    std::vector<Acc> parts(std::size_t(threads), zero);
    int used = 1;
#pragma omp parallel num_threads(threads)
    {
      const int t = omp_get_thread_num();
      const int nt = omp_get_num_threads();
#pragma omp single
      used = nt;
      const std::ptrdiff_t begin = n * t / nt, end = n * (t + 1) / nt;
      Acc& acc = parts[std::size_t(t)];
      for (std::ptrdiff_t i = begin; i < end; ++i) f(acc, i);
    }
    Acc total = zero;
    for (int t = 0; t < used; ++t) merge(total, parts[std::size_t(t)]);
    return total;
  }
#else
  (void)threads;
  (void)merge;
  (void)min_parallel;
#endif
  Acc total = zero;
  for (std::ptrdiff_t i = 0; i < n; ++i) f(total, i);
  return total;
}

}  // namespace registration_detail
}  // namespace binpick
