#pragma once
// Analytic scenes for the registration tests: a plane, oriented boxes and capped cylinders, ray-cast
// exactly into depth images of a pinhole camera placed anywhere in the scene frame.
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include <Eigen/Geometry>
#include <rapidcheck.h>

#include "binpick/core.hpp"
#include "test_support.hpp"

namespace binpick::test {

struct OrientedBox {
  Eigen::Isometry3d T_scene_box = Eigen::Isometry3d::Identity();
  Eigen::Vector3d half = Eigen::Vector3d::Constant(0.02);
};
struct Cylinder {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero(), axis = Eigen::Vector3d::UnitZ();
  double radius = 0.02, half_length = 0.03;
};
struct PlaneSurface {
  Eigen::Vector3d point = Eigen::Vector3d(0, 0, 0.32), normal = Eigen::Vector3d(0, 0, -1);
};

struct AnalyticScene {
  std::vector<PlaneSurface> planes;
  std::vector<OrientedBox> boxes;
  std::vector<Cylinder> cylinders;

  static constexpr double inf = std::numeric_limits<double>::infinity();

  double intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d) const {
    double best = inf;
    for (const auto& p : planes) {
      const double dn = d.dot(p.normal);
      if (std::abs(dn) < 1e-12) continue;
      const double t = (p.point - o).dot(p.normal) / dn;
      if (t > 1e-9 && t < best) best = t;
    }
    for (const auto& b : boxes) {
      const Eigen::Isometry3d T_box_scene = b.T_scene_box.inverse();
      const Eigen::Vector3d ob = T_box_scene * o, db = T_box_scene.linear() * d;
      double t0 = -inf, t1 = inf;
      bool hit = true;
      for (int a = 0; a < 3 && hit; ++a) {
        if (std::abs(db[a]) < 1e-15) {
          if (std::abs(ob[a]) > b.half[a]) hit = false;
          continue;
        }
        double ta = (-b.half[a] - ob[a]) / db[a], tb = (b.half[a] - ob[a]) / db[a];
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta);
        t1 = std::min(t1, tb);
        if (t0 > t1) hit = false;
      }
      if (hit && t0 > 1e-9 && t0 < best) best = t0;
    }
    for (const auto& c : cylinders) {
      // Side: |(x − c) − ((x − c)·a) a|² = r², |(x − c)·a| ≤ h; caps: planes at ±h.
      const Eigen::Vector3d w = o - c.centre;
      const Eigen::Vector3d dp = d - d.dot(c.axis) * c.axis, wp = w - w.dot(c.axis) * c.axis;
      const double A = dp.squaredNorm(), B = 2 * dp.dot(wp), C = wp.squaredNorm() - c.radius * c.radius;
      const double disc = B * B - 4 * A * C;
      if (A > 1e-15 && disc >= 0) {
        const double t = (-B - std::sqrt(disc)) / (2 * A);
        if (t > 1e-9 && t < best && std::abs((w + t * d).dot(c.axis)) <= c.half_length) best = t;
      }
      const double da = d.dot(c.axis);
      if (std::abs(da) > 1e-15)
        for (double s : {-1.0, 1.0}) {
          const double t = (s * c.half_length - w.dot(c.axis)) / da;
          if (t > 1e-9 && t < best && (w + t * d - s * c.half_length * c.axis).norm() <= c.radius) best = t;
        }
    }
    return best;
  }

  /// Depth image [m] (0 = nothing hit) of a pinhole camera at T_scene_camera.
  template <typename Scalar>
  DepthImage<Scalar> render(const PinholeCamera<Scalar>& cam, const Eigen::Isometry3d& T_scene_camera) const {
    DepthImage<Scalar> img(cam.width(), cam.height());
    for (int v = 0; v < cam.height(); ++v)
      for (int u = 0; u < cam.width(); ++u) {
        const Eigen::Vector3d dc((u - double(cam.cx())) / double(cam.fx()), (v - double(cam.cy())) / double(cam.fy()), 1.0);
        const double t = intersect(T_scene_camera.translation(), T_scene_camera.linear() * dc);
        if (t < 2.0) img.at(u, v) = Scalar(t);  // depth = t since dc.z() = 1
      }
    return img;
  }
};

inline Eigen::Matrix3d random_rotation(double max_angle) {
  Eigen::Vector3d axis(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1));
  if (axis.norm() < 1e-3) axis = Eigen::Vector3d::UnitX();
  return Eigen::AngleAxisd(uniform(-max_angle, max_angle), axis.normalized()).toRotationMatrix();
}

