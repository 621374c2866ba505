#pragma once
/// \file simd.hpp
/// Portable 16-byte SIMD packs through the GCC/Clang vector extension (SSE2 on x86-64, NEON on ARM,
/// scalar code elsewhere) — the baseline ISA only, so nothing depends on -march. Used where the
/// auto-vectorizer gives up on select-heavy loops (conditional divisions count as control flow).

#include <cstring>

namespace binpick {
namespace detail {

template <typename Scalar>
struct Pack {
  static constexpr int size = int(16 / sizeof(Scalar));
  typedef Scalar type __attribute__((vector_size(16)));

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
  /// Lane-wise mask ? a : b (mask lanes are all-ones or zero, as comparisons produce).
  template <typename Mask>
  static type select(const Mask& mask, const type& a, const type& b) {
    return mask ? a : b;
  }
};

}  // namespace detail
}  // namespace binpick
