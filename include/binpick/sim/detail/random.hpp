#pragma once
/// \file random.hpp
/// Counter-based random numbers for the simulation. Every draw is a pure function of its key
/// (seed, frame, pixel, purpose), so a frame is reproducible for a seed and identical for any thread
/// count, and no generator state is shared between pixels. The standard library's distributions are
/// implementation-defined, so uniform and normal variates are computed here.

#include <cmath>
#include <cstdint>

namespace binpick::sim::detail {

/// SplitMix64 finalizer: a bijective 64-bit mix with good avalanche.
inline std::uint64_t mix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

/// Hash of several keys (order matters).
inline std::uint64_t hash_keys(std::uint64_t a, std::uint64_t b) { return mix64(a ^ mix64(b)); }
inline std::uint64_t hash_keys(std::uint64_t a, std::uint64_t b, std::uint64_t c) {
  return hash_keys(hash_keys(a, b), c);
}
inline std::uint64_t hash_keys(std::uint64_t a, std::uint64_t b, std::uint64_t c, std::uint64_t d) {
  return hash_keys(hash_keys(a, b, c), d);
}

/// Uniform in [0, 1) from the top 53 bits.
inline double to_unit(std::uint64_t h) { return double(h >> 11) * (1.0 / 9007199254740992.0); }

/// A small stream: SplitMix64 over a key. Cheap to create per pixel.
class Rng {
 public:
  explicit Rng(std::uint64_t key) : state_(key) {}
  std::uint64_t next() {
    state_ += 0x9e3779b97f4a7c15ULL;
    std::uint64_t z = state_;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
  /// Uniform in [0, 1).
  double uniform() { return to_unit(next()); }
  /// Uniform in [lo, hi).
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  /// Standard normal (Box–Muller; the log argument is kept > 0).
  double normal() {
    const double u1 = 1.0 - uniform();  // (0, 1]
    const double u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(6.283185307179586 * u2);
  }

 private:
  std::uint64_t state_;
};

}  // namespace binpick::sim::detail
