#pragma once
/// \file sensing_path.hpp
/// The sensing path of the next cycle (paper §III.C, Alg. 2, Figs. 5 and 7): the start and end sensor
/// poses M and N on the arc L = S ∩ P, and the n capture poses between them, all looking at the target
/// center T.
///
/// Alg. 2 as implemented (all points in the robot base frame, metres):
///   S  = sphere(T, r)                         r: the sensor's best working distance
///   P  = plane(A, B, C)                       A grasp, B lift (vertically above A), C drop
///   1. L   = S ∩ P                            a circle of radius rho = sqrt(r^2 - h^2), h = dist(T, P)
///   2. A'B = line AB rotated by γ about B within P, tilted toward C
///   3. M   = A'B ∩ L                          the hit ahead of B along the tilted lift direction
///   4–5. N = the point of L on the drop side with angle MTN = β measured at T
///
/// T is in general not in P (it is the center of the remaining objects while P is set by the grasp and
/// the drop). Rotating the line MT "within P" then cannot keep the angle at T, so the paper's definition
/// of β wins (Fig. 7: "M and N with the target center T comprise the coverage angle β"): N is reached by
/// turning M about the circle's center by the central angle phi whose angle at T is β (arc_angle.hpp).
/// With T in P this is exactly Alg. 2 line 4.
///
/// Drop side: the arc is swept in the rotation sense that turns the lift direction AB toward C — the
/// same sense as the γ tilt — i.e. about the axis k = u × w, u = (B − A)/|B − A| the lift direction and
/// w the unit direction within P perpendicular to u pointing toward C.
///
/// Capture poses: n poses at central angles phi * i / (n − 1), i = 0..n−1 (equal arc lengths; with T off
/// P the angles at T between neighbours are equal as well, since they share the chord, though they do
/// not add up to β). Camera convention (OpenCV): z forward, from the pose toward T; x along the
/// direction of travel on the arc (z × k); y = z × x. For the usual setup — the lift vertical, the
/// sensor above the bin — the image x axis thus points along the sweep toward the drop point and y
/// across the plane P. Poses are `T_base_camera`: camera points to base.
///
/// Lengths: B→M (straight), M→N along the arc (rho * phi), N→C (straight), and B→C straight, so the
/// extra motion sensing costs is length_bmnc − length_bc.
///
/// Degenerate geometry returns a status (never NaN, never a throw): A, B, C collinear (e.g. picking
/// straight below the drop point: no plane P); S not meeting P (or only touching it); the tilted lift
/// line not reaching L ahead of B; β larger than the arc offers (N would pass the point of L opposite
/// M); the arc M..N dipping below `min_elevation` seen from T (the sensor would look up at the target).
/// Fields computed before the failing step are filled; the later ones stay zero/identity and the
/// capture list stays empty. Bad arguments (non-finite, r <= 0, A == B, γ outside [0, pi/2), β outside
/// (0, pi], n < 2) throw `std::invalid_argument` naming the argument.

#include <algorithm>
#include <cmath>
#include <vector>

#include "binpick/active_vision/arc_angle.hpp"
#include "binpick/core/errors.hpp"
#include "binpick/core/pose.hpp"
#include "binpick/geometry/circle.hpp"
#include "binpick/geometry/in_plane_rotation.hpp"
#include "binpick/geometry/line.hpp"
#include "binpick/geometry/line_circle_intersection.hpp"
#include "binpick/geometry/plane.hpp"
#include "binpick/geometry/sphere.hpp"
#include "binpick/geometry/tolerance.hpp"

