#pragma once
/// \file box_scene.hpp
/// An analytic scene (a floor plane and axis-aligned boxes, base frame z up) ray-cast into exact depth
/// images: ground truth for fusion and registration tests, benchmarks and the quick demo.
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Geometry>

#include "binpick/core.hpp"

namespace binpick::sim {

struct Box {
  Eigen::Vector3d lo, hi;  // axis-aligned, base frame [m]
};

struct BoxScene {
  double floor_z = 0.0;  // plane z = floor_z
  std::vector<Box> boxes;

  /// Distance along base-frame ray o + t d to the first surface, or +inf.
  double intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d) const {
    double best = std::numeric_limits<double>::infinity();
    if (std::abs(d.z()) > 1e-12) {
      const double t = (floor_z - o.z()) / d.z();
      if (t > 0) best = t;
    }
    for (const Box& b : boxes) {
      double t0 = 0, t1 = best;
      bool hit = true;
      for (int a = 0; a < 3 && hit; ++a) {
        if (std::abs(d[a]) < 1e-15) {
          if (o[a] < b.lo[a] || o[a] > b.hi[a]) hit = false;
          continue;
        }
        double ta = (b.lo[a] - o[a]) / d[a], tb = (b.hi[a] - o[a]) / d[a];
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta);
        t1 = std::min(t1, tb);
        if (t0 > t1) hit = false;
      }
      if (hit && t0 > 0 && t0 < best) best = t0;
    }
    return best;
  }

  /// Exact depth image [m] (0 where nothing is hit) seen by `camera` at `T_base_camera`.
  template <typename Scalar, typename Camera>
  DepthImage<Scalar> render(const Camera& camera, const Isometry3<double>& T_base_camera) const {
    DepthImage<Scalar> img(camera.width(), camera.height());
    const Eigen::Matrix3d R = T_base_camera.linear();
    const Eigen::Vector3d o = T_base_camera.translation();
    for (int v = 0; v < camera.height(); ++v)
      for (int u = 0; u < camera.width(); ++u) {
        const auto p = camera.backproject(Scalar(u), Scalar(v), Scalar(1));
        const Eigen::Vector3d ray_camera(double(p.x()), double(p.y()), 1.0);  // z = 1: t is the depth
        const double t = intersect(o, R * ray_camera);
        img.at(u, v) = std::isfinite(t) ? Scalar(t) : Scalar(0);
      }
    return img;
  }
};

/// A camera at `eye` looking at `target` (base frame), x axis as close to base x as possible.
inline Isometry3<double> look_at(const Eigen::Vector3d& eye, const Eigen::Vector3d& target) {
  const Eigen::Vector3d z = (target - eye).normalized();
  Eigen::Vector3d x = Eigen::Vector3d::UnitX() - z * z.x();
  if (x.norm() < 1e-6) x = Eigen::Vector3d::UnitY() - z * z.y();
  x.normalize();
  const Eigen::Vector3d y = z.cross(x);
  Isometry3<double> T = Isometry3<double>::Identity();
  T.linear().col(0) = x;
  T.linear().col(1) = y;
  T.linear().col(2) = z;
  T.translation() = eye;
  return T;
}

/// A small bin-like scene: floor and a few boxes a few centimetres tall.
inline BoxScene boxes_scene() {
  BoxScene s;
  s.boxes.push_back({Eigen::Vector3d(-0.06, -0.04, 0.0), Eigen::Vector3d(-0.01, 0.02, 0.03)});
  s.boxes.push_back({Eigen::Vector3d(0.02, -0.05, 0.0), Eigen::Vector3d(0.07, -0.01, 0.05)});
  s.boxes.push_back({Eigen::Vector3d(0.00, 0.03, 0.0), Eigen::Vector3d(0.05, 0.07, 0.02)});
  return s;
}

/// n camera poses on a short arc 0.3 m above the origin, looking at it (as the sensing path does).
inline std::vector<Isometry3<double>> arc_poses(int n, double arc_angle_rad = 0.12) {
  std::vector<Isometry3<double>> poses;
  for (int i = 0; i < n; ++i) {
    const double a = n > 1 ? -arc_angle_rad / 2 + arc_angle_rad * i / (n - 1) : 0.0;
    const Eigen::Vector3d eye(0.3 * std::sin(a), 0.01 * i, 0.3 * std::cos(a));
    poses.push_back(look_at(eye, Eigen::Vector3d(0, 0, 0)));
  }
  return poses;
}

}  // namespace binpick::sim
