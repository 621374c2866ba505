#pragma once
/// \file in_plane_rotation.hpp
/// Rotation of a vector, a point or a line by an angle about a pivot *within* a plane (paper Alg. 2,
/// lines 2 and 4): the rotation axis is the plane's normal through the pivot, and the angle is positive
/// counter-clockwise seen from the side the normal points to (right-hand rule).

#include <cmath>

#include "binpick/core/pose.hpp"
#include "binpick/geometry/line.hpp"

namespace binpick::geometry {

/// Rodrigues' formula about the unit `axis`: v cos a + (axis x v) sin a + axis (axis . v)(1 - cos a).
/// For v in the plane (v . axis = 0) the last term vanishes and the result stays in the plane.
template <typename Scalar>
Vector3<Scalar> rotate_vector(const Vector3<Scalar>& v, const Vector3<Scalar>& axis, Scalar angle) {
  const Scalar c = std::cos(angle), s = std::sin(angle);
  return v * c + axis.cross(v) * s + axis * (axis.dot(v) * (Scalar(1) - c));
}

/// `x` rotated by `angle` [rad] about the axis through `pivot` along the unit `axis`.
template <typename Scalar>
Vector3<Scalar> rotate_point(const Vector3<Scalar>& x, const Vector3<Scalar>& pivot, const Vector3<Scalar>& axis,
                             Scalar angle) {
  return pivot + rotate_vector<Scalar>(x - pivot, axis, angle);
}

/// The line rotated by `angle` [rad] about `pivot` within the plane whose unit normal is `axis`.
/// When the pivot lies on the line (as B on AB and T on MT in Alg. 2) the rotated line passes through
/// the pivot and keeps it as its point, so parameters t >= 0 stay "ahead of the pivot".
template <typename Scalar>
Line3<Scalar> rotate_line_in_plane(const Line3<Scalar>& line, const Vector3<Scalar>& pivot,
                                   const Vector3<Scalar>& axis, Scalar angle) {
  const Vector3<Scalar> d = rotate_vector<Scalar>(line.direction, axis, angle);
  // Foot of the pivot on the line: the pivot itself when it lies on the line.
  const Vector3<Scalar> foot = line.point + (pivot - line.point).dot(line.direction) * line.direction;
  return Line3<Scalar>{rotate_point<Scalar>(foot, pivot, axis, angle), d.normalized()};
}

}  // namespace binpick::geometry