namespace binpick::active_vision {

enum class SensingPathStatus {
  ok,
  collinear_points,     ///< A, B, C collinear (or B == C): no plane P
  sphere_misses_plane,  ///< dist(T, P) >= r: S and P share no arc
  no_start_point,       ///< the tilted lift line A'B does not meet L ahead of B
  coverage_exceeds_arc, ///< β > 2 asin(rho / r): N would pass the point of L opposite M
  below_min_elevation,  ///< part of the arc M..N is seen from T below `min_elevation`
};

inline const char* to_string(SensingPathStatus s) {
  switch (s) {
    case SensingPathStatus::ok: return "ok";
    case SensingPathStatus::collinear_points: return "grasp, lift and drop points are collinear: no plane P";
    case SensingPathStatus::sphere_misses_plane: return "the sphere S(T, r) does not meet the plane P";
    case SensingPathStatus::no_start_point: return "the tilted lift line A'B does not meet the arc L above B";
    case SensingPathStatus::coverage_exceeds_arc: return "the coverage angle beta is larger than the arc L offers";
    case SensingPathStatus::below_min_elevation: return "the arc M..N goes below the minimum elevation over T";
  }
  return "unknown";
}

/// Inputs of Alg. 2 (base frame, metres, radians).
template <typename Scalar>
struct SensingPathRequest {
  Vector3<Scalar> target = Vector3<Scalar>::Zero();  ///< T, Eq. 1 [m]
  Scalar radius = Scalar(0.3);                       ///< r, best working distance [m] (0.3 in the paper's setup)
  Vector3<Scalar> grasp = Vector3<Scalar>::Zero();   ///< A [m]
  Vector3<Scalar> lift = Vector3<Scalar>::Zero();    ///< B, vertically above A [m]
  Vector3<Scalar> drop = Vector3<Scalar>::Zero();    ///< C [m]
  Scalar gamma = Scalar(5 * 3.14159265358979323846 / 180);  ///< γ, tilt of AB toward C [rad] (5° as in the paper)
  Scalar beta = Scalar(30 * 3.14159265358979323846 / 180);  ///< β, coverage angle at T [rad]; determine offline (parameters.hpp)
  int num_views = 5;                                ///< n >= 2 capture poses, M and N included
  /// Lowest allowed elevation of the sensor seen from T, above the plane through T perpendicular to the
  /// lift direction [rad]. 0: the sensor never looks upward at the target.
  Scalar min_elevation = Scalar(0);
};

template <typename Scalar>
struct SensingPath {
  SensingPathStatus status = SensingPathStatus::collinear_points;
  Vector3<Scalar> start = Vector3<Scalar>::Zero();  ///< M [m]
  Vector3<Scalar> end = Vector3<Scalar>::Zero();    ///< N [m]
  Isometry3<Scalar> T_base_start = Isometry3<Scalar>::Identity();  ///< camera pose at M, looking at T
  Isometry3<Scalar> T_base_end = Isometry3<Scalar>::Identity();    ///< camera pose at N, looking at T
  std::vector<Isometry3<Scalar>> T_base_captures;  ///< n camera poses M..N in equal arc steps
  Scalar length_bmnc = Scalar(0);  ///< |BM| + arc MN + |NC| [m]
  Scalar length_bc = Scalar(0);    ///< |BC| [m]
  Scalar central_angle = Scalar(0);  ///< phi, angle of the arc M..N at its center [rad]
  Scalar coverage_angle = Scalar(0); ///< angle MTN at T [rad] (= β when ok)
  geometry::Plane<Scalar> plane;     ///< P, normal = the sweep axis k
  geometry::Circle3<Scalar> arc;     ///< L, normal = k
  geometry::Line3<Scalar> tilted_lift_line;  ///< A'B through B
  bool ok() const { return status == SensingPathStatus::ok; }
};

using binpick::camera_looking_at;  // core/pose.hpp; poses of the arc use it with the sweep axis

/// Alg. 2 on `request` (see the file comment).
template <typename Scalar>
SensingPath<Scalar> plan_sensing_path(const SensingPathRequest<Scalar>& request) {
  const Scalar pi = Scalar(3.14159265358979323846);
  require_all_finite(request.target, "target");
  require_all_finite(request.grasp, "grasp");
  require_all_finite(request.lift, "lift");
  require_all_finite(request.drop, "drop");
  require(std::isfinite(request.radius) && request.radius > Scalar(0), "radius", "must be finite and > 0");
  require(std::isfinite(request.gamma) && request.gamma >= Scalar(0) && request.gamma < pi / 2, "gamma",
          "must be in [0, pi/2) rad");
  require(std::isfinite(request.beta) && request.beta > Scalar(0) && request.beta <= pi, "beta",
          "must be in (0, pi] rad");
  require(request.num_views >= 2 && request.num_views <= 100000, "num_views", "must be in [2, 100000]");
  require(std::isfinite(request.min_elevation) && request.min_elevation >= -pi / 2 && request.min_elevation < pi / 2,
          "min_elevation", "must be in [-pi/2, pi/2) rad");
  const Vector3<Scalar>& T = request.target;
  const Vector3<Scalar>& A = request.grasp;
  const Vector3<Scalar>& B = request.lift;
  const Vector3<Scalar>& C = request.drop;
  const Scalar r = request.radius;
  const Vector3<Scalar> lift_vector = B - A;
  require(lift_vector.norm() > Scalar(0), "lift", "must differ from grasp");

  SensingPath<Scalar> path;
  path.length_bc = (C - B).norm();

  // Plane P (through A, B, C), oriented so its normal is the sweep axis k = u × w.
  const auto plane = geometry::plane_through_points<Scalar>(A, B, C);
  if (!plane) {
    path.status = SensingPathStatus::collinear_points;
    return path;
  }
  const Vector3<Scalar> u = lift_vector.normalized();
  const Vector3<Scalar> k = plane->normal.dot(u.cross(C - B)) >= Scalar(0) ? plane->normal : Vector3<Scalar>(-plane->normal);
  path.plane = geometry::Plane<Scalar>{A, k};

  // Alg. 2 line 1: L = S ∩ P.
  const auto arc = geometry::intersect(geometry::Sphere<Scalar>{T, r}, path.plane);
  if (!arc) {
    path.status = SensingPathStatus::sphere_misses_plane;
    return path;
  }
  path.arc = *arc;
  const Vector3<Scalar>& c = arc->center;
  const Scalar rho = arc->radius;

  // Line 2: A'B = AB rotated by γ about B within P; positive about k turns u toward C (k × u = w).
  path.tilted_lift_line = geometry::rotate_line_in_plane<Scalar>(geometry::Line3<Scalar>{A, u}, B, k, request.gamma);

  // Line 3: M = A'B ∩ L, the hit ahead of B (line_circle_intersection.hpp: the exit rule).
  const auto M = geometry::exit_point(path.tilted_lift_line, *arc);
  if (!M) {
    path.status = SensingPathStatus::no_start_point;
    return path;
  }
  path.start = *M;
  path.T_base_start = camera_looking_at<Scalar>(path.start, T, k);

  // Lines 4–5: N on L with angle MTN = β at T, i.e. central angle phi on L (arc_angle.hpp).
  if (request.beta > max_target_angle(r, rho) * (Scalar(1) + Scalar(1e-6))) {
    path.status = SensingPathStatus::coverage_exceeds_arc;
    return path;
  }
  const Scalar phi = target_to_central_angle(std::min(request.beta, max_target_angle(r, rho)), r, rho);
  path.central_angle = phi;
  path.end = geometry::rotate_point<Scalar>(path.start, c, k, phi);
  path.T_base_end = camera_looking_at<Scalar>(path.end, T, k);
  path.coverage_angle = geometry::angle_between<Scalar>(path.start - T, path.end - T);
  path.length_bmnc = (path.start - B).norm() + rho * phi + (C - path.end).norm();

  // Elevation over T along the arc: f(psi) = (c - T).u + a cos psi + b sin psi for psi in [0, phi];
  // its minimum is at an end or at psi* = atan2(b, a) + pi when that lies inside.
  const Vector3<Scalar> m0 = path.start - c;
  const Scalar a = m0.dot(u), b = k.cross(m0).dot(u), f0 = (c - T).dot(u);
  Scalar lowest = std::min(f0 + a, (path.end - T).dot(u));
  Scalar psi_star = std::atan2(b, a) + pi;  // in [0, 2 pi]
  if (psi_star >= Scalar(2) * pi) psi_star -= Scalar(2) * pi;
  if (psi_star <= phi) lowest = std::min(lowest, f0 - std::hypot(a, b));
  if (lowest < r * std::sin(request.min_elevation) - geometry::GeometryTolerance<Scalar>::relative() * r) {
    path.status = SensingPathStatus::below_min_elevation;
    return path;
  }

  // The n capture poses, equal central steps from M (i = 0) to N (i = n - 1).
  const int n = request.num_views;
  path.T_base_captures.reserve(std::size_t(n));
  path.T_base_captures.push_back(path.T_base_start);
  for (int i = 1; i + 1 < n; ++i) {
    const Vector3<Scalar> X = geometry::rotate_point<Scalar>(path.start, c, k, phi * Scalar(i) / Scalar(n - 1));
    path.T_base_captures.push_back(camera_looking_at<Scalar>(X, T, k));
  }
  path.T_base_captures.push_back(path.T_base_end);
  path.status = SensingPathStatus::ok;
  return path;
}

/// Alg. 2 from its inputs, as the picking cycle calls it: target center T, best working distance r [m],
/// grasp A, lift B, drop C (base frame, metres), γ and β [rad], n views (see SensingPathRequest).
template <typename Scalar>
SensingPath<Scalar> plan_sensing_path(const Vector3<Scalar>& target, Scalar radius, const Vector3<Scalar>& grasp,
                                      const Vector3<Scalar>& lift, const Vector3<Scalar>& drop, Scalar gamma,
                                      Scalar beta, int num_views, Scalar min_elevation = Scalar(0)) {
  SensingPathRequest<Scalar> request;
  request.target = target;
  request.radius = radius;
  request.grasp = grasp;
  request.lift = lift;
  request.drop = drop;
  request.gamma = gamma;
  request.beta = beta;
  request.num_views = num_views;
  request.min_elevation = min_elevation;
  return plan_sensing_path(request);
}

}  // namespace binpick::active_vision
