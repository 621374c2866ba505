#pragma once
/// \file point_cloud.hpp
/// The clouds registration works on: an unorganized `PointCloud` (points, optional normals) and an
/// `OrganizedCloud` (one point per pixel of a depth image, so neighbours are pixel neighbours), and the
/// backprojection of a depth image into either.
///
/// Conventions: points in metres in the frame of the camera that saw them; a normal is a unit vector or
/// exactly zero ("unknown"). In an organized cloud an invalid pixel holds the point (0, 0, 0) (its
/// z = 0, "no measurement", as in depth images), so no NaN is ever stored.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <limits>
#include <type_traits>
#include <vector>

#include <Eigen/Core>

#include "binpick/core/camera_model.hpp"
#include "binpick/core/depth_image.hpp"
#include "binpick/core/detail/huge_pages.hpp"
#include "binpick/core/detail/simd.hpp"
#include "binpick/core/errors.hpp"
#include "binpick/core/pose.hpp"
#include "binpick/core/ray_table.hpp"
#include "binpick/registration/detail/parallel.hpp"

namespace binpick {

template <typename Scalar>
struct PointCloud {
  std::vector<Vector3<Scalar>> points;   ///< [m]
  std::vector<Vector3<Scalar>> normals;  ///< empty, or one per point (unit, or zero = unknown)

  std::size_t size() const { return points.size(); }
  bool empty() const { return points.empty(); }
  bool has_normals() const { return !points.empty() && normals.size() == points.size(); }
};

template <typename Scalar>
struct OrganizedCloud {
  int width = 0, height = 0;
  std::vector<Vector3<Scalar>> points;   ///< row-major, width*height; z == 0 marks "no measurement"
  std::vector<Vector3<Scalar>> normals;  ///< empty, or width*height (unit, or zero = unknown)

  std::size_t index(int u, int v) const { return std::size_t(v) * std::size_t(width) + std::size_t(u); }
  bool valid(int u, int v) const { return points[index(u, v)].z() > Scalar(0); }
  bool has_normals() const { return !points.empty() && normals.size() == points.size(); }
};

namespace registration_detail {
/// The point of pixel (u, v) at depth z [m] in the camera frame, or zero when there is no measurement
/// (z <= 0, NaN) or the camera gives no finite point: the one backprojection rule of every cloud here.
template <typename Scalar, typename Camera>
Vector3<Scalar> backproject_or_zero(const Camera& camera, int u, int v, Scalar z) {
  if (!(z > Scalar(0))) return Vector3<Scalar>::Zero();
  const Vector3<Scalar> p = camera.backproject(Scalar(u), Scalar(v), z).template cast<Scalar>();
  return p.allFinite() ? p : Vector3<Scalar>::Zero().eval();
}

/// backproject_or_zero for many pixels of one camera. A pinhole camera's rays come from its ray table
/// (core/ray_table.hpp): a pixel costs two products instead of two divisions and a call, with the same
/// bits. Other models call the camera (a whole-image table would cost more than one pass saves).
template <typename Scalar, typename Camera>
class PixelBackprojector {
 public:
  explicit PixelBackprojector(const Camera& camera) : camera_(camera) {}
  Vector3<Scalar> operator()(int u, int v, Scalar z) const { return backproject_or_zero<Scalar>(camera_, u, v, z); }
  /// Entry j of x, y, z = the point of pixel (u0 + j step, v) of `depth`, j < n (all inside the image).
  void row(const DepthImageView<Scalar>& depth, int v, int u0, int step, int n, Scalar* x, Scalar* y, Scalar* z) const {
    for (int j = 0; j < n; ++j) {
      const int u = u0 + j * step;
      const Vector3<Scalar> p = (*this)(u, v, depth.depth(u, v));
      x[j] = p.x();
      y[j] = p.y();
      z[j] = p.z();
    }
  }

