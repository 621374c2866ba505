#pragma once
/// \file estimator_model.hpp
/// What the reference estimator precomputes from a part model: surface samples with normals (a fine
/// set for scoring and the final ICP, a coarse one for the first ICP from each initial orientation),
/// their kd-trees, principal axes, and the gripper shapes shared with the grasp model.

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdint>
#include <limits>
#include <memory>
#include <numeric>
#include <vector>

#include <Eigen/Eigenvalues>

#include "binpick/core/pose.hpp"
#include "binpick/registration/knn_association.hpp"
#include "binpick/registration/point_cloud.hpp"
#include "binpick/sim/detail/estimator_symmetry.hpp"
#include "binpick/sim/detail/random.hpp"
#include "binpick/sim/parts.hpp"

namespace binpick::sim {

/// Simple gripper shapes in the grasp frame (parts.hpp: z = approach, the gripper moves along +z into
/// the part; x = finger closing direction; origin at the grasp point). Two-finger jaws: two boxes
/// beside the grasp point that reach back along −z; vacuum: a cylinder standing on the grasp point.
template <typename Scalar>
struct GripperGeometry {
  Scalar finger_thickness = Scalar(0.004);  ///< along x [m]
  Scalar finger_width = Scalar(0.008);      ///< along y [m]
  Scalar finger_length = Scalar(0.030);     ///< along −z from the finger tip [m]
  Scalar finger_clearance = Scalar(0.001);  ///< extra opening on each side beyond the grasp's opening [m]
  Scalar tip_depth = Scalar(0);             ///< finger tips sit this far past the grasp point along +z [m]
  /// Jaw opening while approaching [m]: a gripper that opens to its stroke before each pick has its
  /// fingers this far apart (plus finger_clearance) whatever the grasp; 0 = each grasp's own opening
  /// (a gripper that pre-shapes). The opening checked is the larger of this and the grasp's.
  Scalar approach_opening = Scalar(0);
  Scalar cup_radius = Scalar(0.005);        ///< vacuum cup [m]
  Scalar cup_length = Scalar(0.040);        ///< cup and stem along −z from the grasp point [m]
};

namespace detail {

/// The indices 0..n−1 in the stable order of `before(a, b)` (by index). Sorting indices instead of the
/// elements also keeps elements with Eigen members out of std::stable_sort's temporary buffer, which
/// (libstdc++ 12) ignores the 32-byte alignment they need with AVX (-march=native) and crashed.
template <typename Before>
std::vector<std::size_t> stable_order(std::size_t n, Before before) {
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), std::size_t(0));
  std::stable_sort(order.begin(), order.end(), before);
  return order;
}

/// An axis-aligned box in the grasp frame.
template <typename Scalar>
struct GraspBox {
  Vector3<Scalar> lo, hi;
};

/// The finger boxes of a two-finger grasp with `opening` [m] (grasp frame).
template <typename Scalar>
std::vector<GraspBox<Scalar>> finger_boxes(const GripperGeometry<Scalar>& g, Scalar opening) {
  const Scalar x0 = opening / 2 + g.finger_clearance, x1 = x0 + g.finger_thickness;
  const Scalar z1 = g.tip_depth, z0 = z1 - g.finger_length, y = g.finger_width / 2;
  return {{Vector3<Scalar>(x0, -y, z0), Vector3<Scalar>(x1, y, z1)}, {Vector3<Scalar>(-x1, -y, z0), Vector3<Scalar>(-x0, y, z1)}};
}

/// Points on and inside the gripper (grasp frame) about every `spacing` [m]: what a collision test
/// against measured depth or against boxes checks.
template <typename Scalar>
std::vector<Vector3<Scalar>> gripper_samples(const GripperGeometry<Scalar>& g, cycle::GripperKind kind, Scalar opening,
                                             Scalar spacing) {
  std::vector<Vector3<Scalar>> out;
  auto steps = [&](Scalar len) { return std::max(1, int(std::ceil(len / spacing))); };
  if (kind == cycle::GripperKind::two_finger) {
    for (const auto& b : finger_boxes(g, opening)) {
      const Vector3<Scalar> e = b.hi - b.lo;
      const int nx = steps(e.x()), ny = steps(e.y()), nz = steps(e.z());
      for (int i = 0; i <= nx; ++i)
        for (int j = 0; j <= ny; ++j)
          for (int k = 0; k <= nz; ++k)
            out.push_back(b.lo + Vector3<Scalar>(e.x() * Scalar(i) / Scalar(nx), e.y() * Scalar(j) / Scalar(ny),
                                                 e.z() * Scalar(k) / Scalar(nz)));
    }
  } else {
    const int nr = steps(g.cup_radius), nz = steps(g.cup_length);
    for (int k = 0; k <= nz; ++k) {
      const Scalar z = -g.cup_length * Scalar(k) / Scalar(nz);
      out.emplace_back(0, 0, z);
      for (int r = 1; r <= nr; ++r) {
        const Scalar rad = g.cup_radius * Scalar(r) / Scalar(nr);
        const int na = std::max(6, int(std::ceil(Scalar(2 * M_PI) * rad / spacing)));
        for (int a = 0; a < na; ++a) {
          const Scalar t = Scalar(2 * M_PI) * Scalar(a) / Scalar(na);
          out.emplace_back(rad * std::cos(t), rad * std::sin(t), z);
        }
      }
    }
  }
  return out;
}

