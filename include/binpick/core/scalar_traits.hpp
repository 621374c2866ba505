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
};

template <>
struct ScalarTraits<float> {
  static constexpr float orthonormal_tolerance() { return 1e-3f; }
  static constexpr float solve_tolerance() { return 1e-7f; }
};

}  // namespace binpick