 private:
  const Camera& camera_;
};

template <typename Scalar>
class PixelBackprojector<Scalar, PinholeCamera<Scalar>> {
 public:
  explicit PixelBackprojector(const PinholeCamera<Scalar>& camera) : rays_(detail::RayTable<Scalar>::make(camera)) {}
  /// (u, v) inside the camera's image.
  Vector3<Scalar> operator()(int u, int v, Scalar z) const {
    if (!(z > Scalar(0))) return Vector3<Scalar>::Zero();
    const Vector3<Scalar> p(rays_.x[std::size_t(u)] * z, rays_.y[std::size_t(v)] * z, z);
    return p.allFinite() ? p : Vector3<Scalar>::Zero().eval();
  }
  /// Entry j of x, y, z = operator()(u0 + j step, v, depth at that pixel), j < n (all inside the
  /// image): the same bits, read as the view's own type and without a branch per pixel (holes in
  /// metal depth images make branches unpredictable).
  void row(const DepthImageView<Scalar>& depth, int v, int u0, int step, int n, Scalar* x, Scalar* y, Scalar* z) const {
    const Scalar ry = rays_.y[std::size_t(v)], scale = depth.metres_per_unit();
    const Scalar big = std::numeric_limits<Scalar>::max();
    const Scalar* rx = rays_.x.data();
    depth.dispatch([&](auto type) {
      using T = decltype(type);
      const T* raw = depth.template row<T>(v);
      for (int j = 0; j < n; ++j) {
        const int u = u0 + j * step;
        const Scalar d = DepthImageView<Scalar>::decode(raw[u], scale);
        const Scalar px = rx[u] * d, py = ry * d;
        // operator()'s tests: a measurement (decode() leaves it finite) and finite products.
        const bool ok = (int(d > Scalar(0)) & int(std::abs(px) <= big) & int(std::abs(py) <= big)) != 0;
        x[j] = ok ? px : Scalar(0);
        y[j] = ok ? py : Scalar(0);
        z[j] = ok ? d : Scalar(0);
      }
    });
  }
  const detail::RayTable<Scalar>& rays() const { return rays_; }