/// random_scene()'s pile at the case's own size (see there).
inline AnalyticScene random_scene_at_drawn_size() {
  AnalyticScene s;
  PlaneSurface floor;
  floor.normal = random_rotation(25 * M_PI / 180) * Eigen::Vector3d(0, 0, -1);
  floor.point = Eigen::Vector3d(0, 0, uniform(0.30, 0.34));
  s.planes.push_back(floor);
  const int boxes = *rc::gen::inRange(3, 5), cylinders = *rc::gen::inRange(0, 3);
  const double slot0 = uniform(0, 2 * M_PI);
  for (int i = 0; i < boxes; ++i) {
    OrientedBox b;
    b.half = Eigen::Vector3d(uniform(0.02, 0.04), uniform(0.02, 0.04), uniform(0.02, 0.03));
    // Per-box offsets keep the boxes' faces apart even when the generated values shrink to equal.
    const double tilt_dir = uniform(0, M_PI) + 1.3 * i;
    const Eigen::Vector3d tilt_axis(std::cos(tilt_dir), std::sin(tilt_dir), 0);
    b.T_scene_box.linear() = Eigen::AngleAxisd(uniform(-M_PI, M_PI) + 2.1 * i, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
                             Eigen::AngleAxisd(uniform(20, 40) * M_PI / 180, tilt_axis.normalized()).toRotationMatrix();
    const double slot = slot0 + 2 * M_PI * i / boxes, radius = uniform(0.04, 0.07);
    b.T_scene_box.translation() =
        Eigen::Vector3d(radius * std::cos(slot), 0.75 * radius * std::sin(slot), floor.point.z() - 0.02);
    s.boxes.push_back(b);
  }
  for (int i = 0; i < cylinders; ++i) {
    Cylinder c;
    c.centre = Eigen::Vector3d(uniform(-0.08, 0.08), uniform(-0.06, 0.06), floor.point.z() - 0.025);
    c.axis = random_rotation(M_PI) * Eigen::Vector3d::UnitZ();
    c.radius = uniform(0.01, 0.025);
    c.half_length = uniform(0.02, 0.05);
    s.cylinders.push_back(c);
  }
  return s;
}

/// A bin-picking-like scene in front of a camera at the scene origin looking along +z: a floor about
/// 0.32 m away (tilted up to 25°), 3–4 boxes on it and 0–2 cylinders. The boxes sit in different
/// slots around the image centre and are tilted by 20°–40° so that their side faces show: the scene
/// constrains all six degrees of freedom (a lone box seen from straight above would not).
///
/// Drawn at rapidcheck's nominal size whatever the case's size: a property's first cases run at size
/// 0 and grow by one per 10 discards, and size-scaled draws then take only the low end of each range.
/// Those piles (floor tilted -25°, boxes at 20°, small radii) are nearly one surface at 2 mm pixels:
/// under Clang's argument order one seed (1276531261019345736, RC_PARAMS max_success=10) discarded
/// every one of 100 cases as unobservable and the properties gave up. `uniform` now draws at the
/// nominal size itself (test_support.hpp); this keeps the box and cylinder counts there too.
/// Shrinking is unchanged.
inline AnalyticScene random_scene() {
  return *rc::gen::resize(rc::kNominalSize, rc::gen::exec([] { return random_scene_at_drawn_size(); }));
}

/// The test camera: 160k × 120k pixels, about 56° × 43° field of view whatever k (>= 1): a pixel
/// spans 2 mm / k at 0.3 m. k = 1 keeps most properties cheap; k = 2 is closer to a real sensor
/// (640 × 480 over the same view spans 0.5 mm).
template <typename Scalar>
PinholeCamera<Scalar> test_camera(int k = 1) {
  if (k < 1) throw std::invalid_argument("test_camera: k must be >= 1");
  return PinholeCamera<Scalar>(Scalar(150 * k), Scalar(150 * k), Scalar((160 * k - 1) / 2.0), Scalar((120 * k - 1) / 2.0),
                               160 * k, 120 * k);
}

/// The test camera that rendered `depth` (its width tells k).
template <typename Scalar>
PinholeCamera<Scalar> test_camera_of(const DepthImage<Scalar>& depth) {
  if (depth.width() % 160 != 0 || depth.height() * 4 != depth.width() * 3)
    throw std::invalid_argument("test_camera_of: depth is not a test_camera image");
  return test_camera<Scalar>(depth.width() / 160);
}

/// Translation [m] and rotation [rad] of A B⁻¹ (the error of A against B).
template <typename Scalar>
std::pair<double, double> pose_error(const Isometry3<Scalar>& A, const Isometry3<Scalar>& B) {
  const Eigen::Isometry3d E = A.template cast<double>() * B.template cast<double>().inverse();
  return {E.translation().norm(), rotation_angle<double>(E)};
}

}  // namespace binpick::test
