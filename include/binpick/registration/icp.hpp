#pragma once
/// \file icp.hpp
/// Iterative closest point: point-to-plane (Gauss–Newton on SE(3)) and point-to-point (closed form),
/// templated on the scalar and on the data-association strategy (correspondence.hpp). The paper
/// (§III.B.2, Fig. 3) refines the late, motion-corrupted poses of views 2..n against view 1 with
/// point-to-plane ICP before voting; this is that step, also usable on its own.
///
/// One iteration (kiss-icp's shape: associate, build the linear system, solve):
///  1. q_i = T p_i for the source points (every `stride`-th one);
///  2. partners y_i (normals n_i) from the association, within `max_correspondence_distance`;
///  3. point-to-plane: residual r_i = n_iᵀ(q_i − y_i), Jacobian J_i = [((q_i − c) × n_i)ᵀ, n_iᵀ] for a
///     left update about the centroid c of the moved source, or of every k-th point of a large one
///     (a centre at the points decouples rotation and translation; which one changes the step only to
///     second order), robust IRLS weight w(r_i); normal equations H δ = −g with H = Σ w J Jᵀ (6×6),
///     g = Σ w J r.  Point-to-point: weighted Kabsch/Umeyama (SVD of the cross-covariance).
///  4. T ← ΔT T; stop when ΔT rotates less than `rotation_epsilon` and moves the source centroid
///     less than `translation_epsilon`.
/// A large source is registered coarse to fine (IcpSettings::coarse_points): a subsample first (runs
/// of consecutive points, copied out once), then all points from its pose.
/// Degeneracy (point-to-plane): H is scaled to unit mean diagonal per block (rotation, translation);
/// eigen-directions whose eigenvalue is below `degeneracy_threshold` × the largest are unobservable
/// (e.g. sliding on one plane) and the update is confined to the observable subspace, so those
/// directions keep their initial value; the result then says `degenerate`. Point-to-point: paired
/// source points that are coincident leave every rotation unobservable, collinear ones the turn about
/// their line; those rotations are not applied, and the result says `degenerate` too.
/// Point-to-plane sums are formed in the caller's scalar over blocks of 256 points (gathered into
/// structure-of-arrays rows, by pack loads where consecutive, moved, paired and summed lane-wise in
/// SIMD packs, every rejection a lane mask; AVX2 chosen at run time, with FMA and AVX-512VL where the
/// CPU has them, core/simd_level.hpp) and added in double
/// (point-to-point sums in double), one accumulator per thread over fixed ranges of blocks, merged in
/// order: deterministic for a fixed thread count on a given CPU. Numerical failure is a status, never
/// an exception.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <type_traits>
#include <vector>

#include <Eigen/Geometry>
#include <Eigen/SVD>

#include "binpick/core/detail/simd.hpp"
#include "binpick/core/errors.hpp"
#include "binpick/core/pose.hpp"
#include "binpick/registration/correspondence.hpp"
#include "binpick/registration/detail/parallel.hpp"
#include "binpick/registration/detail/symmetric_eigen.hpp"
#include "binpick/registration/point_cloud.hpp"

