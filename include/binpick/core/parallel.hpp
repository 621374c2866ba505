#pragma once
/// \file parallel.hpp
/// The OpenMP seam: the library builds and runs without OpenMP; with it, every parallel call takes a
/// `num_threads` setting (0 = all cores) passed to its own parallel region — process-wide OpenMP state
/// is never changed.

#ifdef _OPENMP
#include <omp.h>
#endif

#include "binpick/core/errors.hpp"

namespace binpick {
namespace detail {

/// Threads to use for a requested count (0 = all cores); 1 without OpenMP.
inline int resolve_num_threads(int requested) {
  require(requested >= 0, "num_threads", "must be >= 0 (0 = all cores)");
#ifdef _OPENMP
  return requested == 0 ? omp_get_num_procs() : requested;
#else
  (void)requested;
  return 1;
#endif
}

}  // namespace detail
}  // namespace binpick
