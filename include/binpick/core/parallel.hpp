#pragma once
/// \file parallel.hpp
/// The OpenMP seam: the library builds and runs without OpenMP; with it, every parallel call takes a
/// `num_threads` setting (0 = all cores) passed to its own parallel region — process-wide OpenMP state
/// is never changed.

#ifdef _OPENMP
#include <omp.h>
#endif

#include "binpick/core/errors.hpp"

/// BINPICK_OMP(parallel for ...) is `#pragma omp parallel for ...` with OpenMP and nothing without:
/// a bare `#pragma omp` in a header warns (-Wall's -Wunknown-pragmas) in every project that includes
/// it without OpenMP.
#define BINPICK_DETAIL_PRAGMA_STRING(...) #__VA_ARGS__
#ifdef _OPENMP
#define BINPICK_OMP(...) _Pragma(BINPICK_DETAIL_PRAGMA_STRING(omp __VA_ARGS__))
#else
#define BINPICK_OMP(...)
#endif

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