namespace binpick {

enum class IcpMethod { point_to_plane, point_to_point };
enum class RobustKernel { none, huber, tukey };

enum class IcpStatus {
  /// the update fell below both epsilons, or led back to where the previous update started (a
  /// 2-cycle of partners flipping between two sets; the midpoint of the two poses is returned)
  converged,
  max_iterations,           ///< stopped at max_iterations before converging (pose is the last iterate)
  too_few_correspondences,  ///< fewer than min_correspondences partners (pose: last good iterate)
  degenerate,               ///< some directions unobservable (e.g. one plane); they were not moved
  diverged,                 ///< non-finite update or correction beyond the bounds (pose: the initial one)
};

inline const char* to_string(IcpStatus s) {
  switch (s) {
    case IcpStatus::converged: return "converged";
    case IcpStatus::max_iterations: return "max_iterations";
    case IcpStatus::too_few_correspondences: return "too_few_correspondences";
    case IcpStatus::degenerate: return "degenerate";
    default: return "diverged";
  }
}

template <typename Scalar>
struct IcpSettings {
  IcpMethod method = IcpMethod::point_to_plane;
  int max_iterations = 30;                           ///< >= 1
  Scalar max_correspondence_distance = Scalar(0.02);  ///< [m] partners farther away are ignored, > 0
  /// Tukey rejects gross outliers (occlusions, partners across depth edges) outright; Huber only
  /// bounds their pull and suits large initial errors where most residuals are still large.
  RobustKernel kernel = RobustKernel::tukey;
  Scalar kernel_scale = Scalar(0.01);  ///< [m] Huber threshold / Tukey's c, > 0 (unused with none)
  Scalar rotation_epsilon = Scalar(1e-5);     ///< [rad] convergence: update rotation below this ...
  /// [m] ... and it moves the source centroid less than this (10 µm: below, partners flipping at
  /// depth edges make the last digits oscillate rather than converge)
  Scalar translation_epsilon = Scalar(1e-5);
  int stride = 1;               ///< use every stride-th source point (>= 1)
  /// [rad] With source normals, a pair whose normals (source rotated into the target) differ by more
  /// than this is rejected, as are source points without a normal: partners across creases and
  /// occlusion edges then cannot bias the pose. Ignored without source normals.
  Scalar max_normal_angle = Scalar(0.25);
  int min_correspondences = 6;  ///< fewer partners -> too_few_correspondences (never below 6)
  /// Relative eigenvalue of the scaled normal equations below which a direction is unobservable.
  Scalar degeneracy_threshold = Scalar(1e-4);
  /// Bounds on the total correction (result relative to the initial pose); beyond -> diverged.
  Scalar max_correction_translation = std::numeric_limits<Scalar>::infinity();  ///< [m]
  Scalar max_correction_rotation = std::numeric_limits<Scalar>::infinity();     ///< [rad]
  /// 1 by default: one view's ICP takes milliseconds, and on a machine shared with other work extra
  /// threads mostly wait (measured: 0 = all cores made a single registration many times slower on a
  /// busy 2-core machine). 0 = all cores; the last bits of the result depend on the count (file comment).
  int num_threads = 1;
  /// Coarse to fine: when the (strided) source has more than 4 x coarse_points points, ICP first runs
  /// on about coarse_points of them (runs of 16 consecutive points spread over the source; 10 x the
  /// epsilons; at most half of max_iterations), then on all of them from that pose, so the result is
  /// still that of the full source. What it saves is the cost of the first iterations, which for the
  /// kd-tree association grows with the source's distance from the target (a 640 x 480 pair 3 mm /
  /// 1 deg off, 1 thread: one stage 630-640 ms in 3 iterations; coarse to fine 215-235 ms in 3 in
  /// all, one of them on the full source; same pose and RMSE). `iterations` and max_iterations count
  /// both stages. 0 = one stage.
  int coarse_points = 20000;
};

template <typename Scalar>
struct IcpResult {
  Isometry3<Scalar> T_target_source = Isometry3<Scalar>::Identity();  ///< maps source points into the target
  IcpStatus status = IcpStatus::too_few_correspondences;
  /// [m] root mean square residual of the last association's inliers (point-to-plane distance or
  /// Euclidean distance, by method); 0 when there were none.
  Scalar rmse = Scalar(0);
  std::size_t inliers = 0;        ///< partners of the last association
  int iterations = 0;             ///< associations made
  /// unobservable directions in the last solve (point-to-point: rotations about coincident or
  /// collinear paired source points)
  int degenerate_directions = 0;
  /// True when the pose is usable: converged, or degenerate (best pose in the observable subspace).
  bool ok() const { return status == IcpStatus::converged || status == IcpStatus::degenerate; }
};

/// Scratch memory of icp(): the coarse stage's copy of the source and the batch path's arrays (the
/// point-to-plane pass over a point-wise association, e.g. projective, needs only the copy: about
/// 0.5 MB for a 640 x 480 source). Pass one to icp() and keep it
/// across calls (one per thread): only the first call allocates, so a camera loop runs without heap
/// traffic. (On the 640 x 480 benchmark pair the time per call was the same within the host's noise:
/// the allocator already reuses blocks of this size.) The source given to icp() must not live in the
/// workspace.
template <typename Scalar>
struct IcpWorkspace {
  std::vector<std::uint32_t> kept;      ///< batch path: indices of the usable source points
  std::vector<Vector3<Scalar>> moved;   ///< batch path: the moved source points
  std::vector<std::ptrdiff_t> partners; ///< batch path: their partners
  PointCloud<Scalar> coarse;            ///< the coarse stage's points (IcpSettings::coarse_points)
};

namespace registration_detail {

template <typename T>
T robust_weight(RobustKernel kernel, T r, T k) {
  const T a = std::abs(r);
  switch (kernel) {
    case RobustKernel::huber: return a <= k ? T(1) : k / a;
    case RobustKernel::tukey: {
      if (a >= k) return T(0);
      const T t = T(1) - (a / k) * (a / k);
      return t * t;
    }
    default: return T(1);
  }
}

/// Points per block of the point-to-plane sums: each block is summed in the caller's scalar (float
/// stays accurate over a few hundred terms) and blocks are added in double, so float callers get
/// float-speed inner loops and double-accurate totals.
constexpr std::ptrdiff_t kPlaneBlock = 256;

/// Points the rotation centre of the fused point-to-plane pass is averaged from (icp_one_scale).
constexpr std::size_t kCentroidPoints = 4096;

/// Consecutive source points per run of the coarse stage's subsample (icp()): whole packs at every
/// SIMD level (the widest holds 8 floats or 4 doubles), so a run's partners are mostly read by pack
/// loads.
constexpr std::ptrdiff_t kCoarseRun = 16;

/// The 21 upper-triangle terms of Σ w J Jᵀ (row-major), the 6 of Σ w r J, Σ r² and the count of one
/// block, in Scalar.
template <typename Scalar>
struct PlaneBlockSums {
  Scalar h[21] = {};
  Scalar g[6] = {};
  Scalar sum_sq = Scalar(0);
  std::size_t count = 0;
};

/// One block of source points and their partners as structure-of-arrays rows, padded to the widest
/// pack: the source point p and normal ns (moved into the target frame in place, q = R p + t and
/// R ns), the partner index and the partner's point y and normal nt (zero normal = no partner).
template <typename Scalar>
struct PairBlock {
  static constexpr int kSize = int(kPlaneBlock) + 32 / int(sizeof(Scalar));
  alignas(64) Scalar p[3][kSize];
  alignas(64) Scalar ns[3][kSize];
  alignas(64) Scalar y[3][kSize];
  alignas(64) Scalar nt[3][kSize];
  alignas(64) Scalar use[kSize];  ///< 1 for a usable source point (finite, with a normal if normals are used), else 0
  std::ptrdiff_t partner[kSize];
};

/// What the vectorized point-to-plane pass needs of the iterate and the settings.
template <typename Scalar>
struct PlaneParams {
  Scalar R[3][3], t[3];
  Scalar c[3];              ///< centroid of the moved source (the rotation's centre)
  bool check_normals;       ///< reject pairs whose normals differ by more than acos(cos_normal)
  Scalar cos_normal;
  Scalar max_distance;
  bool check_partner;       ///< pixel partners: test here that y is valid and within max_distance
  RobustKernel kernel;
  Scalar k;
};

BINPICK_SIMD_BEGIN

/// Marks the usable source points of the first `padded` rows (a multiple of the pack size) in `use`
/// (finite, and with a unit normal when normals are checked), zeroes the others, and moves them in
/// place: q = R p + t and R ns.
template <typename Scalar, int Bytes>
BINPICK_SIMD_INLINE void move_rows(PairBlock<Scalar>& b, int padded, const PlaneParams<Scalar>& prm) {
  using P = detail::Pack<Scalar, Bytes>;
  using V = typename P::type;
  using Mask = typename P::mask;
  V R[3][3];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) R[r][c] = P::splat(prm.R[r][c]);
  const V t0 = P::splat(prm.t[0]), t1 = P::splat(prm.t[1]), t2 = P::splat(prm.t[2]);
  const V zero = P::splat(Scalar(0)), one = P::splat(Scalar(1)), half = P::splat(Scalar(0.5));
  const V big = P::splat(std::numeric_limits<Scalar>::max());
  const auto finite = [&](const V& v) BINPICK_SIMD_INLINE_LAMBDA { return P::select(v < zero, -v, v) <= big; };
  for (int i = 0; i < padded; i += P::size) {
    V x = P::load(b.p[0] + i), y = P::load(b.p[1] + i), z = P::load(b.p[2] + i);
    Mask ok = finite(x) & finite(y) & finite(z);
    V nx = zero, ny = zero, nz = zero;
    if (prm.check_normals) {
      nx = P::load(b.ns[0] + i);
      ny = P::load(b.ns[1] + i);
      nz = P::load(b.ns[2] + i);
      ok &= (nx * nx + ny * ny + nz * nz >= half) & finite(nx) & finite(ny) & finite(nz);
    }
    x = P::select(ok, x, zero);
    y = P::select(ok, y, zero);
    z = P::select(ok, z, zero);
    P::store(b.use + i, P::select(ok, one, zero));
    P::store(b.p[0] + i, R[0][0] * x + R[0][1] * y + R[0][2] * z + t0);
    P::store(b.p[1] + i, R[1][0] * x + R[1][1] * y + R[1][2] * z + t1);
    P::store(b.p[2] + i, R[2][0] * x + R[2][1] * y + R[2][2] * z + t2);
    if (!prm.check_normals) continue;
    nx = P::select(ok, nx, zero);
    ny = P::select(ok, ny, zero);
    nz = P::select(ok, nz, zero);
    P::store(b.ns[0] + i, R[0][0] * nx + R[0][1] * ny + R[0][2] * nz);
    P::store(b.ns[1] + i, R[1][0] * nx + R[1][1] * ny + R[1][2] * nz);
    P::store(b.ns[2] + i, R[2][0] * nx + R[2][1] * ny + R[2][2] * nz);
  }
}

/// Σ w J Jᵀ (upper triangle), Σ w r J, Σ r² and the count of the kept pairs among the first `padded`
/// rows of a moved block (file comment, step 3). Every rule of pairing is a lane mask here: a
/// rejected pair contributes zeros, so no branch depends on the data.
/// Two passes: the Jacobian rows, residual and weight of every pair go to rows in L1 first, then the
/// 28 sums are formed in three sweeps of at most 13 running packs each. One sweep with all 28 running
/// packs spills most of them on every pair where a machine has 16 vector registers (AVX2): on the
/// 640 x 480 projective pair (AMD Zen 3, 1 thread) that sweep took ICP's full-resolution iteration
/// from 3.5 to 3.1 ms.
template <typename Scalar, int Bytes>
BINPICK_SIMD_INLINE PlaneBlockSums<Scalar> plane_sums(const PairBlock<Scalar>& b, int padded,
                                                      const PlaneParams<Scalar>& prm) {
  using P = detail::Pack<Scalar, Bytes>;
  using V = typename P::type;
  using Mask = typename P::mask;
  constexpr int L = P::size;
  const V zero = P::splat(Scalar(0)), one = P::splat(Scalar(1)), half = P::splat(Scalar(0.5));
  const V cos_n = P::splat(prm.cos_normal), max_d = P::splat(prm.max_distance);
  const V max_d2 = max_d * max_d, k = P::splat(prm.k);
  const V c0 = P::splat(prm.c[0]), c1 = P::splat(prm.c[1]), c2 = P::splat(prm.c[2]);
  // Rows 0-5: J (zero for rejected pairs), 6: r (zero likewise), 7: w (zero likewise).
  alignas(64) Scalar rows[8][PairBlock<Scalar>::kSize];
  V count = zero;
  for (int i = 0; i < padded; i += L) {
    const V qx = P::load(b.p[0] + i), qy = P::load(b.p[1] + i), qz = P::load(b.p[2] + i);
    V nx = P::load(b.nt[0] + i), ny = P::load(b.nt[1] + i), nz = P::load(b.nt[2] + i);
    const V ex = qx - P::load(b.y[0] + i), ey = qy - P::load(b.y[1] + i), ez = qz - P::load(b.y[2] + i);
    Mask ok = (P::load(b.use + i) > zero) & (nx * nx + ny * ny + nz * nz >= half);  // a partner with a known normal
    if (prm.check_normals)
      ok &= P::load(b.ns[0] + i) * nx + P::load(b.ns[1] + i) * ny + P::load(b.ns[2] + i) * nz >= cos_n;
    if (prm.check_partner) ok &= (P::load(b.y[2] + i) > zero) & (ex * ex + ey * ey + ez * ez <= max_d2);
    V r = nx * ex + ny * ey + nz * ez;
    const V a = P::select(r < zero, -r, r);
    ok &= a <= max_d;
    // Zeros in the rejected lanes (their partner may be missing, or hold NaN).
    r = P::select(ok, r, zero);
    nx = P::select(ok, nx, zero);
    ny = P::select(ok, ny, zero);
    nz = P::select(ok, nz, zero);
    V w;
    switch (prm.kernel) {
      case RobustKernel::huber: w = P::select(a <= k, one, k / P::select(a > zero, a, one)); break;
      case RobustKernel::tukey: {
        const V t = one - (a / k) * (a / k);
        w = P::select(a < k, t * t, zero);
        break;
      }
      default: w = one;
    }
    count += P::select(ok, one, zero);
    const V dx = qx - c0, dy = qy - c1, dz = qz - c2;
    P::store(rows[0] + i, dy * nz - dz * ny);
    P::store(rows[1] + i, dz * nx - dx * nz);
    P::store(rows[2] + i, dx * ny - dy * nx);
    P::store(rows[3] + i, nx);
    P::store(rows[4] + i, ny);
    P::store(rows[5] + i, nz);
    P::store(rows[6] + i, r);
    P::store(rows[7] + i, P::select(ok, w, zero));
  }
  PlaneBlockSums<Scalar> out;
  // Upper-triangle entry (a, c) of h, a <= c <= 5.
  const auto at = [](int a, int c) { return a * 6 - a * (a - 1) / 2 + (c - a); };
  // Rows a0 and a1 of Σ w J Jᵀ (from the diagonal on) and entries a0, a1 of Σ w r J; with the last
  // pair of rows (a1 = 5) also Σ r².
  const auto sweep = [&](auto first) BINPICK_SIMD_INLINE_LAMBDA {
    constexpr int a0 = decltype(first)::value, a1 = a0 + 1, n0 = 6 - a0, n1 = 6 - a1;
    constexpr bool last = a1 == 5;
    V s0[n0], s1[n1], g0 = zero, g1 = zero, sq = zero;
    for (V& v : s0) v = zero;
    for (V& v : s1) v = zero;
    for (int i = 0; i < padded; i += L) {
      const V w = P::load(rows[7] + i), r = P::load(rows[6] + i);
      const V w0 = w * P::load(rows[a0] + i), w1 = w * P::load(rows[a1] + i);
      for (int c = 0; c < n0; ++c) s0[c] += w0 * P::load(rows[a0 + c] + i);
      for (int c = 0; c < n1; ++c) s1[c] += w1 * P::load(rows[a1 + c] + i);
      g0 += w0 * r;
      g1 += w1 * r;
      if constexpr (last) sq += r * r;
    }
    for (int l = 0; l < L; ++l) {  // lanes in a fixed order: deterministic
      for (int c = 0; c < n0; ++c) out.h[at(a0, a0 + c)] += s0[c][l];
      for (int c = 0; c < n1; ++c) out.h[at(a1, a1 + c)] += s1[c][l];
      out.g[a0] += g0[l];
      out.g[a1] += g1[l];
      if constexpr (last) out.sum_sq += sq[l];
    }
  };
  sweep(std::integral_constant<int, 0>());
  sweep(std::integral_constant<int, 2>());
  sweep(std::integral_constant<int, 4>());
  Scalar kept = Scalar(0);
  for (int l = 0; l < L; ++l) kept += count[l];
  out.count = std::size_t(kept);
  return out;
}

/// rows_a[d][i + l] = a[3 index[l] + d] (d = 0, 1, 2) for the lanes of `ok`, else 0, and the same
/// from `b` into rows_b when b is not null (points and their normals share the indices): a pack of
/// 3-vectors gathered from arrays of them (lanes not in `ok` read nothing). When the lanes are L
/// consecutive 3-vectors (the source walked in order; most projective partners, as neighbouring
/// pixels pair with neighbouring pixels) they are read with pack loads and transposed (Pack::load3);
/// else a lane at a time. Measured on 640 x 480 (projective, 307 k points, AMD Zen 5): one ICP
/// iteration 3.9 ms with three AVX2 gathers per row, 3.0 ms a lane at a time (the partners of a
/// block lie in a few rows of the target, and per lane the three values share a cache line);
/// consecutive packs loaded whole (73 % of the partner packs there) took the registration from
/// 4.0-4.6 to 3.6-4.2 ms. Not better either: hardware gathers for the other packs (+2 %), and two
/// pack loads and lane permutations for lanes within two windows of L (+4 %).
template <typename Scalar, int Bytes>
BINPICK_SIMD_INLINE void gather_xyz(const Scalar* a, const Scalar* b,
                                    const typename detail::Pack<Scalar, Bytes>::mask& index,
                                    const typename detail::Pack<Scalar, Bytes>::mask& ok,
                                    Scalar (&rows_a)[3][PairBlock<Scalar>::kSize],
                                    Scalar (&rows_b)[3][PairBlock<Scalar>::kSize], int i) {
  using P = detail::Pack<Scalar, Bytes>;
  using Mask = typename P::mask;
  using Index = typename std::remove_reference<decltype(Mask()[0])>::type;
  constexpr int L = P::size;
  Mask lane;  // a constant: folded at compile time
  for (int l = 0; l < L; ++l) lane[l] = Index(l);
  const Mask start = index - lane;  // index[0] in every lane of a consecutive pack
  if (P::none((start != start[0]) | ~ok)) {
    const std::ptrdiff_t e = 3 * std::ptrdiff_t(index[0]);
    P::load3(a + e, rows_a[0] + i, rows_a[1] + i, rows_a[2] + i);
    if (b) P::load3(b + e, rows_b[0] + i, rows_b[1] + i, rows_b[2] + i);
    return;
  }
  for (int l = 0; l < L; ++l) {
    const std::ptrdiff_t e = ok[l] ? 3 * std::ptrdiff_t(index[l]) : 0;
    for (int d = 0; d < 3; ++d) rows_a[d][i + l] = ok[l] ? a[e + d] : Scalar(0);
    if (b)
      for (int d = 0; d < 3; ++d) rows_b[d][i + l] = ok[l] ? b[e + d] : Scalar(0);
  }
}

BINPICK_SIMD_END

struct PlaneAccumulator {
  Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();
  double sum_sq = 0;
  std::size_t count = 0;
  void merge(const PlaneAccumulator& o) {
    H += o.H;
    g += o.g;
    sum_sq += o.sum_sq;
    count += o.count;
  }
  template <typename Scalar>
  void add(const PlaneBlockSums<Scalar>& b) {
    int k = 0;
    for (int a = 0; a < 6; ++a) {
      for (int c = a; c < 6; ++c) H(a, c) += double(b.h[k++]);
      g(a) += double(b.g[a]);
    }
    sum_sq += double(b.sum_sq);
    count += b.count;
  }
};

struct PointAccumulator {
  double w = 0;
  Eigen::Vector3d sq = Eigen::Vector3d::Zero(), sy = Eigen::Vector3d::Zero();
  Eigen::Matrix3d sqy = Eigen::Matrix3d::Zero(), sqq = Eigen::Matrix3d::Zero();
  double sum_sq = 0;
  std::size_t count = 0;
  void merge(const PointAccumulator& o) {
    w += o.w;
    sq += o.sq;
    sy += o.sy;
    sqy += o.sqy;
    sqq += o.sqq;
    sum_sq += o.sum_sq;
    count += o.count;
  }
};

/// Solves H δ = −g in the observable subspace (see the file comment). Returns the number of
/// unobservable directions; δ = [ω (rotation about c), v (translation)].
inline int solve_observable(const Eigen::Matrix<double, 6, 6>& H, const Eigen::Matrix<double, 6, 1>& g,
                            double threshold, Eigen::Matrix<double, 6, 1>& delta) {
  using Mat6 = Eigen::Matrix<double, 6, 6>;
  using Vec6 = Eigen::Matrix<double, 6, 1>;
  // Block-isotropic scaling keeps "not moved" meaningful: a null direction of pure translation stays
  // orthogonal to the update in the metric of metres.
  const double tr_r = H.topLeftCorner<3, 3>().trace() / 3, tr_t = H.bottomRightCorner<3, 3>().trace() / 3;
  const double s_r = tr_r > 0 ? 1 / std::sqrt(tr_r) : 0, s_t = tr_t > 0 ? 1 / std::sqrt(tr_t) : 0;
  Vec6 d;
  d << s_r, s_r, s_r, s_t, s_t, s_t;
  const Mat6 Hs = d.asDiagonal() * H * d.asDiagonal();
  const Vec6 gs = d.asDiagonal() * g;
  Vec6 lambda;  // ascending
  Mat6 vectors;
  symmetric_eigen<6>(Hs, lambda, vectors);
  const double lmax = lambda(5);
  Vec6 ds = Vec6::Zero();
  int unobservable = 0;
  for (int i = 0; i < 6; ++i) {
    if (!(lmax > 0) || !(lambda(i) > threshold * lmax)) {
      ++unobservable;
      continue;
    }
    const auto vi = vectors.col(i);
    ds -= vi * (vi.dot(gs) / lambda(i));
  }
  delta = d.asDiagonal() * ds;
  return unobservable;
}

template <typename Scalar>
Isometry3<Scalar> orthonormalized(const Isometry3<Scalar>& T) {
  Isometry3<Scalar> out = Isometry3<Scalar>::Identity();
  out.linear() = Eigen::Quaternion<Scalar>(T.linear()).normalized().toRotationMatrix();
  out.translation() = T.translation();
  return out;
}

/// The smallest rotation taking the unit vector a to the unit vector b (Rodrigues about a × b); for
/// opposite vectors, the half turn about an axis perpendicular to a. Written out instead of Eigen's
/// Quaternion::FromTwoVectors, whose SVD fallback cost about 5 s of compile time in every file that
/// instantiates ICP.
inline Eigen::Matrix3d rotation_between(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const Eigen::Vector3d v = a.cross(b);
  const double c = a.dot(b), s2 = v.squaredNorm();
  if (s2 < 1e-24) {
    if (c > 0) return Eigen::Matrix3d::Identity();
    const Eigen::Vector3d u = a.unitOrthogonal();
    return 2 * u * u.transpose() - Eigen::Matrix3d::Identity();
  }
  Eigen::Matrix3d K;
  K << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return Eigen::Matrix3d::Identity() + K + K * K * ((1 - c) / s2);
}

/// The normal rule of pairing: the source normal ns, rotated into the target frame by R, and the target
/// normal nt differ by at most the angle whose cosine is cos_max. Written on components: Eigen's fixed
/// 3-vector expressions cost several times more in the point-to-plane loop.
template <typename Scalar>
inline bool normals_agree(const Eigen::Matrix<Scalar, 3, 3>& R, const Scalar* ns, const Scalar* nt, Scalar cos_max) {
  const Scalar rx = R(0, 0) * ns[0] + R(0, 1) * ns[1] + R(0, 2) * ns[2];
  const Scalar ry = R(1, 0) * ns[0] + R(1, 1) * ns[1] + R(1, 2) * ns[2];
  const Scalar rz = R(2, 0) * ns[0] + R(2, 1) * ns[1] + R(2, 2) * ns[2];
  return rx * nt[0] + ry * nt[1] + rz * nt[2] >= cos_max;
}

/// icp() at one scale (IcpSettings::coarse_points ignored), starting from `T_start`; the correction
/// bounds, and the pose a diverged run returns, refer to the caller's `T_target_source_init`.
template <typename Scalar, typename Association>
IcpResult<Scalar> icp_one_scale(const PointCloud<Scalar>& source, const Association& association,
                                const Isometry3<Scalar>& T_target_source_init, const Isometry3<Scalar>& T_start,
                                const IcpSettings<Scalar>& settings, IcpWorkspace<Scalar>& workspace) {
  const std::vector<Vector3<Scalar>>& source_points = source.points;
  static_assert(is_association<Association>::value, "Association must model the concept in correspondence.hpp");
  static_assert(std::is_same<typename Association::Scalar, Scalar>::value, "Association::Scalar must match");
  namespace rd = registration_detail;
  require(settings.max_iterations >= 1, "max_iterations", "must be >= 1");
  require(std::isfinite(settings.max_correspondence_distance) && settings.max_correspondence_distance > 0,
          "max_correspondence_distance", "must be finite and > 0");
  require(std::isfinite(settings.kernel_scale) && settings.kernel_scale > 0, "kernel_scale", "must be finite and > 0");
  require(std::isfinite(settings.rotation_epsilon) && settings.rotation_epsilon >= 0, "rotation_epsilon",
          "must be finite and >= 0");
  require(std::isfinite(settings.translation_epsilon) && settings.translation_epsilon >= 0, "translation_epsilon",
          "must be finite and >= 0");
  require(settings.stride >= 1, "stride", "must be >= 1");
  require(std::isfinite(settings.max_normal_angle) && settings.max_normal_angle > 0, "max_normal_angle",
          "must be finite and > 0");
  require(source.normals.empty() || source.normals.size() == source.points.size(), "source",
          "normals must be empty or one per point");
  require(std::isfinite(settings.degeneracy_threshold) && settings.degeneracy_threshold >= 0 &&
              settings.degeneracy_threshold < 1,
          "degeneracy_threshold", "must be in [0, 1)");
  require(!(settings.max_correction_translation <= 0), "max_correction_translation", "must be > 0");
  require(!(settings.max_correction_rotation <= 0), "max_correction_rotation", "must be > 0");
  require_valid_pose(T_target_source_init, "T_target_source_init");
  const bool plane = settings.method == IcpMethod::point_to_plane;
  require(!plane || association.has_target_normals(), "association",
          "point-to-plane ICP needs target normals");
  const int threads = rd::resolve_threads(settings.num_threads);
  const std::size_t min_corr = std::size_t(std::max(6, settings.min_correspondences));

  IcpResult<Scalar> result;
  result.T_target_source = T_start;

  const bool use_normals = source.has_normals();
  require(source_points.size() <= std::size_t(std::numeric_limits<std::uint32_t>::max()), "source",
          "more than 2^32 - 1 points");
  const std::size_t stride = std::size_t(settings.stride), total = source_points.size();
  const std::size_t strided = (total + stride - 1) / stride;
  // Point-to-plane over a point-wise association (correspondence.hpp) moves, associates and sums
  // each block of the strided source in one pass, straight from the caller's arrays: no arrays of
  // source size at all, and whether a point is usable is a lane mask of the pass. (Listing the usable
  // points in the first iteration for the later ones cost more than walking the few unusable ones
  // again: the list is a scalar loop, and its gaps break the pack loads of consecutive points.)
  // Otherwise the usable points are listed first and moved and associated in batches.
  constexpr bool pointwise = has_point_partner<Association>::value;
  const bool fused = plane && pointwise;
  // A point is used when finite and, with source normals, when it has one (a point without a normal,
  // likely on an edge, could never pair: see compatible() below).
  const Scalar finite_max = std::numeric_limits<Scalar>::max();
  // The tests are combined with & on ints, not &&: no branch per test.
  const auto within = [&](Scalar v) { return int(std::abs(v) <= finite_max); };
  const auto usable = [&](std::size_t i) {
    const Scalar* p = source_points[i].data();
    int ok = within(p[0]) & within(p[1]) & within(p[2]);
    if (use_normals) {  // a unit normal (the norm test fails for NaN, the bounds for inf)
      const Scalar* nrm = source.normals[i].data();
      ok &= int(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2] >= Scalar(0.5)) & within(nrm[0]) & within(nrm[1]) &
            within(nrm[2]);
    }
    return ok != 0;
  };
  // The batch path: the indices of the usable points among every stride-th one, found once (4 bytes a
  // point instead of a copy of points and normals), branch-free. The centroid (the rotation centre c)
  // sums every usable point of the batch path; the fused path sums those among every k-th strided
  // point, k = ceil(strided / kCentroidPoints) (the step is the same to first order for any centre
  // near the points), in Scalar over blocks and in double across them.
  std::vector<std::uint32_t>& kept = workspace.kept;
  if (!fused && kept.size() < strided) kept.resize(strided);
  std::size_t used = 0;
  Eigen::Vector3d centroid_src = Eigen::Vector3d::Zero();
  const std::size_t centroid_step = fused ? stride * ((strided + kCentroidPoints - 1) / kCentroidPoints) : stride;
  for (std::size_t i = 0; i < total;) {
    Scalar sum[3] = {Scalar(0), Scalar(0), Scalar(0)};
    for (std::ptrdiff_t q = 0; q < rd::kPlaneBlock && i < total; ++q, i += centroid_step) {
      const bool ok = usable(i);
      if (!fused) kept[used] = std::uint32_t(i);
      used += ok;
      for (int d = 0; d < 3; ++d) sum[d] += ok ? source_points[i](d) : Scalar(0);
    }
    centroid_src += Eigen::Vector3d(double(sum[0]), double(sum[1]), double(sum[2]));
  }
  if (!fused) kept.resize(used);
  if (!fused && used < min_corr) return result;
  if (used > 0) centroid_src /= double(used);
  // Source point s of the pass: the s-th strided one (fused), or the s-th of the list.
  const bool listed = !fused;
  const auto src_index = [&](std::ptrdiff_t s) { return listed ? std::size_t(kept[std::size_t(s)]) : std::size_t(s) * stride; };
  const auto src = [&](std::ptrdiff_t s) -> const Vector3<Scalar>& { return source_points[src_index(s)]; };
  const auto src_normal = [&](std::ptrdiff_t s) -> const Scalar* {
    return use_normals ? source.normals[src_index(s)].data() : nullptr;
  };

