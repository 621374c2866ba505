#pragma once
/// \file ray_table.hpp
/// The normalized ray of every pixel of a camera, computed once: reprojection and backprojection of
/// whole images then cost products per pixel, not a call into the lens model.

#include <cstddef>
#include <type_traits>
#include <vector>

#include "binpick/core/camera_model.hpp"

namespace binpick {
namespace detail {

/// Extra elements at the end of ray tables so SIMD loads past the last pixel stay in bounds.
constexpr std::size_t kRayPad = 16;

/// Normalized ray (x/z, y/z) of every pixel, so the per-pixel work is independent of the lens model.
/// Pinhole rays are separable (one x per column, one y per row): the factors (u − cx) / fx and
/// (v − cy) / fy, the camera's own, so ray * z has the bits of camera.backproject(u, v, z).
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
      t.x.resize(std::size_t(t.width) + kRayPad);
      t.y.resize(std::size_t(t.height) + kRayPad);
      for (int u = 0; u < t.width; ++u) t.x[std::size_t(u)] = (Scalar(u) - camera.cx()) / camera.fx();
      for (int v = 0; v < t.height; ++v) t.y[std::size_t(v)] = (Scalar(v) - camera.cy()) / camera.fy();
    } else {
      const std::size_t n = std::size_t(t.width) * std::size_t(t.height);
      t.x.resize(n + kRayPad);
      t.y.resize(n + kRayPad);
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

}  // namespace detail
}  // namespace binpick
