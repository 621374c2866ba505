#pragma once
/// \file line.hpp
/// An infinite line in 3D: a point and a unit direction; points are `point + t * direction`.

#include <cmath>

#include "binpick/core/errors.hpp"
#include "binpick/core/pose.hpp"

namespace binpick::geometry {

template <typename Scalar>
struct Line3 {
  Vector3<Scalar> point = Vector3<Scalar>::Zero();        ///< [m]
  Vector3<Scalar> direction = Vector3<Scalar>::UnitX();   ///< unit

  /// The line through `from` and `to`, directed from `from` to `to`. Throws `std::invalid_argument`
  /// when they are not finite or coincide.
  static Line3 through(const Vector3<Scalar>& from, const Vector3<Scalar>& to) {
    require_all_finite(from, "from");
    require_all_finite(to, "to");
    const Vector3<Scalar> d = to - from;
    const Scalar len = d.norm();
    require(len > Scalar(0), "to", "must differ from 'from'");
    return Line3{from, d / len};
  }

  Vector3<Scalar> at(Scalar t) const { return point + t * direction; }
  /// Distance of `x` from the line [m].
  Scalar distance(const Vector3<Scalar>& x) const {
    const Vector3<Scalar> v = x - point;
    return (v - v.dot(direction) * direction).norm();
  }
};

/// Angle between two unit directions [rad] in [0, pi], through atan2 so it stays accurate near 0 and pi.
template <typename Scalar>
Scalar angle_between(const Vector3<Scalar>& u, const Vector3<Scalar>& v) {
  return std::atan2(u.cross(v).norm(), u.dot(v));
}

}  // namespace binpick::geometry
