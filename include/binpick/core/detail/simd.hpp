#pragma once
/// \file simd.hpp
/// Portable SIMD packs through the GCC/Clang vector extension (SSE2 on x86-64, NEON on ARM,
/// scalar code elsewhere). Used where the auto-vectorizer gives up on select-heavy loops
/// (conditional divisions count as control flow). A kernel written once over `Pack<Scalar, Bytes>`
/// runs at the build's ISA and, through simd_call(), also with AVX2 chosen at run time
/// (core/simd_level.hpp).

#include <atomic>
#include <cmath>
#include <cstring>
#include <type_traits>
#include <utility>

#if defined(__x86_64__)
#include <immintrin.h>  // declares the AVX builtins (Pack::sqrt) in builds without AVX
#endif

#include "binpick/core/simd_level.hpp"

/// Forces inlining: a kernel body and every helper taking packs must be inlined into the function
/// that carries the AVX2 target attribute, or its 32-byte packs would be compiled for the baseline.
#define BINPICK_SIMD_INLINE inline __attribute__((always_inline))
/// The same for a lambda (after its parameter list).
#define BINPICK_SIMD_INLINE_LAMBDA __attribute__((always_inline))
/// Around code that passes 32-byte packs between always-inlined helpers: compiled outside an AVX
/// function they draw GCC/Clang's ABI note, but such calls never survive inlining, so no ABI changes.
#define BINPICK_SIMD_BEGIN _Pragma("GCC diagnostic push") _Pragma("GCC diagnostic ignored \"-Wpsabi\"")
#define BINPICK_SIMD_END _Pragma("GCC diagnostic pop")

namespace binpick {
namespace detail {

/// Pack width [bytes] of the build's ISA: 16 at the baseline; 32 when the translation unit is
/// compiled for AVX2 (opt-in, e.g. -march=x86-64-v3), which also gives
/// single-instruction blends.
#if defined(__AVX2__)
constexpr int kPackBytes = 32;
#else
constexpr int kPackBytes = 16;
#endif

BINPICK_SIMD_BEGIN

/// A vector of N lanes of T (the narrowing conversions of Pack::store_bytes).
template <typename T, int N>
struct Lanes {
  typedef T type __attribute__((vector_size(N * sizeof(T))));
};

/// Lane l of the result is scalar Index(l) of the 2L-lane concatenation a|b (Index a constexpr map).
template <typename V, typename M, int L, typename Index, std::size_t... Ls>
BINPICK_SIMD_INLINE V shuffle_two(const V& a, const V& b, std::index_sequence<Ls...>) {
#if defined(__clang__)
  return __builtin_shufflevector(a, b, Index::at(int(Ls))...);
#else
  using Lane = typename std::remove_reference<decltype(M()[0])>::type;
  const M m = {Lane(Index::at(int(Ls)))...};
  return __builtin_shuffle(a, b, m);
#endif
}

/// Index maps of Pack::load3 / store3 (scalar e of the interleaved 3L is coordinate e % 3 of vector e / 3).
template <int L, int D>
struct DeinterleaveFromAb {  // coordinate D from a|b where it lies there (else any lane)
  static constexpr int at(int l) { return 3 * l + D < 2 * L ? 3 * l + D : 0; }
};
template <int L, int D>
struct DeinterleaveWithC {  // ... then the rest from c
  static constexpr int at(int l) { return 3 * l + D < 2 * L ? l : L + 3 * l + D - 2 * L; }
};
template <int L, int J>
struct InterleaveFromXy {  // scalars J L .. J L + L - 1 of the interleaved array: x and y lanes
  static constexpr int at(int m) {
    return (J * L + m) % 3 == 0 ? (J * L + m) / 3 : (J * L + m) % 3 == 1 ? L + (J * L + m) / 3 : 0;
  }
};
template <int L, int J>
struct InterleaveWithZ {  // ... then the z lanes
  static constexpr int at(int m) { return (J * L + m) % 3 == 2 ? L + (J * L + m) / 3 : m; }
};

template <typename Scalar, int Bytes = kPackBytes>
struct Pack {
  static constexpr int size = int(Bytes / sizeof(Scalar));
  typedef Scalar type __attribute__((vector_size(Bytes)));
  using mask = decltype(type() < type());  ///< comparison result: signed integer lanes, all-ones or zero

