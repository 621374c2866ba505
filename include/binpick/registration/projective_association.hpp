#pragma once
/// \file projective_association.hpp
/// Projective data association (see correspondence.hpp for the concept): a source point, already in
/// the target camera frame, is projected into the target depth image and partnered with the closest
/// valid target point in a (2r+1)×(2r+1) pixel window around its pixel. No tree to build and O(1) per
/// point — the fast path when the target is a depth image. Only surfaces the target camera sees can
/// be partners, which is what registering views of the same scene needs.

#include <cmath>
#include <cstddef>
#include <cstring>
#include <limits>
#include <type_traits>
#include <utility>
#include <vector>

#include "binpick/core/camera_model.hpp"
#include "binpick/core/detail/simd.hpp"
#include "binpick/core/errors.hpp"
#include "binpick/registration/correspondence.hpp"
#include "binpick/registration/detail/parallel.hpp"
#include "binpick/registration/point_cloud.hpp"

namespace binpick {

struct ProjectiveAssociationSettings {
  /// Half size r [px] of the search window around the projected pixel (0 = that pixel only, the
  /// default: fastest, and on real point-to-plane data the most accurate, since a wider window prefers
  /// nearer but noisier partners). A wider window helps point-to-point ICP.
  int window_radius = 0;
};

template <typename Scalar_, typename Camera>
class ProjectiveAssociation {
 public:
  using Scalar = Scalar_;
  static_assert(is_camera_model<Camera>::value, "Camera must model the camera concept (camera_model.hpp)");

  /// `target`: the target view's organized cloud in its camera frame (normals optional, required by
  /// point-to-plane ICP); `camera`: the model that produced it. Throws std::invalid_argument when the
  /// sizes disagree or window_radius < 0.
  ProjectiveAssociation(OrganizedCloud<Scalar> target, const Camera& camera,
                        const ProjectiveAssociationSettings& settings = {})
      : target_(std::move(target)), camera_(camera), settings_(settings) {
    require(target_.width == camera_.width() && target_.height == camera_.height(), "target",
            "organized cloud size differs from the camera's");
    require(target_.points.size() == std::size_t(target_.width) * std::size_t(target_.height), "target",
            "points.size() must equal width*height");
    require(target_.normals.empty() || target_.normals.size() == target_.points.size(), "target",
            "normals must be empty or one per pixel");
    require(settings.window_radius >= 0, "window_radius", "must be >= 0");
  }

  const OrganizedCloud<Scalar>& target() const { return target_; }
  const Camera& camera() const { return camera_; }
  const Vector3<Scalar>& target_point(std::ptrdiff_t i) const { return target_.points[std::size_t(i)]; }
  const Vector3<Scalar>& target_normal(std::ptrdiff_t i) const { return target_.normals[std::size_t(i)]; }
  bool has_target_normals() const { return target_.has_normals(); }
  /// The targets as arrays (correspondence.hpp, the optional storage members).
  std::size_t target_count() const { return target_.points.size(); }
  const Vector3<Scalar>* target_points_data() const { return target_.points.data(); }
  const Vector3<Scalar>* target_normals_data() const { return target_.has_normals() ? target_.normals.data() : nullptr; }

  /// Moves the target cloud out (the association is empty afterwards and must not associate again):
  /// a caller that builds one association per frame keeps the memory for the next frame.
  OrganizedCloud<Scalar> release_target() && { return std::move(target_); }

  void associate(const std::vector<Vector3<Scalar>>& queries, Scalar max_distance, int num_threads,
                 std::vector<std::ptrdiff_t>& partners) const {
    registration_detail::associate_by_partner(*this, queries, max_distance, num_threads, partners);
  }

  /// True when partner(q) is the single-pixel rule (window_radius 0): the target point at the pixel q
  /// rounds to, if it is valid, has a normal (when the target has normals) and lies within
  /// max_distance. ICP's vectorized point-to-plane pass then projects a block of queries with
  /// project_queries() and applies the rest of the rule on the gathered partners itself
  /// (correspondence.hpp, the optional projective members).
  bool pixel_partner() const { return settings_.window_radius == 0; }

