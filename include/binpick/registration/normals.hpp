#pragma once
/// \file normals.hpp
/// Surface normals for point-to-plane ICP (paper §III.B.2: views are refined with point-to-plane ICP).
///  - organized clouds (depth images): the cross product of the horizontal and vertical tangents taken
///    from pixel neighbours (central differences); none on creases and, by default, none next to
///    depth edges and holes (one-sided differences there on request);
///  - unorganized clouds: PCA of the k nearest neighbours (FLANN kd-tree), the eigenvector of the
///    smallest eigenvalue.
/// Normals are unit vectors oriented toward the viewpoint (the camera), or zero where none can be
/// estimated; never NaN.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <limits>
#include <vector>

#include <Eigen/Eigenvalues>

#include "binpick/core/detail/huge_pages.hpp"
#include "binpick/core/detail/simd.hpp"
#include "binpick/core/errors.hpp"
#include "binpick/registration/detail/parallel.hpp"
#include "binpick/registration/kdtree.hpp"
#include "binpick/registration/point_cloud.hpp"

namespace binpick {

template <typename Scalar>
struct OrganizedNormalSettings {
  /// Distance [px] of the neighbours spanning the tangents; larger averages over more sensor noise
  /// (and depth quantization) and blurs edges more. >= 1.
  int pixel_offset = 2;
  /// A neighbour whose depth differs from the centre's by more than this fraction of the centre depth
  /// lies across a depth edge and is not used. > 0.
  Scalar max_depth_jump_ratio = Scalar(0.05);
  /// [rad] When the forward and backward tangents of a pixel differ by more than this angle, the
  /// pixel sits on a crease (a box edge) and a central difference would blend two faces into a
  /// normal that fits neither: the pixel gets no normal. Raise it for noisy sensors (their tangents
  /// scatter); pi disables the check.
  Scalar max_crease_angle = Scalar(0.35);
  /// Near a depth edge or hole (a neighbour missing or across a jump): false (default) leaves the
  /// pixel without a normal, so ICP ignores the silhouette band where partners are ambiguous; true
  /// falls back to the one-sided difference (keeps thin structures, at the cost of edge bias).
  bool one_sided_at_edges = false;
  /// 1 by default (see IcpSettings::num_threads: a few ms of work, often on a busy machine); 0 = all cores.
  int num_threads = 1;
};

namespace registration_detail {

inline void require_normal_settings_valid(int pixel_offset, double max_depth_jump_ratio, double max_crease_angle) {
  require(pixel_offset >= 1, "pixel_offset", "must be >= 1");
  require(std::isfinite(max_depth_jump_ratio) && max_depth_jump_ratio > 0, "max_depth_jump_ratio",
          "must be finite and > 0");
  require(std::isfinite(max_crease_angle) && max_crease_angle > 0, "max_crease_angle", "must be finite and > 0");
}

/// The normal at pixel (u, v) of an organized cloud (zero when none; see OrganizedNormalSettings).
template <typename Scalar>
Vector3<Scalar> organized_normal_at(const OrganizedCloud<Scalar>& cloud, int u, int v,
                                    const OrganizedNormalSettings<Scalar>& settings, Scalar cos_crease) {
  const int k = settings.pixel_offset, w = cloud.width, h = cloud.height;
  const Vector3<Scalar>& c = cloud.points[cloud.index(u, v)];
  if (!(c.z() > Scalar(0))) return Vector3<Scalar>::Zero();
  const Scalar jump = settings.max_depth_jump_ratio * c.z();
  auto usable = [&](int uu, int vv) {
    if (uu < 0 || vv < 0 || uu >= w || vv >= h) return false;
    const Vector3<Scalar>& p = cloud.points[cloud.index(uu, vv)];
    return p.z() > Scalar(0) && std::abs(p.z() - c.z()) <= jump;
  };
  auto tangent = [&](int du, int dv, Vector3<Scalar>& t) {
    const bool fwd = usable(u + du, v + dv), bwd = usable(u - du, v - dv);
    if (fwd && bwd) {
      const Vector3<Scalar> tf = cloud.points[cloud.index(u + du, v + dv)] - c;
      const Vector3<Scalar> tb = c - cloud.points[cloud.index(u - du, v - dv)];
      if (tf.dot(tb) < cos_crease * tf.norm() * tb.norm()) return false;  // crease
      t = tf + tb;
    } else if (!settings.one_sided_at_edges) {
      return false;
    } else if (fwd) {
      t = cloud.points[cloud.index(u + du, v + dv)] - c;
    } else if (bwd) {
      t = c - cloud.points[cloud.index(u - du, v - dv)];
    } else {
      return false;
    }
    return true;
  };
  Vector3<Scalar> tu, tv;
  if (!tangent(k, 0, tu) || !tangent(0, k, tv)) return Vector3<Scalar>::Zero();
  Vector3<Scalar> n = tu.cross(tv);
  const Scalar norm = n.norm();
  // Tangents (nearly) parallel: grazing view or a one-pixel-wide sliver; no reliable normal.
  if (!(norm > Scalar(1e-3) * tu.norm() * tv.norm()) || !std::isfinite(norm)) return Vector3<Scalar>::Zero();
  n /= norm;
  if (n.dot(c) > Scalar(0)) n = -n;  // toward the camera at the origin
  return n;
}

/// organized_normal_at for a pixel at least `k` pixels inside the image with one_sided_at_edges off
/// (the default): the same tests written on components, without bounds checks, and the crease and
/// parallel-tangent tests compared in squares (one square root per pixel instead of five).
/// `p` points at the pixel, `du` = k and `dv` = k × width are the neighbour offsets.
template <typename Scalar>
Vector3<Scalar> organized_normal_interior(const Vector3<Scalar>* p, std::ptrdiff_t du, std::ptrdiff_t dv,
                                          Scalar jump_ratio, Scalar cos_crease) {
  const Scalar cx = p->x(), cy = p->y(), cz = p->z();
  if (!(cz > Scalar(0))) return Vector3<Scalar>::Zero();
  const Scalar jump = jump_ratio * cz;
  const Vector3<Scalar>&r = p[du], &l = p[-du], &d = p[dv], &t = p[-dv];
  // usable(): measured and not across a depth jump (NaN-safe: every comparison fails on NaN)
  if (!(r.z() > Scalar(0) && l.z() > Scalar(0) && d.z() > Scalar(0) && t.z() > Scalar(0) &&
        std::abs(r.z() - cz) <= jump && std::abs(l.z() - cz) <= jump && std::abs(d.z() - cz) <= jump &&
        std::abs(t.z() - cz) <= jump))
    return Vector3<Scalar>::Zero();
  const Scalar cc2 = cos_crease * cos_crease;
  // Crease: tf·tb < cos |tf| |tb|, i.e. in squares by the sign of cos.
  const auto crease = [&](Scalar fx, Scalar fy, Scalar fz, Scalar bx, Scalar by, Scalar bz) {
    const Scalar dot = fx * bx + fy * by + fz * bz;
    const Scalar pp = (fx * fx + fy * fy + fz * fz) * (bx * bx + by * by + bz * bz);
    return cos_crease >= Scalar(0) ? (dot < Scalar(0) || dot * dot < cc2 * pp) : (dot < Scalar(0) && dot * dot > cc2 * pp);
  };
  const Scalar ufx = r.x() - cx, ufy = r.y() - cy, ufz = r.z() - cz;
  const Scalar ubx = cx - l.x(), uby = cy - l.y(), ubz = cz - l.z();
  const Scalar vfx = d.x() - cx, vfy = d.y() - cy, vfz = d.z() - cz;
  const Scalar vbx = cx - t.x(), vby = cy - t.y(), vbz = cz - t.z();
  if (crease(ufx, ufy, ufz, ubx, uby, ubz) || crease(vfx, vfy, vfz, vbx, vby, vbz)) return Vector3<Scalar>::Zero();
  const Scalar ux = ufx + ubx, uy = ufy + uby, uz = ufz + ubz;
  const Scalar vx = vfx + vbx, vy = vfy + vby, vz = vfz + vbz;
  Scalar nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
  const Scalar n2 = nx * nx + ny * ny + nz * nz;
  if (!(n2 > Scalar(1e-6) * (ux * ux + uy * uy + uz * uz) * (vx * vx + vy * vy + vz * vz)) || !std::isfinite(n2))
    return Vector3<Scalar>::Zero();
  const Scalar inv = Scalar(1) / std::sqrt(n2);
  nx *= inv;
  ny *= inv;
  nz *= inv;
  if (nx * cx + ny * cy + nz * cz > Scalar(0)) return Vector3<Scalar>(-nx, -ny, -nz);  // toward the camera
  return Vector3<Scalar>(nx, ny, nz);
}

/// The normal at (u, v): the interior fast path where it applies, else organized_normal_at.
template <typename Scalar>
Vector3<Scalar> organized_normal(const OrganizedCloud<Scalar>& cloud, int u, int v,
                                 const OrganizedNormalSettings<Scalar>& settings, Scalar cos_crease) {
  const int k = settings.pixel_offset;
  if (settings.one_sided_at_edges || u < k || v < k || u + k >= cloud.width || v + k >= cloud.height)
    return organized_normal_at(cloud, u, v, settings, cos_crease);
  return organized_normal_interior(cloud.points.data() + cloud.index(u, v), std::ptrdiff_t(k),
                                   std::ptrdiff_t(k) * cloud.width, settings.max_depth_jump_ratio, cos_crease);
}

template <typename Scalar>
Scalar cos_crease(const OrganizedNormalSettings<Scalar>& settings) {
  return std::cos(std::min(settings.max_crease_angle, Scalar(3.14159265358979323846)));
}

/// One image row as coordinate arrays (the pack kernel loads neighbours contiguously).
template <typename Scalar>
struct RowXyz {
  const Scalar *x, *y, *z;
};

BINPICK_SIMD_BEGIN

/// organized_normal_interior for `Pack<Scalar, Bytes>::size` pixels, entries u.. of `c`: the same
/// operations in the same order lane by lane, so the same bits (the crease sign test is chosen once
/// per call, not per lane). `l` / `r` / `t` / `d` hold, at the same entries, the pixels' neighbours
/// k pixels to the left, right, above and below (for neighbouring pixels of one image row: that row
/// shifted by -k and +k, and the rows k above and below). The first of two passes
/// (organized_normals_packs): writes the raw (unscaled) normals to entries u.. of the rows x, y, z of
/// `raw` (rows `raw_row` apart) and their squared length to its row 3 (0 for none).
template <typename Scalar, int Bytes>
BINPICK_SIMD_INLINE void organized_normals_pack(const RowXyz<Scalar>& c, const RowXyz<Scalar>& l, const RowXyz<Scalar>& r,
                                                const RowXyz<Scalar>& t, const RowXyz<Scalar>& d, int u,
                                                Scalar jump_ratio, Scalar cos_crease, Scalar* raw,
                                                std::ptrdiff_t raw_row) {
  using P = detail::Pack<Scalar, Bytes>;
  using V = typename P::type;
  using M = typename P::mask;
  const V zero = P::splat(Scalar(0)), inf = P::splat(std::numeric_limits<Scalar>::infinity());
  const V cx = P::load(c.x + u), cy = P::load(c.y + u), cz = P::load(c.z + u);
  const V rx = P::load(r.x + u), ry = P::load(r.y + u), rz = P::load(r.z + u);
  const V lx = P::load(l.x + u), ly = P::load(l.y + u), lz = P::load(l.z + u);
  const V dx = P::load(d.x + u), dy = P::load(d.y + u), dz = P::load(d.z + u);
  const V tx = P::load(t.x + u), ty = P::load(t.y + u), tz = P::load(t.z + u);
  const V jump = P::splat(jump_ratio) * cz;
  // |a| <= jump as two comparisons: the same truth for every value, NaN and inf included.
  const auto near = [&](const V& a) BINPICK_SIMD_INLINE_LAMBDA { return (a <= jump) & (-a <= jump); };
  M ok = (cz > zero) & (rz > zero) & (lz > zero) & (dz > zero) & (tz > zero) & near(rz - cz) & near(lz - cz) &
         near(dz - cz) & near(tz - cz);
  const V cc2 = P::splat(cos_crease * cos_crease);
  const bool cos_positive = cos_crease >= Scalar(0);
  const auto crease = [&](const V& fx, const V& fy, const V& fz, const V& bx, const V& by, const V& bz)
                          BINPICK_SIMD_INLINE_LAMBDA {
                            const V dot = fx * bx + fy * by + fz * bz;
                            const V pp = (fx * fx + fy * fy + fz * fz) * (bx * bx + by * by + bz * bz);
                            return cos_positive ? M((dot < zero) | (dot * dot < cc2 * pp))
                                                : M((dot < zero) & (dot * dot > cc2 * pp));
                          };
  const V ufx = rx - cx, ufy = ry - cy, ufz = rz - cz;
  const V ubx = cx - lx, uby = cy - ly, ubz = cz - lz;
  const V vfx = dx - cx, vfy = dy - cy, vfz = dz - cz;
  const V vbx = cx - tx, vby = cy - ty, vbz = cz - tz;
  ok &= ~(crease(ufx, ufy, ufz, ubx, uby, ubz) | crease(vfx, vfy, vfz, vbx, vby, vbz));
  const V ux = ufx + ubx, uy = ufy + uby, uz = ufz + ubz;
  const V vx = vfx + vbx, vy = vfy + vby, vz = vfz + vbz;
  const V nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
  const V n2 = nx * nx + ny * ny + nz * nz;
  ok &= (n2 > P::splat(Scalar(1e-6)) * (ux * ux + uy * uy + uz * uz) * (vx * vx + vy * vy + vz * vz)) & (n2 < inf);
  // ok implies n2 > 0 (it exceeds a product of squares), so n2 or 0 carries ok to the second pass.
  P::store(raw + u, nx);
  P::store(raw + raw_row + u, ny);
  P::store(raw + 2 * raw_row + u, nz);
  P::store(raw + 3 * raw_row + u, P::select(ok, n2, zero));
}

/// The second pass: organized_normals_pack's raw normals at entries u.. of `raw` scaled to unit
/// length and turned toward the camera (the pixels at entries u.. of `c`), zero where their squared
/// length is 0; written to out[0..size).
template <typename Scalar, int Bytes>
BINPICK_SIMD_INLINE void unit_normals_pack(const RowXyz<Scalar>& c, const Scalar* raw, std::ptrdiff_t raw_row, int u,
                                           Vector3<Scalar>* out) {
  using P = detail::Pack<Scalar, Bytes>;
  using V = typename P::type;
  using M = typename P::mask;
  const V zero = P::splat(Scalar(0));
  const V n2 = P::load(raw + 3 * raw_row + u);
  const M ok = n2 > zero;
  const V inv = P::splat(Scalar(1)) / P::sqrt(P::select(ok, n2, P::splat(Scalar(1))));
  V ox = P::load(raw + u) * inv, oy = P::load(raw + raw_row + u) * inv, oz = P::load(raw + 2 * raw_row + u) * inv;
  const M flip = ox * P::load(c.x + u) + oy * P::load(c.y + u) + oz * P::load(c.z + u) > zero;  // toward the camera
  ox = P::select(ok, P::select(flip, -ox, ox), zero);
  oy = P::select(ok, P::select(flip, -oy, oy), zero);
  oz = P::select(ok, P::select(flip, -oz, oz), zero);
  static_assert(sizeof(Vector3<Scalar>) == 3 * sizeof(Scalar), "3-vectors must be packed");
  P::store3(out->data(), ox, oy, oz);
}

/// The normals of the whole packs of entries [begin, end) of one row into out[begin..): both passes,
/// organized_normals_pack over the packs, then unit_normals_pack (`raw`: 4 rows of `raw_row` >= end
/// scalars). The square root and division of the second pass have long latencies; in a loop of their
/// own, several packs overlap them (the normals of a 640 x 480 image, 1 thread, AMD Zen 3: 1.61 ms in
/// one pass, 1.38 ms in two). Returns the first entry not done.
template <typename Scalar, int Bytes>
BINPICK_SIMD_INLINE int organized_normals_packs(const RowXyz<Scalar>& c, const RowXyz<Scalar>& l, const RowXyz<Scalar>& r,
                                                const RowXyz<Scalar>& t, const RowXyz<Scalar>& d, int begin, int end,
                                                Scalar jump_ratio, Scalar cos_crease, Scalar* raw, std::ptrdiff_t raw_row,
                                                Vector3<Scalar>* out) {
  constexpr int size = detail::Pack<Scalar, Bytes>::size;
  int u = begin;
  for (; u + size <= end; u += size)
    organized_normals_pack<Scalar, Bytes>(c, l, r, t, d, u, jump_ratio, cos_crease, raw, raw_row);
  for (int e = begin; e < u; e += size) unit_normals_pack<Scalar, Bytes>(c, raw, raw_row, e, out + e);
  return u;
}

/// x[u], y[u], z[u] = p[u] for u < w: a row of 3-vectors as coordinate rows, a pack at a time.
template <typename Scalar>
void deinterleave_row(const Vector3<Scalar>* p, int w, Scalar* x, Scalar* y, Scalar* z) {
  static_assert(sizeof(Vector3<Scalar>) == 3 * sizeof(Scalar), "3-vectors must be packed");
  int u = 0;
  detail::simd_call([&](auto bytes) BINPICK_SIMD_INLINE_LAMBDA {
    using P = detail::Pack<Scalar, decltype(bytes)::value>;
    for (; u + P::size <= w; u += P::size) P::load3(p[u].data(), x + u, y + u, z + u);
  });
  for (; u < w; ++u) {
    x[u] = p[u].x();
    y[u] = p[u].y();
    z[u] = p[u].z();
  }
}

BINPICK_SIMD_END

/// The normals of every pixel of `cloud` into out[0 .. width*height): organized_normal's result at
/// each pixel. Interior pixels go through organized_normals_pack on coordinate rows; a thread keeps
/// the 2k + 1 rows its next row needs in a ring, so each row is rearranged about once.
template <typename Scalar>
void organized_normals_into(const OrganizedCloud<Scalar>& cloud, const OrganizedNormalSettings<Scalar>& settings,
                            int threads, Vector3<Scalar>* out) {
  const Scalar cc = cos_crease(settings);
  const int k = settings.pixel_offset, w = cloud.width, h = cloud.height;
  const auto scalar_row = [&](int v, int u_begin, int u_end) {
    for (int u = u_begin; u < u_end; ++u) out[cloud.index(u, v)] = organized_normal(cloud, u, v, settings, cc);
  };
  if (settings.one_sided_at_edges || w < 2 * k + 1 || h < 2 * k + 1) {
    parallel_for(h, threads, [&](std::ptrdiff_t v) { scalar_row(int(v), 0, w); }, 8);
    return;
  }
  struct Ring {
    std::vector<Scalar> xyz;  // slots of 3 × width coordinates
    std::vector<int> row;     // the image row in each slot, -1 for none
    std::vector<Scalar> raw;  // organized_normals_pack's raw normals of one row: x, y, z, n2 rows
  };
  const int slots = 2 * k + 1;
  const auto load = [&](Ring& ring, int r) {
    const int slot = r % slots;
    Scalar* x = ring.xyz.data() + std::size_t(slot) * 3 * std::size_t(w);
    if (ring.row[std::size_t(slot)] != r) {
      deinterleave_row(cloud.points.data() + cloud.index(0, r), w, x, x + w, x + 2 * w);
      ring.row[std::size_t(slot)] = r;
    }
    return RowXyz<Scalar>{x, x + w, x + 2 * w};
  };
  const Scalar jump_ratio = settings.max_depth_jump_ratio;
  // Deterministic blocks of rows per thread (parallel_reduce): a thread's ring follows its rows.
  parallel_reduce(
      h, threads, Ring{},
      [&](Ring& ring, std::ptrdiff_t vi) {
        const int v = int(vi);
        if (v < k || v >= h - k) return scalar_row(v, 0, w);
        if (ring.xyz.empty()) {
          ring.xyz.resize(std::size_t(slots) * 3 * std::size_t(w));
          ring.row.assign(std::size_t(slots), -1);
          ring.raw.resize(4 * std::size_t(w));
        }
        const RowXyz<Scalar> t = load(ring, v - k), c = load(ring, v), d = load(ring, v + k);
        const RowXyz<Scalar> l{c.x - k, c.y - k, c.z - k}, r{c.x + k, c.y + k, c.z + k};
        scalar_row(v, 0, k);
        int u = k;
        detail::simd_call([&](auto bytes) BINPICK_SIMD_INLINE_LAMBDA {
          u = organized_normals_packs<Scalar, decltype(bytes)::value>(c, l, r, t, d, k, w - k, jump_ratio, cc, ring.raw.data(),
                                                                      w, out + cloud.index(0, v));
        });
        scalar_row(v, u, w);
      },
      [](Ring&, const Ring&) {}, 8);
}

}  // namespace registration_detail

/// Fills `cloud.normals` (one per pixel). Throws std::invalid_argument for settings out of range or a
/// cloud whose point count is not width*height.
template <typename Scalar>
void estimate_organized_normals(OrganizedCloud<Scalar>& cloud, const OrganizedNormalSettings<Scalar>& settings = {}) {
  registration_detail::require_normal_settings_valid(settings.pixel_offset, double(settings.max_depth_jump_ratio),
                                                      double(settings.max_crease_angle));
  require(cloud.width >= 0 && cloud.height >= 0 &&
              cloud.points.size() == std::size_t(cloud.width) * std::size_t(cloud.height),
          "cloud", "points.size() must equal width*height");
  const int threads = registration_detail::resolve_threads(settings.num_threads);
  binpick::detail::reserve_huge(cloud.normals, cloud.points.size());
  cloud.normals.resize(cloud.points.size());  // every normal is written below (reused memory: no fill)
  registration_detail::organized_normals_into(cloud, settings, threads, cloud.normals.data());
}

/// The valid pixels of every `stride`-th row and column with their normals, the normals taken at full
/// resolution (so subsampling does not widen the band without normals along edges).
template <typename Scalar>
PointCloud<Scalar> subsample_with_normals(const OrganizedCloud<Scalar>& cloud, int stride,
                                          const OrganizedNormalSettings<Scalar>& settings = {}) {
  require(stride >= 1, "stride", "must be >= 1");
  registration_detail::require_normal_settings_valid(settings.pixel_offset, double(settings.max_depth_jump_ratio),
                                                      double(settings.max_crease_angle));
  require(cloud.width >= 0 && cloud.height >= 0 &&
              cloud.points.size() == std::size_t(cloud.width) * std::size_t(cloud.height),
          "cloud", "points.size() must equal width*height");
  const Scalar cc = registration_detail::cos_crease(settings);
  PointCloud<Scalar> out;
  if (stride == 1) {  // every pixel: the vectorized pass into `out`, then the valid ones moved forward
    out.points = cloud.points;
    out.normals.resize(cloud.points.size());
    registration_detail::organized_normals_into(cloud, settings, registration_detail::resolve_threads(settings.num_threads),
                                                out.normals.data());
    registration_detail::keep_valid_in_place(out.points, out.normals);
    return out;
  }
  const std::size_t kept = std::size_t((cloud.width + stride - 1) / stride) * std::size_t((cloud.height + stride - 1) / stride);
  out.points.reserve(kept);
  out.normals.reserve(kept);
  for (int v = 0; v < cloud.height; v += stride)
    for (int u = 0; u < cloud.width; u += stride) {
      if (!cloud.valid(u, v)) continue;
      out.points.push_back(cloud.points[cloud.index(u, v)]);
      out.normals.push_back(registration_detail::organized_normal(cloud, u, v, settings, cc));
    }
  return out;
}

/// subsample_with_normals straight from a depth image: only the kept pixels and the four neighbours
/// each normal needs are backprojected (stride 4 touches under a third of the pixels instead of all of
/// them); from stride 3 on, a kept row's normals are computed a pack at a time from coordinate rows
/// (a scratch of 18 scalars per kept column, allocated per call). The same points and normals as
/// backproject_organized followed by subsample_with_normals. Written into `out` (its points and
/// normals replaced), reusing its memory: a cloud kept across frames allocates nothing large again.
/// Throws std::invalid_argument for stride < 1, settings out of range or a size mismatch.
template <typename Scalar, typename Camera>
void subsample_with_normals(const DepthImageView<Scalar>& depth, const Camera& camera, int stride,
                            const OrganizedNormalSettings<Scalar>& settings, PointCloud<Scalar>& out) {
  static_assert(is_camera_model<Camera>::value, "Camera must model the camera concept (camera_model.hpp)");
  require(stride >= 1, "stride", "must be >= 1");
  require(depth.width() == camera.width() && depth.height() == camera.height(), "depth",
          "image size differs from the camera's");
  registration_detail::require_normal_settings_valid(settings.pixel_offset, double(settings.max_depth_jump_ratio),
                                                      double(settings.max_crease_angle));
  if (stride == 1) {
    // Every pixel: the organized cloud is built in out.points' own memory, its normals in
    // out.normals', and the valid pixels moved forward in both (no allocation once `out` is kept).
    OrganizedCloud<Scalar> organized;
    organized.points.swap(out.points);
    backproject_organized(depth, camera, 1, organized, settings.num_threads);
    binpick::detail::reserve_huge(out.normals, organized.points.size());
    out.normals.resize(organized.points.size());
    registration_detail::organized_normals_into(organized, settings, registration_detail::resolve_threads(settings.num_threads),
                                                out.normals.data());
    registration_detail::keep_valid_in_place(organized.points, out.normals);
    out.points.swap(organized.points);
    return;
  }
  // Stride 2 and one-sided edges: the whole organized cloud is needed anyway.
  if (stride < 3 || settings.one_sided_at_edges) {
    out = subsample_with_normals(backproject_organized(depth, camera), stride, settings);
    return;
  }
  const Scalar cc = registration_detail::cos_crease(settings);
  const int k = settings.pixel_offset, w = depth.width(), h = depth.height();
  // Sized for every kept pixel and trimmed at the end: indexed writes instead of push_back.
  const int cols = (w + stride - 1) / stride;
  const std::size_t kept = std::size_t(cols) * std::size_t((h + stride - 1) / stride);
  binpick::detail::reserve_huge(out.points, kept);
  binpick::detail::reserve_huge(out.normals, kept);
  out.points.resize(kept);
  out.normals.resize(kept);
  std::size_t m = 0;
  // backproject_organized's points.
  const registration_detail::PixelBackprojector<Scalar, Camera> backproject(camera);
  // A kept row's pixels and their four neighbours as coordinate rows (entry j: column j × stride),
  // for organized_normals_pack, and the row's normals. Kept columns whose neighbours are inside
  // the image: j in [j0, j1).
  const int j0 = std::min(cols, (k + stride - 1) / stride);
  const int j1 = w - k - 1 >= 0 ? std::max(j0, std::min(cols, (w - k - 1) / stride + 1)) : j0;
  enum : int { kCentre, kLeft, kRight, kTop, kBottom };
  std::vector<Scalar> rows(std::size_t(15 + 4) * std::size_t(cols));  // and organized_normals_pack's raw rows
  std::vector<Vector3<Scalar>> row_normals(static_cast<std::size_t>(cols));
  // Coordinate row r from entry j_first on: n pixels of image row v from column u0, every stride-th.
  const auto fill = [&](int r, int j_first, int v, int u0, int n) {
    Scalar* x = rows.data() + std::size_t(3 * r) * std::size_t(cols) + std::size_t(j_first);
    backproject.row(depth, v, u0, stride, n, x, x + cols, x + 2 * cols);
  };
  const auto row = [&](int r) {
    const Scalar* x = rows.data() + std::size_t(3 * r) * std::size_t(cols);
    return registration_detail::RowXyz<Scalar>{x, x + cols, x + 2 * cols};
  };
  const registration_detail::RowXyz<Scalar> c = row(kCentre), lft = row(kLeft), rgt = row(kRight), top = row(kTop),
                                            bot = row(kBottom);
  for (int v = 0; v < h; v += stride) {
    const bool interior_row = v >= k && v + k < h;
    fill(kCentre, 0, v, 0, cols);
    if (interior_row) {
      const int u0 = j0 * stride, n = j1 - j0;
      fill(kLeft, j0, v, u0 - k, n);
      fill(kRight, j0, v, u0 + k, n);
      fill(kTop, j0, v - k, u0, n);
      fill(kBottom, j0, v + k, u0, n);
      int j = j0;
      detail::simd_call([&](auto bytes) BINPICK_SIMD_INLINE_LAMBDA {
        j = registration_detail::organized_normals_packs<Scalar, decltype(bytes)::value>(
            c, lft, rgt, top, bot, j0, j1, settings.max_depth_jump_ratio, cc, rows.data() + 15 * std::size_t(cols), cols,
            row_normals.data());
      });
      for (; j < j1; ++j) {  // the last few: organized_normal_interior on a patch
        // The centre and its four neighbours laid out for it: offsets ±1 (u), ±2 (v).
        const Vector3<Scalar> patch[5] = {{top.x[j], top.y[j], top.z[j]},
                                          {lft.x[j], lft.y[j], lft.z[j]},
                                          {c.x[j], c.y[j], c.z[j]},
                                          {rgt.x[j], rgt.y[j], rgt.z[j]},
                                          {bot.x[j], bot.y[j], bot.z[j]}};
        row_normals[std::size_t(j)] =
            registration_detail::organized_normal_interior(patch + 2, 1, 2, settings.max_depth_jump_ratio, cc);
      }
    }
    for (int j = 0; j < cols; ++j) {
      if (!(c.z[j] > Scalar(0))) continue;
      out.points[m] = Vector3<Scalar>(c.x[j], c.y[j], c.z[j]);
      // Central differences impossible at the border: no normal.
      out.normals[m++] = interior_row && j >= j0 && j < j1 ? row_normals[std::size_t(j)] : Vector3<Scalar>::Zero();
    }
  }
  out.points.resize(m);
  out.normals.resize(m);
}

/// subsample_with_normals from a depth image into a new cloud.
template <typename Scalar, typename Camera>
PointCloud<Scalar> subsample_with_normals(const DepthImageView<Scalar>& depth, const Camera& camera, int stride,
                                          const OrganizedNormalSettings<Scalar>& settings = {}) {
  PointCloud<Scalar> out;
  subsample_with_normals(depth, camera, stride, settings, out);
  return out;
}

template <typename Scalar>
struct KnnNormalSettings {
  int k = 10;                                         ///< neighbours per PCA (the point included), >= 3
  Vector3<Scalar> viewpoint = Vector3<Scalar>::Zero();  ///< normals point toward it [m]
  KdTreeSettings<Scalar> kdtree{};
  int num_threads = 1;  ///< 1 by default (see IcpSettings::num_threads); 0 = all cores
};

/// One normal per point of `points` (zero for non-finite points and where the neighbours are
/// collinear or fewer than 3). Throws std::invalid_argument for settings out of range.
template <typename Scalar>
std::vector<Vector3<Scalar>> estimate_knn_normals(const std::vector<Vector3<Scalar>>& points,
                                                  const KnnNormalSettings<Scalar>& settings = {}) {
  require(settings.k >= 3, "k", "must be >= 3");
  require_all_finite(settings.viewpoint, "viewpoint");
  const int threads = registration_detail::resolve_threads(settings.num_threads);
  std::vector<Vector3<Scalar>> normals(points.size(), Vector3<Scalar>::Zero());
  const KdTree<Scalar> tree(points, settings.kdtree);
  if (tree.size() < 3) return normals;
  std::vector<Scalar> queries;
  std::vector<std::size_t> ids;
  queries.reserve(points.size() * 3);
  for (std::size_t i = 0; i < points.size(); ++i)
    if (points[i].allFinite()) {
      queries.insert(queries.end(), points[i].data(), points[i].data() + 3);
      ids.push_back(i);
    }
  std::vector<std::ptrdiff_t> nn;
  std::vector<Scalar> d2;
  const int k = settings.k;
  tree.knn(queries.data(), ids.size(), k, threads, nn, d2);
  registration_detail::parallel_for(std::ptrdiff_t(ids.size()), threads, [&](std::ptrdiff_t qi) {
    // Covariance in double about the first neighbour's offset mean: stable for float input.
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    int count = 0;
    for (int j = 0; j < k; ++j) {
      const std::ptrdiff_t id = nn[std::size_t(qi) * k + j];
      if (id < 0) continue;
      mean += points[std::size_t(id)].template cast<double>();
      ++count;
    }
    if (count < 3) return;
    mean /= count;
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (int j = 0; j < k; ++j) {
      const std::ptrdiff_t id = nn[std::size_t(qi) * k + j];
      if (id < 0) continue;
      const Eigen::Vector3d d = points[std::size_t(id)].template cast<double>() - mean;
      cov += d * d.transpose();
    }
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
    const Eigen::Vector3d ev = es.eigenvalues();  // ascending
    // A line (two vanishing eigenvalues) has no normal.
    if (!(ev(1) > 1e-12 * ev(2)) || !(ev(2) > 0)) return;
    Eigen::Vector3d n = es.eigenvectors().col(0);
    const std::size_t i = ids[std::size_t(qi)];
    if (n.dot(settings.viewpoint.template cast<double>() - points[i].template cast<double>()) < 0) n = -n;
    if (n.allFinite()) normals[i] = n.normalized().template cast<Scalar>();
  });
  return normals;
}

}  // namespace binpick