  const double max_d = double(settings.max_correspondence_distance), k = double(settings.kernel_scale);
  const double degeneracy = double(settings.degeneracy_threshold);
  const Scalar cos_normal = Scalar(std::cos(std::min(double(settings.max_normal_angle), 3.14159265358979323846)));
  const bool check_normals = use_normals && association.has_target_normals();
  // Is the pair (source i with a normal — usable() — and target j) compatible by its normals, under the
  // rotation R_ts of the current pose? A target point without a normal passes.
  const auto compatible = [&](const Eigen::Matrix<Scalar, 3, 3>& R_ts, std::ptrdiff_t i, std::ptrdiff_t j) {
    if (!check_normals) return true;
    const Vector3<Scalar>& nt = association.target_normal(j);
    return nt.squaredNorm() < Scalar(0.5) || rd::normals_agree(R_ts, src_normal(i), nt.data(), cos_normal);
  };
  Eigen::Isometry3d T = T_start.template cast<double>();
  std::vector<Vector3<Scalar>>& moved = workspace.moved;
  if (!fused) moved.resize(kept.size());
  std::vector<std::ptrdiff_t>& partners = workspace.partners;
  const std::ptrdiff_t n = std::ptrdiff_t(fused ? strided : kept.size());  // points of the pass
  bool converged = false;
  Eigen::Isometry3d T_before = T;  // where the previous update started: a 2-cycle ends the loop (below)

