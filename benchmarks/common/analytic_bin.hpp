#pragma once
// The analytic bin both registration benchmarks register on: six tilted boxes on a floor tilted 10°,
// seen from about 0.3 m (one scene, so bench_registration and bench_peers measure the same clouds).
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Geometry>

#include "binpick/core/camera_model.hpp"
#include "binpick/core/depth_image.hpp"

namespace binpick::bench {

struct Box {
  Eigen::Isometry3d T_scene_box;
  Eigen::Vector3d half;
};

// Distance along o + t d to the floor plane z = 0.32 (tilted 10°) or a box, +inf if none.
inline double intersect(const std::vector<Box>& boxes, const Eigen::Vector3d& n_floor, const Eigen::Vector3d& o,
                 const Eigen::Vector3d& d) {
  double best = std::numeric_limits<double>::infinity();
  const double dn = d.dot(n_floor);
  if (std::abs(dn) > 1e-12) {
    const double t = (Eigen::Vector3d(0, 0, 0.32) - o).dot(n_floor) / dn;
    if (t > 0) best = t;
  }
  for (const Box& b : boxes) {
    const Eigen::Isometry3d Ti = b.T_scene_box.inverse();
    const Eigen::Vector3d ob = Ti * o, db = Ti.linear() * d;
    double t0 = -1e300, t1 = 1e300;
    bool hit = true;
    for (int a = 0; a < 3 && hit; ++a) {
      if (std::abs(db[a]) < 1e-15) {
        hit = std::abs(ob[a]) <= b.half[a];
        continue;
      }
      double ta = (-b.half[a] - ob[a]) / db[a], tb = (b.half[a] - ob[a]) / db[a];
      if (ta > tb) std::swap(ta, tb);
      t0 = std::max(t0, ta);
      t1 = std::min(t1, tb);
      hit = t0 <= t1;
    }
    if (hit && t0 > 0 && t0 < best) best = t0;
  }
  return best;
}

inline DepthImage<float> render_analytic_bin(const PinholeCamera<float>& cam, const Eigen::Isometry3d& T_scene_camera) {
  std::vector<Box> boxes;
  for (int i = 0; i < 6; ++i) {
    Box b;
    const double a = 2 * M_PI * i / 6;
    b.T_scene_box = Eigen::Isometry3d::Identity();
    b.T_scene_box.linear() = (Eigen::AngleAxisd(a * 1.7, Eigen::Vector3d::UnitZ()) *
                              Eigen::AngleAxisd(0.4, Eigen::Vector3d(std::cos(a), std::sin(a), 0)))
                                 .toRotationMatrix();
    b.T_scene_box.translation() = Eigen::Vector3d(0.07 * std::cos(a), 0.05 * std::sin(a), 0.3);
    b.half = Eigen::Vector3d(0.03, 0.02, 0.015);
    boxes.push_back(b);
  }
  const Eigen::Vector3d n_floor = Eigen::AngleAxisd(0.17, Eigen::Vector3d::UnitX()) * Eigen::Vector3d(0, 0, -1);
  DepthImage<float> img(cam.width(), cam.height());
  for (int v = 0; v < cam.height(); ++v)
    for (int u = 0; u < cam.width(); ++u) {
      const Eigen::Vector3d dc((u - double(cam.cx())) / double(cam.fx()), (v - double(cam.cy())) / double(cam.fy()), 1);
      const double t = intersect(boxes, n_floor, T_scene_camera.translation(), T_scene_camera.linear() * dc);
      if (t < 2) img.at(u, v) = float(t);
    }
  return img;
}

}  // namespace binpick::bench
