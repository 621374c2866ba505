#pragma once
/// \file tolerance.hpp
/// Geometric tolerances per scalar type, decided in one place. They are relative: a length is compared
/// against `relative() * scale` where the scale is the size of the configuration (e.g. a radius).

#include "binpick/core/scalar_traits.hpp"

namespace binpick::geometry {

template <typename Scalar>
struct GeometryTolerance {
  /// Relative tolerance for "degenerate" decisions (collinear, tangent, parallel) [-]; the values per
  /// scalar live in ScalarTraits (core), which poses share.
  static constexpr Scalar relative() { return ScalarTraits<Scalar>::degenerate_tolerance(); }
};

}  // namespace binpick::geometry
