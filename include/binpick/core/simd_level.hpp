#pragma once
/// \file simd_level.hpp
/// The instruction set of binpick's vectorized kernels (reprojection and voting, fusion/). A build
/// for the baseline x86-64 ISA (SSE2, the compiler default) still runs them with AVX2 when the CPU
/// has it: the kernels are compiled for both and chosen at run time, once per call. AVX2 here means
/// 8-lane float packs without FMA, so both levels round alike (except ICP's point-to-plane sums,
/// which at this level also use FMA and AVX-512VL where the CPU has them: detail::simd_call_fused,
/// compared by the tests with tolerances); the vote's shortcut for pixels whose
/// views all agree is taken per pack, so fused depths may differ in the last bit between levels
/// (votes never). A build with AVX2 on (e.g. -march=x86-64-v3) uses it everywhere and has nothing to
/// choose; so do non-x86 targets (NEON packs). Defining BINPICK_NO_SIMD_DISPATCH (CMake:
/// BINPICK_SIMD_DISPATCH=OFF) keeps a baseline build at the baseline: no AVX2 code is emitted.
///
/// \code
///   binpick::set_max_simd_level(binpick::SimdLevel::baseline);  // e.g. for bit-equal runs across hosts
/// \endcode

#include <atomic>
#include <vector>

namespace binpick {

enum class SimdLevel : int {
  baseline = 0,  ///< the build's own ISA (16-byte packs on x86-64 and ARM)
  avx2 = 1,      ///< 32-byte packs
};

namespace detail {

#if !defined(BINPICK_NO_SIMD_DISPATCH) && !defined(__AVX2__) && defined(__x86_64__) && \
    (defined(__GNUC__) || defined(__clang__))
#define BINPICK_SIMD_DISPATCH 1
#else
#define BINPICK_SIMD_DISPATCH 0
#endif

inline std::atomic<int>& max_simd_level_storage() {
  static std::atomic<int> level{int(SimdLevel::avx2)};
  return level;
}

inline bool cpu_has_avx2() {
#if BINPICK_SIMD_DISPATCH
  static const bool has = __builtin_cpu_supports("avx2") != 0;
  return has;
#elif defined(__AVX2__)
  return true;
#else
  return false;
#endif
}

}  // namespace detail

/// Caps the level the kernels choose at run time (default: no cap). Thread-safe; calls already
/// running keep their level. No effect in builds that do not choose (see the file comment).
inline void set_max_simd_level(SimdLevel level) { detail::max_simd_level_storage().store(int(level)); }

/// The level the kernels run at: AVX2 when the build has it, or the build chooses at run time, the
/// CPU has it and the cap allows it; else the baseline.
inline SimdLevel simd_level() {
#if BINPICK_SIMD_DISPATCH
  return detail::cpu_has_avx2() && detail::max_simd_level_storage().load(std::memory_order_relaxed) >= int(SimdLevel::avx2)
             ? SimdLevel::avx2
             : SimdLevel::baseline;
#elif defined(__AVX2__)
  return SimdLevel::avx2;
#else
  return SimdLevel::baseline;
#endif
}

/// The levels simd_level() can take in this build on this CPU, lowest first (what a test or a
/// benchmark comparing the levels runs through with set_max_simd_level): one level in builds that do
/// not choose.
inline std::vector<SimdLevel> available_simd_levels() {
#if BINPICK_SIMD_DISPATCH
  if (detail::cpu_has_avx2()) return {SimdLevel::baseline, SimdLevel::avx2};
  return {SimdLevel::baseline};
#elif defined(__AVX2__)
  return {SimdLevel::avx2};
#else
  return {SimdLevel::baseline};
#endif
}

/// "baseline" or "avx2", for reports.
inline const char* to_string(SimdLevel level) { return level == SimdLevel::avx2 ? "avx2" : "baseline"; }

}  // namespace binpick