/// Area-weighted surface samples of a mesh, about one per spacing² [m²]; deterministic (keyed by the
/// triangle index). Normals: the interpolated corner normals (smooth on curved surfaces).
template <typename Scalar>
PointCloud<Scalar> sample_surface(const TriangleMesh<Scalar>& mesh, Scalar spacing, std::uint64_t key) {
  PointCloud<Scalar> out;
  const double per_area = 1.0 / (double(spacing) * double(spacing));
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& tri = mesh.triangles[t];
    const Vector3<Scalar> a = mesh.vertices[std::size_t(tri.x())], b = mesh.vertices[std::size_t(tri.y())],
                          c = mesh.vertices[std::size_t(tri.z())];
    const double area = 0.5 * double((b - a).cross(c - a).norm());
    Rng rng(hash_keys(key, t));
    const double expected = area * per_area;
    int n = int(expected);
    if (rng.uniform() < expected - double(n)) ++n;
    for (int i = 0; i < n; ++i) {
      double u = rng.uniform(), v = rng.uniform();
      if (u + v > 1) {
        u = 1 - u;
        v = 1 - v;
      }
      const Scalar su = Scalar(u), sv = Scalar(v), sw = Scalar(1 - u - v);
      const Vector3<Scalar> p = sw * a + su * b + sv * c;
      Vector3<Scalar> nrm = sw * mesh.corner_normals[3 * t] + su * mesh.corner_normals[3 * t + 1] +
                            sv * mesh.corner_normals[3 * t + 2];
      const Scalar len = nrm.norm();
      if (!(len > Scalar(1e-6))) continue;
      out.points.push_back(p);
      out.normals.push_back(nrm / len);
    }
  }
  return out;
}

/// Principal axes (columns, decreasing variance, right-handed) and centroid of a point set.
template <typename Scalar>
void principal_axes(const std::vector<Vector3<Scalar>>& points, Matrix3<Scalar>& axes, Vector3<Scalar>& centroid,
                    Vector3<Scalar>* variances = nullptr) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : points) mean += p.template cast<double>();
  mean /= double(std::max<std::size_t>(1, points.size()));
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : points) {
    const Eigen::Vector3d d = p.template cast<double>() - mean;
    cov += d * d.transpose();
  }
  cov /= double(std::max<std::size_t>(1, points.size()));
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  Eigen::Matrix3d E;
  E.col(0) = es.eigenvectors().col(2);
  E.col(1) = es.eigenvectors().col(1);
  E.col(2) = E.col(0).cross(E.col(1));
  axes = E.cast<Scalar>();
  centroid = mean.cast<Scalar>();
  if (variances) *variances = Vector3<Scalar>(Scalar(es.eigenvalues()(2)), Scalar(es.eigenvalues()(1)), Scalar(es.eigenvalues()(0)));
}

/// Nearest-sample association on a voxel grid around the model (the data-association concept of
/// registration/correspondence.hpp): each voxel stores its nearest model sample, so a query costs one
/// lookup instead of a kd-tree search. The partner is the sample nearest the voxel centre (at most
/// half a voxel diagonal from the true nearest one), which point-to-plane ICP tolerates since the
/// residual is taken along the partner's normal.
template <typename Scalar_>
class VoxelAssociation {
 public:
  using Scalar = Scalar_;

  /// `target`: model samples with normals; `voxel` [m]; `margin` [m] beyond the samples' bounds
  /// (queries farther out have no partner).
  VoxelAssociation(const PointCloud<Scalar>& target, Scalar voxel, Scalar margin)
      : target_(target), inv_voxel_(Scalar(1) / voxel) {
    require(!target.points.empty() && target.has_normals(), "target", "needs points with normals");
    require(voxel > Scalar(0), "voxel", "must be > 0");
    Vector3<Scalar> lo = target.points.front(), hi = lo;
    for (const auto& p : target.points) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    origin_ = lo - Vector3<Scalar>::Constant(margin);
    for (int a = 0; a < 3; ++a) dims_[a] = int(std::ceil((hi[a] - lo[a] + 2 * margin) / voxel)) + 1;
    std::vector<Vector3<Scalar>> centres;
    centres.reserve(std::size_t(dims_[0]) * std::size_t(dims_[1]) * std::size_t(dims_[2]));
    for (int k = 0; k < dims_[2]; ++k)
      for (int j = 0; j < dims_[1]; ++j)
        for (int i = 0; i < dims_[0]; ++i)
          centres.push_back(origin_ + voxel * Vector3<Scalar>(Scalar(i) + Scalar(0.5), Scalar(j) + Scalar(0.5), Scalar(k) + Scalar(0.5)));
    const KnnAssociation<Scalar> tree(target);
    std::vector<std::ptrdiff_t> nearest;
    tree.associate(centres, std::numeric_limits<Scalar>::max(), 0, nearest);
    nearest_.assign(nearest.begin(), nearest.end());
  }

