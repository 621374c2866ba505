#pragma once
/// \file plane.hpp
/// A plane in 3D: a point on it and a unit normal. Built from a point and a normal, or through three
/// points (paper §III.C.2: P through the grasp point A, the lift point B and the drop point C).

#include <cmath>
#include <optional>

#include "binpick/core/errors.hpp"
#include "binpick/core/pose.hpp"
#include "binpick/geometry/tolerance.hpp"

namespace binpick::geometry {

template <typename Scalar>
struct Plane {
  Vector3<Scalar> point = Vector3<Scalar>::Zero();   ///< a point on the plane [m]
  Vector3<Scalar> normal = Vector3<Scalar>::UnitZ(); ///< unit normal

  /// Throws `std::invalid_argument` unless both are finite and the normal is not zero; the normal is
  /// normalized.
  static Plane from_point_normal(const Vector3<Scalar>& point, const Vector3<Scalar>& normal) {
    require_all_finite(point, "point");
    require_all_finite(normal, "normal");
    const Scalar len = normal.norm();
    require(len > Scalar(0) && std::isfinite(len), "normal", "must be a non-zero finite vector");
    return Plane{point, normal / len};
  }

  /// Signed distance of `x` along the normal [m].
  Scalar signed_distance(const Vector3<Scalar>& x) const { return normal.dot(x - point); }
  /// Orthogonal projection of `x` onto the plane.
  Vector3<Scalar> project(const Vector3<Scalar>& x) const { return x - signed_distance(x) * normal; }
};

/// The plane through `a`, `b`, `c` with normal (b - a) x (c - a) normalized, placed at `a`.
/// Returns nothing when the points are collinear or coincide: the sine of the angle at `a` is at most
/// GeometryTolerance::relative() (or a side has zero length). Throws on non-finite input.
template <typename Scalar>
std::optional<Plane<Scalar>> plane_through_points(const Vector3<Scalar>& a, const Vector3<Scalar>& b,
                                                  const Vector3<Scalar>& c) {
  require_all_finite(a, "a");
  require_all_finite(b, "b");
  require_all_finite(c, "c");
  const Vector3<Scalar> ab = b - a, ac = c - a;
  const Vector3<Scalar> n = ab.cross(ac);
  const Scalar n_len = n.norm();
  const Scalar scale = ab.norm() * ac.norm();
  if (!(scale > Scalar(0)) || !(n_len > GeometryTolerance<Scalar>::relative() * scale)) return std::nullopt;
  return Plane<Scalar>{a, n / n_len};
}

}  // namespace binpick::geometry