  for (int it = 1; it <= settings.max_iterations; ++it) {
    // R p + t written out: Transform's operator* goes through homogeneous coordinates.
    const Eigen::Matrix<Scalar, 3, 3> Rm = T.linear().cast<Scalar>();
    const Vector3<Scalar> tm = T.translation().cast<Scalar>();
    if (!fused) {
      rd::parallel_for(n, threads, [&](std::ptrdiff_t i) { moved[std::size_t(i)].noalias() = Rm * src(i) + tm; });
      association.associate(moved, settings.max_correspondence_distance, threads, partners);
    }
    result.iterations = it;

    Eigen::Isometry3d dT = Eigen::Isometry3d::Identity();
    const Eigen::Vector3d c = T * centroid_src;
    const Eigen::Matrix<Scalar, 3, 3> Rs = T.linear().cast<Scalar>();
    if (plane) {
      // The hot loop in Scalar (see kPlaneBlock); r_i and J_i as in the file comment, step 3.
      rd::PlaneParams<Scalar> prm;
      for (int r = 0; r < 3; ++r) {
        for (int col = 0; col < 3; ++col) prm.R[r][col] = Rm(r, col);
        prm.t[r] = tm(r);
        prm.c[r] = Scalar(c(r));
      }
      prm.check_normals = check_normals;
      prm.cos_normal = cos_normal;
      prm.max_distance = settings.max_correspondence_distance;
      prm.kernel = settings.kernel;
      prm.k = settings.kernel_scale;
      // Pixel partners: the association projects a pack of points at a time and its remaining tests
      // (valid partner within max_distance) are lane masks of the sums (correspondence.hpp).
      bool pixels = false;
      if constexpr (has_pixel_partner<Association>::value) pixels = association.pixel_partner();
      prm.check_partner = pixels;
      // A block: gather the source rows, move them (SIMD), find partners (SIMD projection, or a scalar
      // call per point), gather the partners' rows, and sum (SIMD, file comment). Rows are gathered a
      // pack at a time (gather_xyz: pack loads where the points are consecutive) from the source's
      // arrays and, through the optional storage members (correspondence.hpp), the target's, while the
      // element offsets 3 i + 2 fit the index lanes (32-bit for float); else one point at a time.
      const Scalar* tgt_p = nullptr;
      const Scalar* tgt_n = nullptr;
      bool gathers = false;
      std::ptrdiff_t target_total = 0;  // target points (gathers only)
      if constexpr (has_target_arrays<Association>::value) {
        static_assert(sizeof(Vector3<Scalar>) == 3 * sizeof(Scalar), "3-vectors must be packed");
        tgt_p = association.target_points_data()->data();
        tgt_n = association.target_normals_data() ? association.target_normals_data()->data() : nullptr;
        const std::size_t lanes_max = std::size_t(std::numeric_limits<std::int32_t>::max() / 3);
        gathers = tgt_n != nullptr && association.target_count() < lanes_max && total < lanes_max;
        target_total = std::ptrdiff_t(association.target_count());
      }
      const Scalar* src_p = source_points.empty() ? nullptr : source_points.data()->data();
      const Scalar* src_n = use_normals ? source.normals.data()->data() : nullptr;
      const auto block_sums = [&](rd::PlaneAccumulator& acc, std::ptrdiff_t b) {
        rd::PairBlock<Scalar> blk;
        const std::ptrdiff_t first = b * rd::kPlaneBlock;
        const int count = int(std::min(n, first + rd::kPlaneBlock) - first);
        if (!gathers) {
          for (int s = 0; s < count; ++s) {
            const Scalar* p = src(first + s).data();
            blk.p[0][s] = p[0];
            blk.p[1][s] = p[1];
            blk.p[2][s] = p[2];
          }
          if (check_normals)
            for (int s = 0; s < count; ++s) {
              const Scalar* nrm = src_normal(first + s);
              blk.ns[0][s] = nrm[0];
              blk.ns[1][s] = nrm[1];
              blk.ns[2][s] = nrm[2];
            }
        }
        rd::PlaneBlockSums<Scalar> sums;
        detail::simd_call_fused([&](auto bytes) BINPICK_SIMD_INLINE_LAMBDA {
          constexpr int Bytes = decltype(bytes)::value;
          using P = detail::Pack<Scalar, Bytes>;
          using Mask = typename P::mask;
          using Index = typename std::remove_reference<decltype(Mask()[0])>::type;
          constexpr int L = P::size;
          const int padded = (count + L - 1) / L * L;
          if (gathers) {
            Mask lane;
            for (int l = 0; l < L; ++l) lane[l] = Index(l);
            for (int i = 0; i < padded; i += L) {
              const Mask ok = lane + Index(i) < Index(count);
              Mask index;
              if (!listed) {
                index = (lane + Index(first + i)) * Index(stride);
              } else if (i + L <= count) {  // L list entries (< 2^31 / 3: gathers)
                typename detail::Lanes<std::uint32_t, L>::type k;
                std::memcpy(&k, kept.data() + first + i, sizeof k);
                index = __builtin_convertvector(k, Mask);
              } else {
                for (int l = 0; l < L; ++l) index[l] = i + l < count ? Index(kept[std::size_t(first + i + l)]) : Index(0);
              }
              rd::gather_xyz<Scalar, Bytes>(src_p, check_normals ? src_n : nullptr, index, ok, blk.p, blk.ns, i);
            }
          } else {
            for (int s = count; s < padded; ++s)  // padding: no partner
              for (int d = 0; d < 3; ++d) blk.p[d][s] = blk.ns[d][s] = Scalar(0);
          }
          rd::move_rows<Scalar, Bytes>(blk, padded, prm);
          for (int s = count; s < padded; ++s) blk.use[s] = Scalar(0);
          if constexpr (has_pixel_partner<Association>::value) {
            if (pixels) association.template project_queries<Bytes>(blk.p[0], blk.p[1], blk.p[2], padded, blk.partner);
          }
          if (!pixels) {
            for (int s = 0; s < count; ++s) {
              if constexpr (pointwise)
                blk.partner[s] = blk.use[s] > Scalar(0)
                                     ? association.partner(Vector3<Scalar>(blk.p[0][s], blk.p[1][s], blk.p[2][s]),
                                                           settings.max_correspondence_distance)
                                     : -1;
              else
                blk.partner[s] = partners[std::size_t(first + s)];
            }
          }
          for (int s = count; s < padded; ++s) blk.partner[s] = -1;
          if (gathers && pixels) {
            // Neighbouring source points pair with neighbouring target pixels, so the blocks after
            // this one will most likely pair past its last partner: ask for the target rows two
            // blocks ahead now. Measured (640 x 480 projective pair, 1 thread, interleaved medians):
            // ICP 3.08 -> 2.92 ms and 4.36 -> 4.01 ms (one block ahead 2-4 % less, three 5 %).
            std::ptrdiff_t last = -1;
            for (int s = count - 1; s >= 0 && last < 0; --s) last = blk.partner[s];
            if (last >= 0) {
              constexpr std::ptrdiff_t ahead = 2 * rd::kPlaneBlock, line = 64 / std::ptrdiff_t(sizeof(Scalar));
              const std::ptrdiff_t end = std::min(last + 1 + ahead + rd::kPlaneBlock, target_total);
              for (std::ptrdiff_t e = 3 * (last + 1 + ahead); e < 3 * end; e += line) {
                __builtin_prefetch(tgt_p + e);
                __builtin_prefetch(tgt_n + e);
              }
            }
          }
          if (gathers) {
            for (int i = 0; i < padded; i += L) {
              typename detail::Lanes<std::ptrdiff_t, L>::type j;
              std::memcpy(&j, blk.partner + i, sizeof j);
              const Mask index = __builtin_convertvector(j, Mask);  // < 2^31 / 3 (gathers)
              const Mask ok = index >= Index(0);
              rd::gather_xyz<Scalar, Bytes>(tgt_p, tgt_n, index, ok, blk.y, blk.nt, i);
            }
          } else {
            for (int s = 0; s < padded; ++s) {
              const std::ptrdiff_t j = blk.partner[s];
              if (j >= 0) {
                const Scalar* y = association.target_point(j).data();
                const Scalar* nt = association.target_normal(j).data();
                for (int d = 0; d < 3; ++d) {
                  blk.y[d][s] = y[d];
                  blk.nt[d][s] = nt[d];
                }
              } else {
                for (int d = 0; d < 3; ++d) blk.y[d][s] = blk.nt[d][s] = Scalar(0);
              }
            }
          }
          sums = rd::plane_sums<Scalar, Bytes>(blk, padded, prm);
        });
        acc.add(sums);
      };
      const std::ptrdiff_t blocks = (n + rd::kPlaneBlock - 1) / rd::kPlaneBlock;
      const rd::PlaneAccumulator acc = rd::parallel_reduce(
          blocks, threads, rd::PlaneAccumulator{}, block_sums,
          [](rd::PlaneAccumulator& total, const rd::PlaneAccumulator& a) { total.merge(a); }, 1);
      result.inliers = acc.count;
      result.rmse = acc.count ? Scalar(std::sqrt(acc.sum_sq / double(acc.count))) : Scalar(0);
      if (acc.count < min_corr) {
        result.status = IcpStatus::too_few_correspondences;
        result.T_target_source = rd::orthonormalized<Scalar>(T.cast<Scalar>());
        return result;
      }
      const Eigen::Matrix<double, 6, 6> H = acc.H.template selfadjointView<Eigen::Upper>();
      Eigen::Matrix<double, 6, 1> delta;
      result.degenerate_directions = rd::solve_observable(H, acc.g, degeneracy, delta);
      if (!delta.allFinite()) {
        result.status = IcpStatus::diverged;
        result.T_target_source = T_target_source_init;
        return result;
      }
      const Eigen::Vector3d omega = delta.head<3>();
      const double angle = omega.norm();
      const Eigen::Matrix3d R = angle > 0 ? Eigen::AngleAxisd(angle, omega / angle).toRotationMatrix()
                                          : Eigen::Matrix3d::Identity();
      // q' = R (q − c) + c + v
      dT.linear() = R;
      dT.translation() = c - R * c + delta.tail<3>();
    } else {
      const rd::PointAccumulator acc = rd::parallel_reduce(
          n, threads, rd::PointAccumulator{},
          [&](rd::PointAccumulator& a, std::ptrdiff_t i) {
            const std::ptrdiff_t j = partners[std::size_t(i)];
            if (j < 0 || !compatible(Rs, i, j)) return;
            const Eigen::Vector3d q = moved[std::size_t(i)].template cast<double>();
            const Eigen::Vector3d y = association.target_point(j).template cast<double>();
            const double d2 = (q - y).squaredNorm();
            if (!(d2 <= max_d * max_d)) return;
            const double w = rd::robust_weight(settings.kernel, std::sqrt(d2), k);
            a.w += w;
            a.sq += w * q;
            a.sy += w * y;
            a.sqy += w * q * y.transpose();
            a.sqq += w * q * q.transpose();
            a.sum_sq += d2;
            ++a.count;
          },
          [](rd::PointAccumulator& total, const rd::PointAccumulator& a) { total.merge(a); });
      result.inliers = acc.count;
      result.rmse = acc.count ? Scalar(std::sqrt(acc.sum_sq / double(acc.count))) : Scalar(0);
      result.degenerate_directions = 0;
      if (acc.count < min_corr || !(acc.w > 0)) {
        result.status = IcpStatus::too_few_correspondences;
        result.T_target_source = rd::orthonormalized<Scalar>(T.cast<Scalar>());
        return result;
      }
      // Weighted Kabsch: R maximizing tr(R Σ) with Σ = cov(q, y) (Umeyama without scale).
      const Eigen::Vector3d mq = acc.sq / acc.w, my = acc.sy / acc.w;
      const Eigen::Matrix3d S = acc.sqy - acc.w * mq * my.transpose();
      Eigen::JacobiSVD<Eigen::Matrix3d> svd(S, Eigen::ComputeFullU | Eigen::ComputeFullV);
      Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
      if ((svd.matrixV() * svd.matrixU().transpose()).determinant() < 0) D(2, 2) = -1;
      Eigen::Matrix3d R = svd.matrixV() * D * svd.matrixU().transpose();
      // Degeneracy: the rotation about an axis a is pinned by the source's spread about it, aᵀ(tr C − C)a
      // with C the weighted covariance of the paired source points. None for coincident points (every
      // rotation unobservable: not rotated), one for collinear ones (the turn about the line: only the
      // line's direction is rotated, R a). Relative to the largest, as for point-to-plane, and to a
      // floor of rounding noise (points spread less than 1e-7 of their distance from the origin).
      const Eigen::Matrix3d C = acc.sqq / acc.w - mq * mq.transpose();
      Eigen::Vector3d lambda;  // ascending
      Eigen::Matrix3d axes;
      symmetric_eigen<3>(C, lambda, axes);
      const double lever_max = lambda(1) + lambda(2), floor = 1e-14 * mq.squaredNorm();
      if (!(lever_max > floor)) {
        R.setIdentity();
        result.degenerate_directions = 3;
      } else if (!(lambda(0) + lambda(1) > degeneracy * lever_max)) {
        const Eigen::Vector3d a = axes.col(2);  // the line
        R = rd::rotation_between(a, Eigen::Vector3d(R * a));
        result.degenerate_directions = 1;
      }
      dT.linear() = R;
      dT.translation() = my - R * mq;
      if (!dT.matrix().allFinite()) {
        result.status = IcpStatus::diverged;
        result.T_target_source = T_target_source_init;
        return result;
      }
    }

    const Eigen::Isometry3d T_here = T;
    T = dT * T;
    // Re-orthonormalize: many small updates would otherwise drift off SO(3) (float callers).
    T.linear() = Eigen::Quaterniond(T.linear()).normalized().toRotationMatrix();
    const Eigen::Isometry3d correction = T * T_target_source_init.template cast<double>().inverse(Eigen::Isometry);
    if (!T.matrix().allFinite() || correction.translation().norm() > double(settings.max_correction_translation) ||
        rotation_angle<double>(correction) > double(settings.max_correction_rotation)) {
      result.status = IcpStatus::diverged;
      result.T_target_source = T_target_source_init;
      return result;
    }
    // Does a move turn less than rotation_epsilon and shift the source centroid less than translation_epsilon?
    const auto below_epsilons = [&](const Eigen::Isometry3d& d) {
      return rotation_angle<double>(d) < double(settings.rotation_epsilon) &&
             (d * c - c).norm() < double(settings.translation_epsilon);
    };
    if (below_epsilons(dT)) {
      converged = true;
      break;
    }
    // A 2-cycle: the update leads back to where the previous one started, because partners flip
    // between two sets (kNN partners on a pixel grid, pairs at depth edges). The loop would alternate
    // between the two poses until max_iterations and return whichever the count's parity picks (a
    // generated pile, kNN: 0.023 mm from the truth at even counts, 0.115 mm at odd ones; the one
    // nearer the truth had the larger RMSE, so neither fit picks the better). Each pose's partners
    // pull it to the other, so the optimum lies between: the loop ends at their midpoint.
    if (it > 1 && below_epsilons(T * T_before.inverse(Eigen::Isometry))) {
      const Eigen::Quaterniond qa(T_here.linear()), qb(T_before.linear());
      T.linear() = qa.slerp(0.5, qb).normalized().toRotationMatrix();
      T.translation() = 0.5 * (T_here.translation() + T_before.translation());
      converged = true;
      break;
    }
    T_before = T_here;
  }
  result.T_target_source = rd::orthonormalized<Scalar>(T.cast<Scalar>());
  if (result.degenerate_directions > 0) result.status = IcpStatus::degenerate;
  else result.status = converged ? IcpStatus::converged : IcpStatus::max_iterations;
  return result;
}

}  // namespace registration_detail

