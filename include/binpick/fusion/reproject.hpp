#pragma once
/// \file reproject.hpp
/// Reprojection of one depth view into another camera (paper Alg. 1, line 1; Fig. 4): every valid
/// pixel of the source view is backprojected, moved by `T_target_source`, projected into the target
/// camera and z-tested — when several points land on one target pixel the nearest surface wins.
/// Source and target cameras may be different models.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <type_traits>
#include <vector>

#include "binpick/core/camera_model.hpp"
#include "binpick/core/depth_image.hpp"
#include "binpick/core/detail/simd.hpp"
#include "binpick/core/pose.hpp"
#include "binpick/core/ray_table.hpp"

namespace binpick {
namespace detail {
BINPICK_SIMD_BEGIN

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

/// Decodes `w` depths of one row of a view to metres into `out`: a valid depth (finite, > 0) as it
/// is, any other as `invalid`. Returns the row's valid count. Branch-free (& not &&), so it vectorizes.
template <typename Scalar, typename T>
BINPICK_SIMD_INLINE std::size_t decode_row(const T* __restrict row, int w, Scalar scale, Scalar invalid,
                                           Scalar* __restrict out) {
  const Scalar inf = std::numeric_limits<Scalar>::infinity();
  std::size_t valid = 0;
  for (int u = 0; u < w; ++u) {
    const Scalar z = Scalar(row[u]) * scale;
    const bool ok = (z > Scalar(0)) & (z < inf);
    out[u] = ok ? z : invalid;
    valid += ok;
  }
  return valid;
}

/// The pinhole-target case of reproject_rows with packs of `Bytes` (inlined into simd_call's choice).
/// `PerPixelY`: the rays are not separable (rays.y holds one y per pixel, not one per row); a template
/// argument, not a test in the loop, which cost 8 % at 128-bit packs.
template <typename Scalar, typename T, int Bytes, bool PerPixelY>
BINPICK_SIMD_INLINE std::size_t reproject_rows_pinhole(const DepthImageView<Scalar>& source, const RayTable<Scalar>& rays,
                                                       const Isometry3<Scalar>& T_target_source,
                                                       const PinholeCamera<Scalar>& target, Scalar* plane, int row_begin,
                                                       int row_end) {
  const int w = source.width();
  // Homogeneous pixel h = z * (M r) + m with M = K_t R, m = K_t t and r = (x/z, y/z, 1). Per row,
  // first a branch-free pass (vectorized across pixels, decoding the row as it goes) computes each
  // pixel's target index — invalid points get the index `none`, one past the image — then a scatter
  // pass does the z-test.
  Matrix3<Scalar> K = Matrix3<Scalar>::Identity();
  K(0, 0) = target.fx();
  K(1, 1) = target.fy();
  K(0, 2) = target.cx();
  K(1, 2) = target.cy();
  const Matrix3<Scalar> M = K * T_target_source.linear();
  const Vector3<Scalar> m = K * T_target_source.translation();
  const int tw = target.width(), th = target.height();
  const Scalar umax = Scalar(tw) - Scalar(0.5), vmax = Scalar(th) - Scalar(0.5);
  using P = Pack<Scalar, Bytes>;
  using V = typename P::type;
  using Mask = decltype(V() < V());  // signed integer lanes as wide as Scalar
  using Index = typename std::remove_reference<decltype(Mask()[0])>::type;
  const Index none = Index(std::size_t(tw) * std::size_t(th));
  const int wpad = (w + P::size - 1) / P::size * P::size;
  const int wfull = w / P::size * P::size;  // packs read straight from the row; the rest from `tail`
  std::vector<Index> index(static_cast<std::size_t>(wpad));
  std::vector<Scalar> depth(static_cast<std::size_t>(wpad));
  T tail[P::size];
  Scalar spare[64];  // the scatter's sink for invalid points
  std::fill(spare, spare + 64, Scalar(0));
  const V m00 = P::splat(M(0, 0)), m10 = P::splat(M(1, 0)), m20 = P::splat(M(2, 0));
  const V mx = P::splat(m.x()), my = P::splat(m.y()), mz = P::splat(m.z());
  const V vzero = P::splat(Scalar(0)), vone = P::splat(Scalar(1)), vhalf = P::splat(Scalar(0.5));
  const V vumax = P::splat(umax), vvmax = P::splat(vmax), vmhalf = P::splat(Scalar(-0.5));
  const V vtw1 = P::splat(Scalar(tw - 1)), vth1 = P::splat(Scalar(th - 1));
  const V m01 = P::splat(M(0, 1)), m11 = P::splat(M(1, 1)), m21 = P::splat(M(2, 1));
  Mask valid_lanes = Mask();  // valid pixels per lane (from zero)
  for (int v = row_begin; v < row_end; ++v) {
    const T* row = source.template row<T>(v);
    // Separable rays: y is the row's, so M r's y and constant terms are one per row (b*0); otherwise
    // each pixel has its own y (ry) and the row terms are the constant ones.
    const Scalar* rx = rays.x.data() + (PerPixelY ? std::size_t(v) * w : 0);  // padded by kRayPad
    const Scalar* ry = PerPixelY ? rays.y.data() + std::size_t(v) * w : nullptr;
    const Scalar yr = PerPixelY ? Scalar(0) : rays.y[std::size_t(v)];
    const V bx0 = P::splat(M(0, 1) * yr + M(0, 2)), by0 = P::splat(M(1, 1) * yr + M(1, 2)),
            bz0 = P::splat(M(2, 1) * yr + M(2, 2));
    if (wfull < w) {  // the last partial pack is read from a zero-padded copy (0 = invalid)
      std::fill(tail, tail + P::size, T(0));
      std::copy(row + wfull, row + w, tail);
    }
    for (int u = 0; u < wpad; u += P::size) {
      Mask z_ok;
      const V z = decode_pack<Scalar, Bytes>(u < wfull ? row + u : tail, source.metres_per_unit(), z_ok);
      valid_lanes -= z_ok;  // a set lane is -1
      const V x = P::load(rx + u);
      V bx = bx0, by = by0, bz = bz0;
      if constexpr (PerPixelY) {
        const V y = P::load(ry + u);
        bx += m01 * y, by += m11 * y, bz += m21 * y;
      }
      const V ax = m00 * x + bx, ay = m10 * x + by, az = m20 * x + bz;
      const V hz = z * az + mz;
      const auto in_front = hz > vzero;
      const V inv = vone / P::select(in_front, hz, vone);
      const V pu = (z * ax + mx) * inv;
      const V pv = (z * ay + my) * inv;
      const auto ok = z_ok & in_front & (pu >= vmhalf) & (pu < vumax) & (pv >= vmhalf) & (pv < vvmax);
      // Truncation of (p + 0.5) rounds to the nearest pixel for p >= -0.5; clamped first so the
      // conversion is defined for any value (NaN fails `>= 0` and becomes 0: both index lanes are
      // computed before the select, and an INT_MIN lane would overflow in iv * tw).
      V fu = pu + vhalf, fv = pv + vhalf;
      fu = P::select(fu >= vzero, P::select(fu > vtw1, vtw1, fu), vzero);
      fv = P::select(fv >= vzero, P::select(fv > vth1, vth1, fv), vzero);
      const Mask iu = __builtin_convertvector(fu, Mask), iv = __builtin_convertvector(fv, Mask);
      const Mask idx = ok ? Mask(iv * Index(tw) + iu) : Mask(iu * Index(0) + none);
      std::memcpy(&index[std::size_t(u)], &idx, sizeof idx);
      P::store(&depth[std::size_t(u)], hz);
    }
    // Scatter with the z-test, without a branch: invalid points go to one of 64 spare slots (one
    // shared slot made a read-min-write chain through one address, 2-3 ms a view at 1280 x 1024).
    // On simulated metal views, whose holes come in runs, a skip branch was as fast (3 % either way
    // by ISA); the sink does not depend on the sensor's hole pattern.
    for (int u = 0; u < w; ++u) {
      const Index i = index[std::size_t(u)];
      Scalar* p = i == none ? spare + (u & 63) : plane + i;
      *p = std::min(*p, depth[std::size_t(u)]);  // branch-free: z-test outcomes are random
    }
  }
  std::size_t valid = 0;
  for (int l = 0; l < P::size; ++l) valid += std::size_t(valid_lanes[l]);
  return valid;
}

/// Scatters the valid pixels of `source` into `plane` (target-sized, +inf = empty) with a z-test. `plane` is not cleared
/// here. Rows [row_begin, row_end) of the source.
/// Returns the number of valid source pixels.
template <typename Scalar, typename TargetCamera, typename T>
std::size_t reproject_rows(const DepthImageView<Scalar>& source, const RayTable<Scalar>& rays,
                    const Isometry3<Scalar>& T_target_source, const TargetCamera& target, Scalar* plane,
                    int row_begin, int row_end) {
  std::size_t valid = 0;
  if constexpr (std::is_same<TargetCamera, PinholeCamera<Scalar>>::value) {
    simd_call([&](auto bytes) BINPICK_SIMD_INLINE_LAMBDA {
      constexpr int B = decltype(bytes)::value;
      valid = rays.separable
                  ? reproject_rows_pinhole<Scalar, T, B, false>(source, rays, T_target_source, target, plane, row_begin, row_end)
                  : reproject_rows_pinhole<Scalar, T, B, true>(source, rays, T_target_source, target, plane, row_begin, row_end);
    });
  } else {
    const int w = source.width();
    const Scalar scale = source.metres_per_unit();
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

/// Reprojects a whole view into `plane` (width * height elements, all set to +inf first); returns
/// its valid pixel count.
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

BINPICK_SIMD_END
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
  std::vector<Scalar> plane(out.storage().size());
  const auto rays = detail::RayTable<Scalar>::make(source_camera);
  detail::reproject_to_plane(source, rays, T_target_source, target_camera, plane.data());
  for (std::size_t i = 0; i < out.storage().size(); ++i)
    out.storage()[i] = plane[i] == std::numeric_limits<Scalar>::infinity() ? Scalar(0) : plane[i];
  return out;
}

}  // namespace binpick