 private:
  detail::RayTable<Scalar> rays_;
};

BINPICK_SIMD_BEGIN

/// Row v of a pinhole backprojection at stride 1 a pack at a time: out[u] = point(u, v, decode(row[u]))
/// (the same operations lane by lane, so the same bits) for the leading whole packs of the row.
/// Returns the first column not written.
template <typename Scalar, typename T>
int backproject_pinhole_row(const T* row, Scalar scale, const PixelBackprojector<Scalar, PinholeCamera<Scalar>>& point,
                            int v, int width, Vector3<Scalar>* out) {
  static_assert(sizeof(Vector3<Scalar>) == 3 * sizeof(Scalar), "3-vectors must be packed");
  int u = 0;
  const Scalar* rx = point.rays().x.data();
  const Scalar ry = point.rays().y[std::size_t(v)];
  detail::simd_call([&](auto bytes) BINPICK_SIMD_INLINE_LAMBDA {
    using P = detail::Pack<Scalar, decltype(bytes)::value>;
    using V = typename P::type;
    const V zero = P::splat(Scalar(0)), y_ray = P::splat(ry), big = P::splat(std::numeric_limits<Scalar>::max());
    for (; u + P::size <= width; u += P::size) {
      typename P::mask ok;
      const V z = detail::decode_pack<Scalar, decltype(bytes)::value>(row + u, scale, ok);
      const V x = P::load(rx + u) * z, y = y_ray * z;
      ok &= (x <= big) & (-x <= big) & (y <= big) & (-y <= big);  // allFinite()
      P::store3(out[u].data(), P::select(ok, x, zero), P::select(ok, y, zero), P::select(ok, z, zero));
    }
  });
  return u;
}

BINPICK_SIMD_END

/// Moves the pixels with a measurement (z > 0), and their normals when `normals` is not empty, to the
/// front of the arrays, in order, and drops the rest: an organized cloud (and its normals) becomes an
/// unorganized one in place.
template <typename Scalar>
void keep_valid_in_place(std::vector<Vector3<Scalar>>& points, std::vector<Vector3<Scalar>>& normals) {
  const bool with_normals = !normals.empty();
  // Runs of valid pixels moved whole (m <= i: nothing not yet read is overwritten); a run already
  // in place (no invalid pixel before it) is not copied at all.
  const std::size_t n = points.size();
  std::size_t m = 0;
  for (std::size_t i = 0; i < n;) {
    if (!(points[i].z() > Scalar(0))) {
      ++i;
      continue;
    }
    std::size_t end = i + 1;
    while (end < n && points[end].z() > Scalar(0)) ++end;
    if (m != i) {
      std::memmove(static_cast<void*>(points.data() + m), points.data() + i, (end - i) * sizeof(Vector3<Scalar>));
      if (with_normals)
        std::memmove(static_cast<void*>(normals.data() + m), normals.data() + i, (end - i) * sizeof(Vector3<Scalar>));
    }
    m += end - i;
    i = end;
  }
  points.resize(m);
  if (with_normals) normals.resize(m);
}

}  // namespace registration_detail

/// One point per pixel of every `stride`-th row and column of `depth` (stride 1: every pixel; the
/// cloud is then ceil(width/stride) × ceil(height/stride)), in the camera frame [m], written into
/// `cloud` (its points replaced, its normals left alone) reusing its memory: a cloud kept across frames
/// allocates once. Rows are split over `num_threads` threads (0 = all cores; the points do not
/// depend on it). Throws std::invalid_argument when the image size differs from the camera's or
/// stride < 1.
template <typename Scalar, typename Camera>
void backproject_organized(const DepthImageView<Scalar>& depth, const Camera& camera, int stride,
                           OrganizedCloud<Scalar>& cloud, int num_threads = 1) {
  static_assert(is_camera_model<Camera>::value, "Camera must model the camera concept (camera_model.hpp)");
  require(stride >= 1, "stride", "must be >= 1");
  require(depth.width() == camera.width() && depth.height() == camera.height(), "depth",
          "image size differs from the camera's");
  cloud.width = (depth.width() + stride - 1) / stride;
  cloud.height = (depth.height() + stride - 1) / stride;
  binpick::detail::reserve_huge(cloud.points, std::size_t(cloud.width) * std::size_t(cloud.height));
  cloud.points.resize(std::size_t(cloud.width) * std::size_t(cloud.height));  // every point is written below
  // The encoding switch is taken once, not per pixel.
  const registration_detail::PixelBackprojector<Scalar, Camera> point(camera);
  const int threads = registration_detail::resolve_threads(num_threads);
  depth.dispatch([&](auto tag) {
    using T = decltype(tag);
    const Scalar scale = depth.metres_per_unit();
    // Threaded like the normals that follow (contiguous row ranges): each thread then reads back
    // mostly points it wrote itself.
    registration_detail::parallel_for(cloud.height, threads, [&](std::ptrdiff_t vi) {
      const int v = int(vi);
      const T* row = depth.template row<T>(v * stride);
      Vector3<Scalar>* out = cloud.points.data() + cloud.index(0, v);
      int u = 0;
      if constexpr (std::is_same<Camera, PinholeCamera<Scalar>>::value) {
        if (stride == 1) u = registration_detail::backproject_pinhole_row(row, scale, point, v, cloud.width, out);
      }
      for (; u < cloud.width; ++u) {
        const Scalar z = DepthImageView<Scalar>::decode(row[std::size_t(u) * std::size_t(stride)], scale);
        out[u] = point(u * stride, v * stride, z);
      }
    }, 8);
  });
}

/// backproject_organized into a new cloud.
template <typename Scalar, typename Camera>
OrganizedCloud<Scalar> backproject_organized(const DepthImageView<Scalar>& depth, const Camera& camera, int stride = 1) {
  OrganizedCloud<Scalar> cloud;
  backproject_organized(depth, camera, stride, cloud);
  return cloud;
}

/// The valid points of an organized cloud (and their normals, when it has them).
template <typename Scalar>
PointCloud<Scalar> valid_points(const OrganizedCloud<Scalar>& organized) {
  PointCloud<Scalar> cloud;
  const bool normals = organized.has_normals();
  for (std::size_t i = 0; i < organized.points.size(); ++i)
    if (organized.points[i].z() > Scalar(0)) {
      cloud.points.push_back(organized.points[i]);
      if (normals) cloud.normals.push_back(organized.normals[i]);
    }
  return cloud;
}

/// The valid pixels of every `stride`-th row and column of `depth` as an unorganized cloud [m]
/// (stride 4 keeps 1/16 of the pixels), in row order, written into `cloud` (its normals cleared)
/// reusing its memory: a cloud kept across frames allocates once. Throws std::invalid_argument for
/// stride < 1 or a size mismatch.
template <typename Scalar, typename Camera>
void backproject_points(const DepthImageView<Scalar>& depth, const Camera& camera, int stride, PointCloud<Scalar>& cloud) {
  // The organized backprojection in the cloud's own memory, then its holes squeezed out.
  OrganizedCloud<Scalar> grid;
  grid.points.swap(cloud.points);
  backproject_organized(depth, camera, stride, grid);
  cloud.points.swap(grid.points);
  cloud.normals.clear();
  registration_detail::keep_valid_in_place(cloud.points, cloud.normals);
}

/// backproject_points into a new cloud.
template <typename Scalar, typename Camera>
PointCloud<Scalar> backproject_points(const DepthImageView<Scalar>& depth, const Camera& camera, int stride = 1) {
  PointCloud<Scalar> cloud;
  backproject_points(depth, camera, stride, cloud);
  return cloud;
}

}  // namespace binpick
