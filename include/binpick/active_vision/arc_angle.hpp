#pragma once
/// \file arc_angle.hpp
/// The two angles of a sensing arc (paper §III.C–D). The arc L = S ∩ P is a circle of radius rho
/// around c, the foot of the target center T on P; every point of L is at the sphere radius r from T,
/// and rho = sqrt(r^2 - h^2) with h = distance(T, P).
///
///  - central angle phi: the angle at c between two points of L, measured in P (arc length = rho * phi);
///  - target angle theta: the angle at T between the same two points (the paper's α and β are these,
///    Fig. 7–8: "M and N with the target center T comprise the coverage angle β").
///
/// Both see the same chord: |MN| = 2 rho sin(phi / 2) = 2 r sin(theta / 2). With T in P (h = 0,
/// rho = r) they are equal. Angles in [rad], lengths in [m]; phi in [0, pi], theta in
/// [0, max_target_angle(r, rho)].

#include <algorithm>
#include <cmath>

#include "binpick/core/errors.hpp"

namespace binpick::active_vision {

namespace detail {
template <typename Scalar>
void require_arc(Scalar sphere_radius, Scalar arc_radius) {
  require(std::isfinite(sphere_radius) && sphere_radius > Scalar(0), "sphere_radius", "must be finite and > 0");
  require(std::isfinite(arc_radius) && arc_radius > Scalar(0) && arc_radius <= sphere_radius, "arc_radius",
          "must be finite, > 0 and <= sphere_radius");
}
}  // namespace detail

/// The largest target angle an arc offers: that of two opposite points of L (phi = pi),
/// 2 asin(rho / r) [rad].
template <typename Scalar>
Scalar max_target_angle(Scalar sphere_radius, Scalar arc_radius) {
  detail::require_arc(sphere_radius, arc_radius);
  return Scalar(2) * std::asin(std::min(Scalar(1), arc_radius / sphere_radius));
}

/// Target angle theta [rad] at T of the central angle `central_angle` phi in [0, pi] [rad]:
/// theta = 2 asin((rho / r) sin(phi / 2)). Throws on phi outside [0, pi] or an invalid arc.
template <typename Scalar>
Scalar central_to_target_angle(Scalar central_angle, Scalar sphere_radius, Scalar arc_radius) {
  detail::require_arc(sphere_radius, arc_radius);
  const Scalar pi = Scalar(3.14159265358979323846);
  require(std::isfinite(central_angle) && central_angle >= Scalar(0) && central_angle <= pi, "central_angle",
          "must be in [0, pi]");
  const Scalar s = std::min(Scalar(1), arc_radius / sphere_radius * std::sin(central_angle / Scalar(2)));
  return Scalar(2) * std::asin(s);
}

/// Central angle phi in [0, pi] [rad] of the target angle `target_angle` theta [rad]:
/// phi = 2 asin((r / rho) sin(theta / 2)). Throws unless theta is in [0, max_target_angle(r, rho)]
/// (a slight excess from rounding, within 1e-6 relative, is clamped to phi = pi).
template <typename Scalar>
Scalar target_to_central_angle(Scalar target_angle, Scalar sphere_radius, Scalar arc_radius) {
  detail::require_arc(sphere_radius, arc_radius);
  require(std::isfinite(target_angle) && target_angle >= Scalar(0), "target_angle", "must be finite and >= 0");
  const Scalar s = sphere_radius / arc_radius * std::sin(std::min(target_angle, Scalar(3.14159265358979323846)) / Scalar(2));
  require(target_angle <= Scalar(3.14159265358979323846) && s <= Scalar(1) + Scalar(1e-6), "target_angle",
          "exceeds the largest angle at the target the arc offers (2 asin(arc_radius / sphere_radius))");
  return Scalar(2) * std::asin(std::min(Scalar(1), s));
}

}  // namespace binpick::active_vision