/// Registers `source` (source frame [m]; normals optional, used to reject incompatible pairs) to the
/// target held by `association`, starting from `T_target_source_init`. Non-finite source points are
/// skipped, and so are points without a normal when the source has normals (they could never pair).
/// Throws std::invalid_argument for settings out of range or an invalid initial pose; everything else
/// is reported in the result. Point-to-plane needs target normals (`association.has_target_normals()`),
/// else throws.
/// With a workspace kept across calls (IcpWorkspace), calls after the first allocate nothing.
template <typename Scalar, typename Association>
IcpResult<Scalar> icp(const PointCloud<Scalar>& source, const Association& association,
                      const Isometry3<Scalar>& T_target_source_init, const IcpSettings<Scalar>& settings,
                      IcpWorkspace<Scalar>& workspace) {
  namespace rd = registration_detail;
  require(settings.coarse_points >= 0, "coarse_points", "must be >= 0 (0 = one stage)");
  require(settings.stride >= 1, "stride", "must be >= 1");
  const std::size_t strided = (source.points.size() + std::size_t(settings.stride) - 1) / std::size_t(settings.stride);
  const std::size_t coarse_points = std::size_t(settings.coarse_points);
  if (coarse_points == 0 || strided <= 4 * coarse_points || settings.max_iterations < 2)
    return rd::icp_one_scale(source, association, T_target_source_init, T_target_source_init, settings, workspace);
  IcpSettings<Scalar> coarse = settings;
  // The coarse points: runs of kCoarseRun consecutive strided points, one run every `spacing`
  // (about coarse_points in all), copied out once. Its iterations then read a few hundred kB in order,
  // and each pack of partners is mostly consecutive target pixels read by pack loads, where single
  // points every k-th took a cache line or two each. The spacing is odd so that on an image the
  // runs do not fall into the same columns row after row (640 columns and a spacing of 256 sampled
  // five column stripes and cost the fine stage a second pass).
  const std::size_t run = std::size_t(rd::kCoarseRun), k = (strided + coarse_points - 1) / coarse_points;
  const std::size_t spacing = run * k + 1;
  PointCloud<Scalar>& sub = workspace.coarse;
  sub.points.clear();
  sub.normals.clear();
  const bool normals = source.has_normals();
  sub.points.reserve(strided / spacing * run + run);
  if (normals) sub.normals.reserve(sub.points.capacity());
  const std::size_t stride = std::size_t(settings.stride);
  for (std::size_t j = 0; j < strided; j += spacing)
    for (std::size_t s = j; s < std::min(strided, j + run); ++s) {
      sub.points.push_back(source.points[s * stride]);
      if (normals) sub.normals.push_back(source.normals[s * stride]);
    }
  coarse.stride = 1;
  coarse.max_iterations = settings.max_iterations / 2;
  coarse.rotation_epsilon *= Scalar(10);
  coarse.translation_epsilon *= Scalar(10);
  const IcpResult<Scalar> c =
      rd::icp_one_scale(sub, association, T_target_source_init, T_target_source_init, coarse, workspace);
  // A coarse stage that failed (too few pairs, diverged) only cost time: the fine one starts over.
  const bool moved = c.ok() || c.status == IcpStatus::max_iterations;
  IcpSettings<Scalar> fine = settings;
  fine.max_iterations = settings.max_iterations - c.iterations;
  IcpResult<Scalar> r = rd::icp_one_scale(source, association, T_target_source_init,
                                          moved ? c.T_target_source : T_target_source_init, fine, workspace);
  r.iterations += c.iterations;
  return r;
}

/// icp() with its scratch memory allocated for this call.
template <typename Scalar, typename Association>
IcpResult<Scalar> icp(const PointCloud<Scalar>& source, const Association& association,
                      const Isometry3<Scalar>& T_target_source_init, const IcpSettings<Scalar>& settings = {}) {
  IcpWorkspace<Scalar> workspace;
  return icp(source, association, T_target_source_init, settings, workspace);
}

}  // namespace binpick

namespace binpick {

/// Overload for a bare point list (no source normals).
template <typename Scalar, typename Association>
IcpResult<Scalar> icp(const std::vector<Vector3<Scalar>>& source_points, const Association& association,
                      const Isometry3<Scalar>& T_target_source_init, const IcpSettings<Scalar>& settings = {}) {
  PointCloud<Scalar> source;
  source.points = source_points;
  return icp(source, association, T_target_source_init, settings);
}

}  // namespace binpick
