#pragma once
/// \file circle.hpp
/// A circle in 3D (center, unit normal, radius) and the circle where a sphere meets a plane (paper
/// §III.C.2 and Alg. 2 line 1: arc L = S ∩ P).

#include <algorithm>
#include <cmath>
#include <optional>

#include "binpick/core/pose.hpp"
#include "binpick/geometry/plane.hpp"
#include "binpick/geometry/sphere.hpp"
#include "binpick/geometry/tolerance.hpp"

namespace binpick::geometry {

template <typename Scalar>
struct Circle3 {
  Vector3<Scalar> center = Vector3<Scalar>::Zero();   ///< [m]
  Vector3<Scalar> normal = Vector3<Scalar>::UnitZ();  ///< unit normal of the circle's plane
  Scalar radius = Scalar(0);                          ///< [m]

  /// Distance of `x` from the circle (the curve, not the disc) [m].
  Scalar distance(const Vector3<Scalar>& x) const {
    const Vector3<Scalar> v = x - center;
    const Scalar off = normal.dot(v);
    const Scalar in_plane = (v - off * normal).norm();
    return std::hypot(in_plane - radius, off);
  }
};

/// The circle S ∩ P: centered at the projection of the sphere's center onto the plane, radius
/// sqrt(R^2 - h^2) where h is the center's distance from the plane; its normal is the plane's.
/// Returns nothing when the plane misses the sphere or only touches it (radius at most
/// GeometryTolerance::relative() * R): a single point carries no arc.
template <typename Scalar>
std::optional<Circle3<Scalar>> intersect(const Sphere<Scalar>& sphere, const Plane<Scalar>& plane) {
  const Scalar h = plane.signed_distance(sphere.center);
  const Scalar rho2 = (sphere.radius - h) * (sphere.radius + h);  // R^2 - h^2 without cancellation
  const Scalar min_radius = GeometryTolerance<Scalar>::relative() * sphere.radius;
  if (!(rho2 > min_radius * min_radius)) return std::nullopt;
  // min(): rounding must never make the circle wider than the sphere (callers rely on rho <= R).
  return Circle3<Scalar>{sphere.center - h * plane.normal, plane.normal, std::min(sphere.radius, std::sqrt(rho2))};
}

}  // namespace binpick::geometry