  const Vector3<Scalar>& target_point(std::ptrdiff_t i) const { return target_.points[std::size_t(i)]; }
  const Vector3<Scalar>& target_normal(std::ptrdiff_t i) const { return target_.normals[std::size_t(i)]; }
  bool has_target_normals() const { return true; }

  void associate(const std::vector<Vector3<Scalar>>& queries, Scalar max_distance, int /*num_threads*/,
                 std::vector<std::ptrdiff_t>& partners) const {
    partners.resize(queries.size());
    for (std::size_t q = 0; q < queries.size(); ++q) partners[q] = partner(queries[q], max_distance);
  }

  /// The sample stored for the voxel of `q` when it lies within max_distance of q, else -1.
  std::ptrdiff_t partner(const Vector3<Scalar>& q, Scalar max_distance) const {
    const Vector3<Scalar> r = (q - origin_) * inv_voxel_;
    // Compared as floats first: any query, however far (or NaN), converts to int only inside the grid.
    if (!(r.minCoeff() >= Scalar(0) && r.x() < Scalar(dims_[0]) && r.y() < Scalar(dims_[1]) && r.z() < Scalar(dims_[2])))
      return -1;
    const int i = int(r.x()), j = int(r.y()), k = int(r.z());
    if (i >= dims_[0] || j >= dims_[1] || k >= dims_[2]) return -1;
    const std::int32_t n = nearest_[(std::size_t(k) * std::size_t(dims_[1]) + std::size_t(j)) * std::size_t(dims_[0]) + std::size_t(i)];
    return n >= 0 && (target_.points[std::size_t(n)] - q).squaredNorm() <= max_distance * max_distance ? n : -1;
  }

 private:
  PointCloud<Scalar> target_;
  Scalar inv_voxel_;
  Vector3<Scalar> origin_;
  int dims_[3] = {0, 0, 0};
  std::vector<std::int32_t> nearest_;
};

/// A part model prepared for recognition.
/// The n-th angular harmonic about the z axis of points (part frame) within `radius` of it, each
/// weighted by r⁴ so the outline (the corners of a polygonal prism) dominates, divided by the sum of
/// the weights: its argument / n is where the corners are, its magnitude how clearly (0 for a
/// circle). 0 when no point counts.
template <typename Scalar>
std::complex<double> outline_harmonic(const std::vector<Vector3<Scalar>>& points, int n, double radius) {
  std::complex<double> sum = 0;
  double weight = 0;
  for (const auto& p : points) {
    const double x = double(p.x()), y = double(p.y()), r2 = x * x + y * y;
    if (!(r2 <= radius * radius) || r2 == 0) continue;
    const double w = r2 * r2;
    sum += w * std::polar(1.0, double(n) * std::atan2(y, x));
    weight += w;
  }
  return weight > 0 ? sum / weight : std::complex<double>(0);
}

template <typename Scalar>
struct PreparedModel {
  PartModel<Scalar> model;
  PartSymmetry symmetry;
  PointCloud<Scalar> fine;                              ///< surface samples, part frame [m]
  std::shared_ptr<const VoxelAssociation<Scalar>> association;  ///< nearest sample lookup
  Matrix3<Scalar> axes = Matrix3<Scalar>::Identity();   ///< principal axes of the surface
  Vector3<Scalar> centroid = Vector3<Scalar>::Zero();   ///< of the surface samples
  /// n-fold parts (symmetry.z_fold >= 3, not continuous): the n-th angular harmonic of the samples
  /// about the z axis (outline_harmonic), normalized by its weights: where the corners are.
  std::complex<double> outline = 0;

  static PreparedModel make(const PartModel<Scalar>& m, Scalar spacing, Scalar voxel, Scalar margin) {
    PreparedModel p;
    p.model = m;
    p.symmetry = part_symmetry(m.type);
    p.fine = sample_surface(m.mesh, spacing, 0xf1e5ULL + std::uint64_t(m.type));
    p.association = std::make_shared<const VoxelAssociation<Scalar>>(p.fine, voxel, margin);
    principal_axes(p.fine.points, p.axes, p.centroid);
    if (!p.symmetry.continuous_z && p.symmetry.z_fold >= 3)
      p.outline = outline_harmonic(p.fine.points, p.symmetry.z_fold, double(m.bounding_radius));
    return p;
  }
};

}  // namespace detail
}  // namespace binpick::sim