  /// The target index (v * width + u) of the pixel each of `count` queries rounds to, or -1 when it
  /// projects outside the image, is not finite or not in front (the camera's project() rule).
  /// Queries as coordinate arrays; `count` a multiple of Pack<Scalar, Bytes>::size (detail/simd.hpp),
  /// the pack width the caller runs at. A pinhole target projects a pack at a time, other models call
  /// the camera per query.
  template <int Bytes>
  BINPICK_SIMD_INLINE void project_queries(const Scalar* x, const Scalar* y, const Scalar* z, int count,
                                           std::ptrdiff_t* index) const {
    const int w = target_.width, h = target_.height;
    if constexpr (std::is_same<Camera, PinholeCamera<Scalar>>::value) {
      BINPICK_SIMD_BEGIN
      using P = detail::Pack<Scalar, Bytes>;
      using V = typename P::type;
      using Mask = typename P::mask;
      using Index = typename std::remove_reference<decltype(Mask()[0])>::type;
      const V fx = P::splat(camera_.fx()), fy = P::splat(camera_.fy()), cx = P::splat(camera_.cx()),
              cy = P::splat(camera_.cy());
      const V zero = P::splat(Scalar(0)), half = P::splat(Scalar(0.5)), one = P::splat(Scalar(1));
      const V inf = P::splat(std::numeric_limits<Scalar>::infinity());
      const V umax = P::splat(Scalar(w) - Scalar(0.5)), vmax = P::splat(Scalar(h) - Scalar(0.5));
      for (int i = 0; i < count; i += P::size) {
        const V qx = P::load(x + i), qy = P::load(y + i), qz = P::load(z + i);
        Mask ok = (qz > zero) & (qz < inf);
        const V inv_z = one / P::select(ok, qz, one);
        // project()'s arithmetic, operation for operation: the same pixel as partner().
        const V u = fx * qx * inv_z + cx, v = fy * qy * inv_z + cy;
        ok &= (u >= -half) & (v >= -half) & (u < umax) & (v < vmax);
        const Mask iu = __builtin_convertvector(P::select(ok, u + half, zero), Mask);
        const Mask iv = __builtin_convertvector(P::select(ok, v + half, zero), Mask);
        ok &= (iu < Index(w)) & (iv < Index(h));
        const Mask id = ok ? iv * Index(w) + iu : Mask() - Index(1);
        using Wide = typename detail::Lanes<std::ptrdiff_t, P::size>::type;
        const Wide wide = __builtin_convertvector(id, Wide);  // one sign extension, not a lane at a time
        std::memcpy(index + i, &wide, sizeof wide);
      }
      BINPICK_SIMD_END
    } else {
      for (int i = 0; i < count; ++i) index[i] = pixel_of(Vector3<Scalar>(x[i], y[i], z[i]));
    }
  }

  /// The partner of one query (the optional point-wise member of the concept: ICP then transforms,
  /// associates and sums in one pass, without per-iteration arrays), or -1.
  std::ptrdiff_t partner(const Vector3<Scalar>& q, Scalar max_distance) const {
    const Scalar max_d2 = max_distance * max_distance;
    const int r = settings_.window_radius, w = target_.width, h = target_.height;
    const auto px = camera_.project(q);
    if (!px) return -1;
    // Nearest pixel: project() keeps (u, v) >= -0.5, so truncating u + 0.5 is floor(u + 0.5)
    // (std::floor is a library call at the baseline ISA); the clamps below absorb rounding at
    // the far border.
    const int u0 = int(px->x() + Scalar(0.5)), v0 = int(px->y() + Scalar(0.5));
    const bool need_normal = target_.has_normals();
    if (r == 0) {  // the default: one pixel, no window loop
      const std::ptrdiff_t pixel = pixel_of(u0, v0);
      if (pixel < 0) return -1;
      const std::size_t id = std::size_t(pixel);
      const Vector3<Scalar>& p = target_.points[id];
      if (!(p.z() > Scalar(0))) return -1;
      if (need_normal && target_.normals[id].squaredNorm() == Scalar(0)) return -1;
      return (p - q).squaredNorm() <= max_d2 ? std::ptrdiff_t(id) : -1;
    }
    Scalar best = max_d2;
    std::ptrdiff_t best_id = -1;
    for (int v = std::max(0, v0 - r); v <= std::min(h - 1, v0 + r); ++v)
      for (int u = std::max(0, u0 - r); u <= std::min(w - 1, u0 + r); ++u) {
        const std::size_t id = target_.index(u, v);
        const Vector3<Scalar>& p = target_.points[id];
        if (!(p.z() > Scalar(0))) continue;
        if (need_normal && target_.normals[id].z() == Scalar(0) && target_.normals[id].squaredNorm() == Scalar(0))
          continue;  // no normal here: useless for point-to-plane
        const Scalar d2 = (p - q).squaredNorm();
        if (d2 <= best) {
          if (d2 == best && best_id >= 0) continue;  // ties: first in scan order
          best = d2;
          best_id = std::ptrdiff_t(id);
        }
      }
    return best_id;
  }

 private:
  /// The index of pixel (u0, v0), or -1 outside the image.
  std::ptrdiff_t pixel_of(int u0, int v0) const {
    return u0 >= 0 && v0 >= 0 && u0 < target_.width && v0 < target_.height ? std::ptrdiff_t(target_.index(u0, v0)) : -1;
  }
  /// The index of the pixel q rounds to (the camera's project() rule), or -1.
  std::ptrdiff_t pixel_of(const Vector3<Scalar>& q) const {
    const auto px = camera_.project(q);
    return px ? pixel_of(int(px->x() + Scalar(0.5)), int(px->y() + Scalar(0.5))) : -1;
  }

  OrganizedCloud<Scalar> target_;
  Camera camera_;
  ProjectiveAssociationSettings settings_;
};

}  // namespace binpick
