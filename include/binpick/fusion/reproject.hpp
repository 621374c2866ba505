#pragma once
/// \file reproject.hpp
/// Reprojection of one depth view into another camera (paper Alg. 1, line 1; Fig. 4): every valid
/// pixel of the source view is backprojected, moved by `T_target_source`, projected into the target
/// camera and z-tested — when several points land on one target pixel the nearest surface wins.
/// Source and target cameras may be different models.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <type_traits>
#include <vector>

#include "binpick/core/camera_model.hpp"
#include "binpick/core/depth_image.hpp"
#include "binpick/core/pose.hpp"

namespace binpick {
namespace detail {

/// Normalized ray (x/z, y/z) of every source pixel, computed once per camera so the per-pixel work is
/// independent of the lens model. Pinhole rays are separable (one x per column, one y per row).
template <typename Scalar>
struct RayTable {
  int width = 0, height = 0;
  bool separable = false;
  std::vector<Scalar> x, y;  // separable: x[width], y[height]; else x, y [width * height]

  template <typename Camera>
  static RayTable make(const Camera& camera) {
    RayTable t;
    t.width = camera.width();
    t.height = camera.height();
    if constexpr (std::is_same<Camera, PinholeCamera<Scalar>>::value) {
      t.separable = true;
      t.x.resize(std::size_t(t.width));
      t.y.resize(std::size_t(t.height));
      for (int u = 0; u < t.width; ++u) t.x[std::size_t(u)] = (Scalar(u) - camera.cx()) / camera.fx();
      for (int v = 0; v < t.height; ++v) t.y[std::size_t(v)] = (Scalar(v) - camera.cy()) / camera.fy();
    } else {
      const std::size_t n = std::size_t(t.width) * std::size_t(t.height);
      t.x.resize(n);
      t.y.resize(n);
      for (int v = 0; v < t.height; ++v)
        for (int u = 0; u < t.width; ++u) {
          const auto p = camera.backproject(Scalar(u), Scalar(v), Scalar(1));
          t.x[std::size_t(v) * t.width + u] = p.x();
          t.y[std::size_t(v) * t.width + u] = p.y();
        }
    }
    return t;
  }
};

/// Projection of a target-frame point to an integer pixel index, or -1. The pinhole model is folded
/// into the transform (its rows are K_target * [R | t]) so the inner loop has no optional and no call.
template <typename Scalar, typename Camera>
struct TargetProjector {
  const Camera* camera;
  Isometry3<Scalar> T;
  TargetProjector(const Camera& c, const Isometry3<Scalar>& T_target_source) : camera(&c), T(T_target_source) {}
  // Returns the flat pixel index and writes the target depth, or -1.
  long operator()(Scalar x, Scalar y, Scalar z, Scalar& depth_out) const {
    const Vector3<Scalar> p = T * Vector3<Scalar>(x, y, z);
    const auto px = camera->project(p);
    if (!px) return -1;
    depth_out = p.z();
    // project() guarantees -0.5 <= u < width - 0.5, so +0.5 and truncation round to a valid index.
    return long(px->y() + Scalar(0.5)) * camera->width() + long(px->x() + Scalar(0.5));
  }
};

/// Scatters the valid pixels of `source` into `plane` (target-sized, +inf = empty) with a z-test.
/// `plane` is not cleared here. Rows [row_begin, row_end) of the source.
/// Returns the number of valid source pixels.
template <typename Scalar, typename TargetCamera, typename T>
std::size_t reproject_rows(const DepthImageView<Scalar>& source, const RayTable<Scalar>& rays,
                    const Isometry3<Scalar>& T_target_source, const TargetCamera& target, Scalar* plane,
                    int row_begin, int row_end) {
  const int w = source.width();
  const Scalar scale = source.metres_per_unit();
  std::size_t valid = 0;
  if constexpr (std::is_same<TargetCamera, PinholeCamera<Scalar>>::value) {
    // Homogeneous pixel h = z * (M r) + m with M = K_t R, m = K_t t and r = (x/z, y/z, 1): per pixel
    // 6 multiply-adds, one division, the bounds test and the z-test.
    Matrix3<Scalar> K = Matrix3<Scalar>::Identity();
    K(0, 0) = target.fx();
    K(1, 1) = target.fy();
    K(0, 2) = target.cx();
    K(1, 2) = target.cy();
    const Matrix3<Scalar> M = K * T_target_source.linear();
    const Vector3<Scalar> m = K * T_target_source.translation();
    const int tw = target.width(), th = target.height();
    const Scalar umax = Scalar(tw) - Scalar(0.5), vmax = Scalar(th) - Scalar(0.5);
    for (int v = row_begin; v < row_end; ++v) {
      const T* row = source.template row<T>(v);
      const Scalar* rx = rays.separable ? rays.x.data() : rays.x.data() + std::size_t(v) * w;
      const Scalar* ry_row = rays.separable ? nullptr : rays.y.data() + std::size_t(v) * w;
      const Scalar ry_const = rays.separable ? rays.y[std::size_t(v)] : Scalar(0);
      for (int u = 0; u < w; ++u) {
        const Scalar z = Scalar(row[u]) * scale;
        if (!(z > Scalar(0) && z < std::numeric_limits<Scalar>::infinity())) continue;
        ++valid;
        const Scalar ry = ry_row ? ry_row[u] : ry_const;
        const Scalar ax = M(0, 0) * rx[u] + M(0, 1) * ry + M(0, 2);
        const Scalar ay = M(1, 0) * rx[u] + M(1, 1) * ry + M(1, 2);
        const Scalar az = M(2, 0) * rx[u] + M(2, 1) * ry + M(2, 2);
        const Scalar hz = z * az + m.z();
        if (!(hz > Scalar(0))) continue;
        const Scalar inv = Scalar(1) / hz;
        const Scalar pu = (z * ax + m.x()) * inv;
        const Scalar pv = (z * ay + m.y()) * inv;
        if (!(pu >= Scalar(-0.5) && pu < umax && pv >= Scalar(-0.5) && pv < vmax)) continue;
        const std::size_t idx = std::size_t(int(pv + Scalar(0.5))) * std::size_t(tw) + std::size_t(int(pu + Scalar(0.5)));
        if (hz < plane[idx]) plane[idx] = hz;
      }
    }
  } else {
    const TargetProjector<Scalar, TargetCamera> project(target, T_target_source);
    for (int v = row_begin; v < row_end; ++v) {
      const T* row = source.template row<T>(v);
      for (int u = 0; u < w; ++u) {
        const Scalar z = Scalar(row[u]) * scale;
        if (!(z > Scalar(0) && z < std::numeric_limits<Scalar>::infinity())) continue;
        ++valid;
        const std::size_t r = rays.separable ? std::size_t(u) : std::size_t(v) * w + u;
        const Scalar ry = rays.separable ? rays.y[std::size_t(v)] : rays.y[r];
        Scalar zt;
        const long idx = project(rays.x[r] * z, ry * z, z, zt);
        if (idx >= 0 && zt < plane[idx]) plane[idx] = zt;
      }
    }
  }
  return valid;
}

/// Reprojects a whole view into `plane` (filled with +inf first); returns its valid pixel count.
template <typename Scalar, typename TargetCamera>
std::size_t reproject_to_plane(const DepthImageView<Scalar>& source, const RayTable<Scalar>& rays,
                        const Isometry3<Scalar>& T_target_source, const TargetCamera& target, Scalar* plane) {
  std::fill(plane, plane + std::size_t(target.width()) * std::size_t(target.height()),
            std::numeric_limits<Scalar>::infinity());
  return source.dispatch([&](auto tag) {
    using T = decltype(tag);
    return reproject_rows<Scalar, TargetCamera, T>(source, rays, T_target_source, target, plane, 0, source.height());
  });
}

}  // namespace detail

/// Reprojects `source` (seen by `source_camera`) into `target_camera`, whose frame is reached by
/// `T_target_source` (maps source-camera points into the target camera). Returns a target-sized depth
/// image [m], 0 where no source point landed; the nearest surface wins on collisions.
/// Throws std::invalid_argument naming the argument for a source whose size differs from its camera or
/// a non-rigid / non-finite pose.
template <typename Scalar, typename SourceCamera, typename TargetCamera>
DepthImage<Scalar> reproject(const DepthImageView<Scalar>& source, const SourceCamera& source_camera,
                             const Isometry3<Scalar>& T_target_source, const TargetCamera& target_camera) {
  static_assert(is_camera_model<SourceCamera>::value && is_camera_model<TargetCamera>::value,
                "reproject: camera types must model the camera concept (core/camera_model.hpp)");
  require(source.width() == source_camera.width() && source.height() == source_camera.height(), "source",
          "image size differs from source_camera's");
  require_valid_pose(T_target_source, "T_target_source");
  DepthImage<Scalar> out(target_camera.width(), target_camera.height());
  const auto rays = detail::RayTable<Scalar>::make(source_camera);
  detail::reproject_to_plane(source, rays, T_target_source, target_camera, out.data());
  for (Scalar& d : out.storage())
    if (d == std::numeric_limits<Scalar>::infinity()) d = Scalar(0);
  return out;
}

}  // namespace binpick
