#pragma once
/// \file simd.hpp
/// Portable SIMD packs through the GCC/Clang vector extension (SSE2 on x86-64, NEON on ARM,
/// scalar code elsewhere) — the baseline ISA only, so nothing depends on -march. Used where the
/// auto-vectorizer gives up on select-heavy loops (conditional divisions count as control flow).

#include <cstring>

namespace binpick {
namespace detail {

/// Pack width [bytes]: 16 at the baseline ISA; 32 when the translation unit is compiled for AVX2
/// (opt-in, e.g. -march=x86-64-v3 or BINPICK_NATIVE_ARCH=ON), which also gives single-instruction
/// blends.
#if defined(__AVX2__)
constexpr int kPackBytes = 32;
#else
constexpr int kPackBytes = 16;
#endif

template <typename Scalar>
struct Pack {
  static constexpr int size = int(kPackBytes / sizeof(Scalar));
  typedef Scalar type __attribute__((vector_size(kPackBytes)));

  static type load(const Scalar* p) {
    type v;
    std::memcpy(&v, p, sizeof v);
    return v;
  }
  static void store(Scalar* p, const type& v) { std::memcpy(p, &v, sizeof v); }
  static type splat(Scalar s) {
    type v;
    for (int i = 0; i < size; ++i) v[i] = s;
    return v;
  }
  /// True when every lane of a comparison mask is set.
  template <typename Mask>
  static bool all(const Mask& mask) {
    bool r = true;
    for (int i = 0; i < size; ++i) r &= mask[i] != 0;
    return r;
  }
  /// Lane-wise mask ? a : b (mask lanes are all-ones or zero, as comparisons produce).
  template <typename Mask>
  static type select(const Mask& mask, const type& a, const type& b) {
    return mask ? a : b;
  }
};

}  // namespace detail
}  // namespace binpick
