#pragma once
/// \file mesh.hpp
/// Triangle meshes of the simulated parts and bin, and the generators that build them in code:
/// surfaces of revolution (screws), extruded rings (nuts, couplers) and extruded star-shaped polygons
/// (connectors). Every generated mesh is closed, with triangles wound counter-clockwise seen from
/// outside, so an inside test by ray parity works on it. Units: metres.
///
/// Each triangle corner carries its own shading normal: flat faces repeat the face normal, curved
/// surfaces carry the analytic normal, so specular highlights move smoothly over a shank and the
/// spread of the corner normals measures how curved a reflector is (the ghost model needs it).

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Geometry>

#include "binpick/core/errors.hpp"
#include "binpick/core/pose.hpp"

namespace binpick::sim {

template <typename Scalar>
struct TriangleMesh {
  using Vec3 = Vector3<Scalar>;
  std::vector<Vec3> vertices;                 ///< [m]
  std::vector<Eigen::Vector3i> triangles;     ///< vertex indices, counter-clockwise seen from outside
  std::vector<Vec3> corner_normals;           ///< 3 per triangle (unit), in triangle corner order

  std::size_t size() const { return triangles.size(); }

  /// Appends a triangle with explicit corner normals.
  void add(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& na, const Vec3& nb, const Vec3& nc) {
    const int i = int(vertices.size());
    vertices.push_back(a);
    vertices.push_back(b);
    vertices.push_back(c);
    triangles.emplace_back(i, i + 1, i + 2);
    corner_normals.push_back(na.normalized());
    corner_normals.push_back(nb.normalized());
    corner_normals.push_back(nc.normalized());
  }
  /// Appends a flat triangle (corner normals = face normal); degenerate triangles are skipped.
  void add_flat(const Vec3& a, const Vec3& b, const Vec3& c) {
    const Vec3 n = (b - a).cross(c - a);
    if (!(n.norm() > Scalar(0))) return;
    add(a, b, c, n, n, n);
  }
  /// Appends another mesh transformed by T_this_other.
  void append(const TriangleMesh& other, const Isometry3<Scalar>& T_this_other) {
    const int base = int(vertices.size());
    for (const Vec3& v : other.vertices) vertices.push_back(T_this_other * v);
    for (const auto& t : other.triangles) triangles.emplace_back(t.x() + base, t.y() + base, t.z() + base);
    for (const Vec3& n : other.corner_normals) corner_normals.push_back(T_this_other.linear() * n);
  }
  /// Axis-aligned bounds (min, max); zeros for an empty mesh.
  std::pair<Vec3, Vec3> bounds() const {
    if (vertices.empty()) return {Vec3::Zero(), Vec3::Zero()};
    Vec3 lo = vertices.front(), hi = vertices.front();
    for (const Vec3& v : vertices) {
      lo = lo.cwiseMin(v);
      hi = hi.cwiseMax(v);
    }
    return {lo, hi};
  }
};

namespace detail {

/// Surface of revolution about +z of a profile (r, z) [m] that starts and ends on the axis (r = 0),
/// ordered so the solid lies to its left (bottom cap outward, side upward, top cap inward).
/// Normals are smooth around the axis and flat along the profile.
template <typename Scalar>
TriangleMesh<Scalar> lathe(const std::vector<Vector2<Scalar>>& profile, int segments) {
  using V3 = Vector3<Scalar>;
  require(profile.size() >= 3, "profile", "needs at least 3 points");
  require(segments >= 3, "segments", "must be >= 3");
  TriangleMesh<Scalar> m;
  const Scalar two_pi = Scalar(2 * M_PI);
  for (std::size_t i = 0; i + 1 < profile.size(); ++i) {
    const Vector2<Scalar> a = profile[i], b = profile[i + 1];
    const Scalar dr = b.x() - a.x(), dz = b.y() - a.y();
    const Scalar nr = dz, nz = -dr;  // outward normal of the profile segment (solid on the left)
    for (int j = 0; j < segments; ++j) {
      const Scalar p0 = two_pi * Scalar(j) / Scalar(segments), p1 = two_pi * Scalar(j + 1) / Scalar(segments);
      const Scalar c0 = std::cos(p0), s0 = std::sin(p0), c1 = std::cos(p1), s1 = std::sin(p1);
      const V3 A(a.x() * c0, a.x() * s0, a.y()), B(a.x() * c1, a.x() * s1, a.y());
      const V3 C(b.x() * c1, b.x() * s1, b.y()), D(b.x() * c0, b.x() * s0, b.y());
      const V3 n0(nr * c0, nr * s0, nz), n1(nr * c1, nr * s1, nz);
      if ((B - A).norm() > Scalar(0)) m.add(A, B, C, n0, n1, n1);  // skipped where the ring is the axis
      if ((C - D).norm() > Scalar(0)) m.add(A, C, D, n0, n1, n0);
    }
  }
  return m;
}

/// Extrusion along +z over [0, height] of a ring between an outer and an inner closed polyline
/// (both counter-clockwise, same number of points, inner[j] facing outer[j]). `smooth_outer` /
/// `smooth_inner` give radial corner normals (round walls) instead of flat ones (hexagon walls).
template <typename Scalar>
TriangleMesh<Scalar> extrude_ring(const std::vector<Vector2<Scalar>>& outer, const std::vector<Vector2<Scalar>>& inner,
                                  Scalar height, bool smooth_outer, bool smooth_inner) {
  using V3 = Vector3<Scalar>;
  require(outer.size() >= 3 && outer.size() == inner.size(), "outer", "needs >= 3 points, as many as inner");
  require(height > Scalar(0), "height", "must be > 0");
  TriangleMesh<Scalar> m;
  const std::size_t n = outer.size();
  const V3 up(0, 0, 1);
  for (std::size_t j = 0; j < n; ++j) {
    const std::size_t k = (j + 1) % n;
    const V3 o0(outer[j].x(), outer[j].y(), 0), o1(outer[k].x(), outer[k].y(), 0);
    const V3 i0(inner[j].x(), inner[j].y(), 0), i1(inner[k].x(), inner[k].y(), 0);
    const V3 h = up * height;
    // Outer wall (normal away from the axis).
    const V3 fo = (o1 - o0).cross(up);
    const V3 no0 = smooth_outer ? V3(o0.x(), o0.y(), 0) : fo, no1 = smooth_outer ? V3(o1.x(), o1.y(), 0) : fo;
    m.add(o0, o1, o1 + h, no0, no1, no1);
    m.add(o0, o1 + h, o0 + h, no0, no1, no0);
    // Inner wall (normal toward the axis): reversed winding.
    const V3 fi = up.cross(i1 - i0);
    const V3 ni0 = smooth_inner ? V3(-i0.x(), -i0.y(), 0) : fi, ni1 = smooth_inner ? V3(-i1.x(), -i1.y(), 0) : fi;
    m.add(i1, i0, i0 + h, ni1, ni0, ni0);
    m.add(i1, i0 + h, i1 + h, ni1, ni0, ni1);
    // Caps.
    m.add_flat(o0 + h, o1 + h, i1 + h);
    m.add_flat(o0 + h, i1 + h, i0 + h);
    m.add_flat(o1, o0, i0);
    m.add_flat(o1, i0, i1);
  }
  return m;
}

/// Extrusion along +z over [-height/2, height/2] of a polygon (counter-clockwise) that is star-shaped
/// about `centre`: caps are fans from the centre. Flat normals.
template <typename Scalar>
TriangleMesh<Scalar> extrude_star(const std::vector<Vector2<Scalar>>& polygon, const Vector2<Scalar>& centre,
                                  Scalar height) {
  using V3 = Vector3<Scalar>;
  require(polygon.size() >= 3, "polygon", "needs at least 3 points");
  require(height > Scalar(0), "height", "must be > 0");
  TriangleMesh<Scalar> m;
  const Scalar hz = height / 2;
  const V3 ct(centre.x(), centre.y(), hz), cb(centre.x(), centre.y(), -hz);
  for (std::size_t j = 0; j < polygon.size(); ++j) {
    const auto& a = polygon[j];
    const auto& b = polygon[(j + 1) % polygon.size()];
    const V3 a0(a.x(), a.y(), -hz), b0(b.x(), b.y(), -hz), a1(a.x(), a.y(), hz), b1(b.x(), b.y(), hz);
    m.add_flat(a0, b0, b1);
    m.add_flat(a0, b1, a1);
    m.add_flat(ct, a1, b1);
    m.add_flat(cb, b0, a0);
  }
  return m;
}

/// Points of a circle of radius r [m] (counter-clockwise, n points starting at angle 0).
template <typename Scalar>
std::vector<Vector2<Scalar>> circle_points(Scalar r, int n) {
  std::vector<Vector2<Scalar>> p;
  for (int j = 0; j < n; ++j) {
    const Scalar a = Scalar(2 * M_PI) * Scalar(j) / Scalar(n);
    p.emplace_back(r * std::cos(a), r * std::sin(a));
  }
  return p;
}

/// Points of a regular hexagon with apothem `a` [m] (corners at 0°, 60°, …), sampled at the same
/// angles as circle_points(·, n) with n a multiple of 6, so it pairs with a circular hole.
template <typename Scalar>
std::vector<Vector2<Scalar>> hexagon_points(Scalar apothem, int n) {
  std::vector<Vector2<Scalar>> p;
  const Scalar sixty = Scalar(M_PI / 3);
  for (int j = 0; j < n; ++j) {
    const Scalar a = Scalar(2 * M_PI) * Scalar(j) / Scalar(n);
    const Scalar local = std::fmod(a, sixty) - sixty / 2;
    const Scalar r = apothem / std::cos(local);
    p.emplace_back(r * std::cos(a), r * std::sin(a));
  }
  return p;
}

}  // namespace detail

/// True when p lies inside the closed mesh (ray parity along a fixed, slightly skewed direction;
/// brute force — for tests and validation, not for rendering).
template <typename Scalar>
bool point_inside_mesh(const TriangleMesh<Scalar>& mesh, const Vector3<Scalar>& p) {
  const Vector3<double> d = Vector3<double>(0.2113, 0.3771, 0.9017).normalized();
  const Vector3<double> o = p.template cast<double>();
  int crossings = 0;
  for (const auto& t : mesh.triangles) {
    const Vector3<double> a = mesh.vertices[t.x()].template cast<double>(), b = mesh.vertices[t.y()].template cast<double>(),
                          c = mesh.vertices[t.z()].template cast<double>();
    const Vector3<double> e1 = b - a, e2 = c - a, q = d.cross(e2);
    const double det = e1.dot(q);
    if (std::abs(det) < 1e-18) continue;
    const double inv = 1.0 / det;
    const Vector3<double> s = o - a;
    const double u = s.dot(q) * inv;
    if (u < 0 || u > 1) continue;
    const Vector3<double> r = s.cross(e1);
    const double v = d.dot(r) * inv;
    if (v < 0 || u + v > 1) continue;
    if (e2.dot(r) * inv > 0) ++crossings;
  }
  return crossings % 2 == 1;
}

}  // namespace binpick::sim
