#pragma once
/// \file huge_pages.hpp
/// Transparent huge pages for the large buffers of a registration (organized clouds, their normals).
/// Linux kernels in THP mode "madvise" (Debian's default) back memory with huge pages only where the
/// process asked with madvise(MADV_HUGEPAGE), and glibc asks only when the process runs with
/// GLIBC_TUNABLES=glibc.malloc.hugetlb=1; so the library asks for its own large buffers. What that
/// buys is fewer page faults when such a buffer is first written: 512 faults of 4 kB become one of
/// 2 MB (a one-call registration at 640 x 480 in fresh memory: 65 -> 24 ms on a virtual machine,
/// README). Buffers kept across frames were measured no faster or slower. A hint: it changes no
/// value, and is a no-op elsewhere (other systems, THP off, small buffers).

#include <cstddef>
#include <cstdint>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace binpick {
namespace detail {

/// Size of a transparent huge page on x86-64 and most ARM64 kernels [bytes].
constexpr std::size_t kHugePageBytes = std::size_t(1) << 21;

/// Asks the kernel to back the whole huge pages inside [p, p + bytes) with huge pages. Effective for
/// pages not touched yet (call it between reserving and writing); errors are ignored (a hint).
inline void advise_huge_pages(const void* p, std::size_t bytes) noexcept {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  if (p == nullptr || bytes < kHugePageBytes) return;
  const std::uintptr_t a = reinterpret_cast<std::uintptr_t>(p);
  // Down to the huge page holding the start: a large allocation is its own mapping (aligned to 2 MB by
  // current kernels when its length is a multiple of that, see reserve_huge) with the allocator's
  // header before `p`; an allocation inside the heap shares the page with its neighbours, which the
  // hint then covers too (harmless). Nothing past the end.
  const std::uintptr_t lo = a & ~std::uintptr_t(kHugePageBytes - 1);
  const std::uintptr_t hi = (a + bytes) & ~std::uintptr_t(kHugePageBytes - 1);
  if (hi > lo) (void)::madvise(reinterpret_cast<void*>(lo), hi - lo, MADV_HUGEPAGE);
#else
  (void)p;
  (void)bytes;
#endif
}

/// v.reserve(n), asking for huge pages when this allocates a large buffer (before anything is
/// written into its new part). Call before resize() of a buffer that is kept across frames. The
/// capacity is rounded up so that the allocation with glibc's chunk header fills whole huge pages
/// (at most 2 MB more): the kernel then aligns the mapping to them and every page of it can be huge,
/// not only the ones inside an unaligned mapping.
template <typename T, typename Alloc>
void reserve_huge(std::vector<T, Alloc>& v, std::size_t n) {
  if (v.capacity() >= n) return;
  constexpr std::size_t kHeader = 24;  // glibc: the chunk header before the data and the size word it adds
  const std::size_t bytes = n * sizeof(T);
  if (bytes >= kHugePageBytes && n <= v.max_size() / 2)
    n = ((bytes + kHeader + kHugePageBytes - 1) / kHugePageBytes * kHugePageBytes - kHeader) / sizeof(T);
  v.reserve(n);
  advise_huge_pages(v.data(), v.capacity() * sizeof(T));
}

}  // namespace detail
}  // namespace binpick
