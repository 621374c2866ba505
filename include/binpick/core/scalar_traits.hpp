#pragma once
/// \file scalar_traits.hpp
/// Tolerances per scalar type, decided in one place (float and double tests need different epsilons).

#include <type_traits>

namespace binpick {

template <typename Scalar>
struct ScalarTraits {
  static_assert(std::is_floating_point<Scalar>::value, "binpick: Scalar must be float or double");
  /// Tolerance for "is this rotation orthonormal" checks on user poses.
  static constexpr Scalar orthonormal_tolerance() { return Scalar(1e-6); }
  /// Relative tolerance of an iterative solve (e.g. lens undistortion).
  static constexpr Scalar solve_tolerance() { return Scalar(1e-12); }
  /// Relative tolerance for "degenerate" decisions (collinear, tangent, parallel) [-].
  static constexpr Scalar degenerate_tolerance() { return Scalar(1e-9); }
};

template <>
struct ScalarTraits<float> {
  static constexpr float orthonormal_tolerance() { return 1e-3f; }
  static constexpr float solve_tolerance() { return 1e-7f; }
  // float carries ~7 digits; rounding of products of lengths sits near 1e-7, so degeneracy is declared
  // a little above that.
  static constexpr float degenerate_tolerance() { return 1e-5f; }
};

}  // namespace binpick
