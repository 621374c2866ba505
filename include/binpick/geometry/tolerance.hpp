#pragma once
/// \file tolerance.hpp
/// Geometric tolerances per scalar type, decided in one place. They are relative: a length is compared
/// against `relative() * scale` where the scale is the size of the configuration (e.g. a radius).

#include <type_traits>

namespace binpick::geometry {

template <typename Scalar>
struct GeometryTolerance {
  static_assert(std::is_floating_point<Scalar>::value, "binpick: Scalar must be float or double");
  /// Relative tolerance for "degenerate" decisions (collinear, tangent, parallel) [-].
  static constexpr Scalar relative() { return Scalar(1e-9); }
};

template <>
struct GeometryTolerance<float> {
  // float carries ~7 digits; rounding of products of lengths sits near 1e-7, so degeneracy is declared
  // a little above that.
  static constexpr float relative() { return 1e-5f; }
};

}  // namespace binpick::geometry