  BINPICK_SIMD_INLINE static type load(const Scalar* p) {
    type v;
    std::memcpy(&v, p, sizeof v);
    return v;
  }
  BINPICK_SIMD_INLINE static void store(Scalar* p, const type& v) { std::memcpy(p, &v, sizeof v); }
  /// The coordinates of `size` consecutive 3-vectors (3 × size scalars from p) as three packs: three
  /// loads and two shuffles a coordinate, instead of a scalar load and insert a value.
  BINPICK_SIMD_INLINE static void load3(const Scalar* p, type& x, type& y, type& z) {
    const type a = load(p), b = load(p + size), c = load(p + 2 * size);
    const auto lanes = std::make_index_sequence<std::size_t(size)>();
    x = shuffle_two<type, mask, size, DeinterleaveWithC<size, 0>>(
        shuffle_two<type, mask, size, DeinterleaveFromAb<size, 0>>(a, b, lanes), c, lanes);
    y = shuffle_two<type, mask, size, DeinterleaveWithC<size, 1>>(
        shuffle_two<type, mask, size, DeinterleaveFromAb<size, 1>>(a, b, lanes), c, lanes);
    z = shuffle_two<type, mask, size, DeinterleaveWithC<size, 2>>(
        shuffle_two<type, mask, size, DeinterleaveFromAb<size, 2>>(a, b, lanes), c, lanes);
  }
  /// load3 into coordinate rows: x[l], y[l], z[l] = the l-th of the `size` 3-vectors at p.
  BINPICK_SIMD_INLINE static void load3(const Scalar* p, Scalar* x, Scalar* y, Scalar* z) {
    type px, py, pz;
    load3(p, px, py, pz);
    store(x, px);
    store(y, py);
    store(z, pz);
  }
  /// load3's inverse: x, y, z written as `size` consecutive 3-vectors at p.
  BINPICK_SIMD_INLINE static void store3(Scalar* p, const type& x, const type& y, const type& z) {
    const auto lanes = std::make_index_sequence<std::size_t(size)>();
    store(p, shuffle_two<type, mask, size, InterleaveWithZ<size, 0>>(
                 shuffle_two<type, mask, size, InterleaveFromXy<size, 0>>(x, y, lanes), z, lanes));
    store(p + size, shuffle_two<type, mask, size, InterleaveWithZ<size, 1>>(
                        shuffle_two<type, mask, size, InterleaveFromXy<size, 1>>(x, y, lanes), z, lanes));
    store(p + 2 * size, shuffle_two<type, mask, size, InterleaveWithZ<size, 2>>(
                            shuffle_two<type, mask, size, InterleaveFromXy<size, 2>>(x, y, lanes), z, lanes));
  }
  BINPICK_SIMD_INLINE static type splat(Scalar s) {
    type v;
    for (int i = 0; i < size; ++i) v[i] = s;
    return v;
  }
  /// Stores each lane, a whole number in [0, 255], as one byte (a single conversion and a narrowing
  /// store, not one scalar conversion a lane).
  BINPICK_SIMD_INLINE static void store_bytes(unsigned char* p, const type& v) {
    const typename Lanes<int, size>::type i = __builtin_convertvector(v, typename Lanes<int, size>::type);
    const typename Lanes<unsigned char, size>::type b =
        __builtin_convertvector(i, typename Lanes<unsigned char, size>::type);
    std::memcpy(p, &b, sizeof b);
  }
  /// True when every lane of a comparison mask is set.
  BINPICK_SIMD_INLINE static bool all(const mask& m) { return none(~m); }
  /// True when no lane of a comparison mask is set: one pmovmskb with GCC's builtins on x86-64 (as
  /// sqrt below); a lane loop otherwise, which GCC compiles to an extract a lane. (A sampling profile
  /// put 9 % of a full-resolution point-to-plane iteration on such a loop in ICP's partner reads; the
  /// instruction made no difference there above the benchmark host's run-to-run spread.)
  BINPICK_SIMD_INLINE static bool none(const mask& m) {
#if defined(__x86_64__) && !defined(__clang__) && defined(__GNUC__)
    using bytes = typename Lanes<char, Bytes>::type;
    if constexpr (Bytes == 32) {
      return __builtin_ia32_pmovmskb256((bytes)m) == 0;
    } else if constexpr (Bytes == 16) {
      return __builtin_ia32_pmovmskb128((bytes)m) == 0;
    }
#endif
    bool any = false;
    for (int i = 0; i < size; ++i) any |= m[i] != 0;
    return !any;
  }
  /// Lane-wise mask ? a : b (mask lanes are all-ones or zero, as comparisons produce).
  BINPICK_SIMD_INLINE static type select(const mask& m, const type& a, const type& b) { return m ? a : b; }
  /// Lane-wise square root (IEEE, as std::sqrt: the same bits a lane). One instruction on x86-64
  /// with GCC's builtins (they need the instruction set only in the function they are inlined
  /// into, not in the caller's own target), lane by lane otherwise.
  BINPICK_SIMD_INLINE static type sqrt(const type& v) {
#if defined(__x86_64__) && !defined(__clang__) && defined(__GNUC__)
    if constexpr (Bytes == 32 && std::is_same<Scalar, float>::value) {
      return __builtin_ia32_sqrtps256(v);
    } else if constexpr (Bytes == 32 && std::is_same<Scalar, double>::value) {
      return __builtin_ia32_sqrtpd256(v);
    } else if constexpr (Bytes == 16 && std::is_same<Scalar, float>::value) {
      return __builtin_ia32_sqrtps(v);
    } else if constexpr (Bytes == 16 && std::is_same<Scalar, double>::value) {
      return __builtin_ia32_sqrtpd(v);
    }
#endif
    type r;
    for (int i = 0; i < size; ++i) r[i] = std::sqrt(v[i]);
    return r;
  }
};

#if BINPICK_SIMD_DISPATCH
template <typename F>
__attribute__((target("avx2"))) void simd_call_avx2(F& f) {
  f(std::integral_constant<int, 32>{});
}
#endif

/// Runs `f(std::integral_constant<int, Bytes>{})` with the pack width of simd_level(): `f` is a
/// generic lambda marked BINPICK_SIMD_INLINE_LAMBDA whose body uses Pack<Scalar, Bytes>.
template <typename F>
void simd_call(F&& f) {
#if BINPICK_SIMD_DISPATCH
  if (simd_level() == SimdLevel::avx2) return simd_call_avx2(f);
#endif
  f(std::integral_constant<int, kPackBytes>{});
}

#if BINPICK_SIMD_DISPATCH
template <typename F>
__attribute__((target("avx2,fma"))) void simd_call_avx2_fma(F& f) {
  f(std::integral_constant<int, 32>{});
}
/// The same 32-byte packs with AVX-512VL's encoding: 32 vector registers instead of 16 (the sums of
/// ICP's pass keep 28 accumulators), and its mask and blend instructions.
template <typename F>
__attribute__((target("avx2,fma,avx512f,avx512vl,avx512bw,avx512dq"))) void simd_call_avx512vl(F& f) {
  f(std::integral_constant<int, 32>{});
}
inline bool cpu_has_fma() {
  static const bool has = __builtin_cpu_supports("fma") != 0;
  return has;
}
inline bool cpu_has_avx512vl() {
  static const bool has = cpu_has_fma() && __builtin_cpu_supports("avx512f") != 0 &&
                          __builtin_cpu_supports("avx512vl") != 0 && __builtin_cpu_supports("avx512bw") != 0 &&
                          __builtin_cpu_supports("avx512dq") != 0;
  return has;
}
#endif

/// Whether simd_call_fused may use AVX-512VL (default true). Tests set false to run the FMA variant
/// that CPUs without AVX-512VL get.
inline std::atomic<bool>& fused_avx512vl_allowed() {
  static std::atomic<bool> allowed{true};
  return allowed;
}

/// The variants of simd_call_fused (the build's own packs, or AVX2 with FMA / AVX-512VL's encoding).
enum class FusedVariant { baseline, avx2, avx2_fma, avx512vl };

/// The variant simd_call_fused runs now (builds that do not choose at run time: the build's level).
inline FusedVariant fused_variant() {
#if BINPICK_SIMD_DISPATCH
  if (simd_level() != SimdLevel::avx2) return FusedVariant::baseline;
  if (cpu_has_avx512vl() && fused_avx512vl_allowed().load(std::memory_order_relaxed)) return FusedVariant::avx512vl;
  return cpu_has_fma() ? FusedVariant::avx2_fma : FusedVariant::avx2;
#else
  return simd_level() == SimdLevel::avx2 ? FusedVariant::avx2 : FusedVariant::baseline;
#endif
}

/// fused_variant() for reports: "baseline", "avx2", "avx2_fma" or "avx512vl".
inline const char* fused_isa() {
  switch (fused_variant()) {
    case FusedVariant::avx512vl: return "avx512vl";
    case FusedVariant::avx2_fma: return "avx2_fma";
    case FusedVariant::avx2: return "avx2";
    default: return "baseline";
  }
}

/// simd_call for kernels whose results need not round as the baseline level's do (sums that tests
/// compare with tolerances, never bit for bit). At the AVX2 level the compiler may also fuse
/// multiply-adds (FMA) and, on CPUs with AVX-512VL, use its encoding for the same 32-byte packs, so
/// the last bits of such a kernel depend on the CPU. Measured on ICP's point-to-plane pass
/// (640 x 480, AMD Zen 5, medians of interleaved runs): FMA took the registration to 0.83 of its
/// time (with the pass's other change of that commit), AVX-512VL a further 0.95.
template <typename F>
void simd_call_fused(F&& f) {
#if BINPICK_SIMD_DISPATCH
  switch (fused_variant()) {
    case FusedVariant::avx512vl: return simd_call_avx512vl(f);
    case FusedVariant::avx2_fma: return simd_call_avx2_fma(f);
    case FusedVariant::avx2: return simd_call_avx2(f);
    default: break;
  }
#endif
  f(std::integral_constant<int, kPackBytes>{});
}

BINPICK_SIMD_END

}  // namespace detail
}  // namespace binpick
