#pragma once
/// \file sphere.hpp
/// A sphere in 3D (paper §III.C.2: S, centered at the target center with the sensor's best working
/// distance as radius).

#include "binpick/core/errors.hpp"
#include "binpick/core/pose.hpp"

namespace binpick::geometry {

template <typename Scalar>
struct Sphere {
  Vector3<Scalar> center = Vector3<Scalar>::Zero();  ///< [m]
  Scalar radius = Scalar(0);                         ///< [m], > 0

  /// Throws `std::invalid_argument` unless the center is finite and the radius finite and > 0.
  static Sphere make(const Vector3<Scalar>& center, Scalar radius) {
    require_all_finite(center, "center");
    require(std::isfinite(radius) && radius > Scalar(0), "radius", "must be finite and > 0");
    return Sphere{center, radius};
  }

  /// Distance of `x` from the surface (negative inside) [m].
  Scalar signed_distance(const Vector3<Scalar>& x) const { return (x - center).norm() - radius; }
};

}  // namespace binpick::geometry
