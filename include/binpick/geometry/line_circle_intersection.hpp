#pragma once
/// \file line_circle_intersection.hpp
/// Intersection of a line lying in a circle's plane with the circle (paper Alg. 2 lines 3 and 5).
///
/// Choosing between two hits: the hits are reported sorted by their line parameter t (ascending).
/// Alg. 2 needs the point where the line *leaves* the circle going along its direction — for the tilted
/// lift line A'B through B that is the hit above B, ahead in the lift direction — so `exit_point`
/// returns the hit with the larger t, and only when it lies ahead of the line's point (t >= 0).

#include <cmath>
#include <optional>

#include "binpick/core/pose.hpp"
#include "binpick/geometry/circle.hpp"
#include "binpick/geometry/line.hpp"
#include "binpick/geometry/tolerance.hpp"

namespace binpick::geometry {

template <typename Scalar>
struct LineCircleHits {
  int count = 0;                       ///< 0, 1 (tangent) or 2
  Scalar t[2] = {Scalar(0), Scalar(0)};  ///< line parameters, ascending [m]
  Vector3<Scalar> points[2] = {Vector3<Scalar>::Zero(), Vector3<Scalar>::Zero()};
};

/// Intersects `line` with `circle`. The line is taken to lie in the circle's plane (its direction is
/// projected onto the plane, its point onto the plane, so rounding off the plane is harmless); a line
/// perpendicular to the plane gives no hit. Tangency within GeometryTolerance::relative() * radius
/// counts as one hit.
template <typename Scalar>
LineCircleHits<Scalar> intersect(const Line3<Scalar>& line, const Circle3<Scalar>& circle) {
  LineCircleHits<Scalar> hits;
  const Vector3<Scalar>& n = circle.normal;
  Vector3<Scalar> d = line.direction - n.dot(line.direction) * n;
  const Scalar d_len = d.norm();
  const Scalar tol = GeometryTolerance<Scalar>::relative();
  if (!(d_len > tol)) return hits;
  d /= d_len;
  // The line's point in the plane, relative to the center: p(t) = q + t d with t measured along d.
  Vector3<Scalar> q = line.point - circle.center;
  q -= n.dot(q) * n;
  const Scalar b = q.dot(d);  // |q + t d|^2 = rho^2  <=>  t^2 + 2 b t + |q|^2 - rho^2 = 0
  const Scalar foot2 = (q - b * d).squaredNorm();  // squared distance of the center from the line
  const Scalar rho = circle.radius;
  const Scalar foot = std::sqrt(foot2);
  const Scalar eps = tol * rho;
  if (foot > rho + eps) return hits;
  const Scalar disc = (rho - foot) * (rho + foot);  // rho^2 - foot^2, the squared half chord
  const Scalar half = disc > Scalar(0) ? std::sqrt(disc) : Scalar(0);
  // t along d relates to the line's own parameter by t_line = t_d / d_len (d_len = direction . d).
  const Vector3<Scalar> origin = circle.center + q;
  if (half <= eps) {  // tangent: the two hits merge
    hits.count = 1;
    hits.points[0] = origin - b * d;
    hits.t[0] = -b / d_len;
    return hits;
  }
  const Scalar t0 = -b - half, t1 = -b + half;
  hits.count = 2;
  hits.points[0] = origin + t0 * d;
  hits.points[1] = origin + t1 * d;
  hits.t[0] = t0 / d_len;  // d_len > 0, so the order t0 < t1 is kept
  hits.t[1] = t1 / d_len;
  return hits;
}

/// The point where `line` leaves `circle` going along its direction (the hit with the larger t), if that
/// hit lies ahead of the line's point (t >= -tolerance); otherwise nothing.
template <typename Scalar>
std::optional<Vector3<Scalar>> exit_point(const Line3<Scalar>& line, const Circle3<Scalar>& circle) {
  const LineCircleHits<Scalar> hits = intersect(line, circle);
  if (hits.count == 0) return std::nullopt;
  const int last = hits.count - 1;
  if (hits.t[last] < -GeometryTolerance<Scalar>::relative() * circle.radius) return std::nullopt;
  return hits.points[last];
}

}  // namespace binpick::geometry
