#pragma once
/// \file knn_association.hpp
/// Nearest-neighbour data association in a FLANN kd-tree (see correspondence.hpp for the concept).
/// Works on any target cloud; exact by default (`KdTreeSettings::eps` = 0), approximate when eps > 0.

#include <cmath>
#include <cstddef>
#include <limits>
#include <utility>
#include <vector>

#include "binpick/core/errors.hpp"
#include "binpick/registration/correspondence.hpp"
#include "binpick/registration/kdtree.hpp"
#include "binpick/registration/point_cloud.hpp"

namespace binpick {

template <typename Scalar_>
class KnnAssociation {
 public:
  using Scalar = Scalar_;

  /// Builds the tree over the finite points of `target` (kept; normals optional, required only by
  /// point-to-plane ICP). Throws std::invalid_argument when `target.normals` is neither empty nor one
  /// per point.
  explicit KnnAssociation(PointCloud<Scalar> target, const KdTreeSettings<Scalar>& kdtree = {})
      : target_(std::move(target)), tree_(target_.points, kdtree) {
    require(target_.normals.empty() || target_.normals.size() == target_.points.size(), "target",
            "normals must be empty or one per point");
  }

  const PointCloud<Scalar>& target() const { return target_; }
  const Vector3<Scalar>& target_point(std::ptrdiff_t i) const { return target_.points[std::size_t(i)]; }
  const Vector3<Scalar>& target_normal(std::ptrdiff_t i) const { return target_.normals[std::size_t(i)]; }
  bool has_target_normals() const { return target_.has_normals(); }
  /// The targets as arrays (correspondence.hpp, the optional storage members).
  std::size_t target_count() const { return target_.points.size(); }
  const Vector3<Scalar>* target_points_data() const { return target_.points.data(); }
  const Vector3<Scalar>* target_normals_data() const { return target_.has_normals() ? target_.normals.data() : nullptr; }

  /// The nearest target point within max_distance of `query` (finite), or -1: one search, no arrays,
  /// so ICP's point-to-plane loop calls it per point (correspondence.hpp, `has_point_partner`) and
  /// allocates nothing per iteration. (As fast as FLANN's batch search: bench_registration, 640x480.)
  std::ptrdiff_t partner(const Vector3<Scalar>& query, Scalar max_distance) const {
    // FLANN keeps points strictly nearer than the bound; the next float up keeps those at max_distance.
    const Scalar bound = std::nextafter(max_distance * max_distance, std::numeric_limits<Scalar>::infinity());
    Scalar d2;
    return tree_.nearest(query.data(), bound, d2);
  }

  void associate(const std::vector<Vector3<Scalar>>& queries, Scalar max_distance, int num_threads,
                 std::vector<std::ptrdiff_t>& partners) const {
    registration_detail::associate_by_partner(*this, queries, max_distance, num_threads, partners);
  }

 private:
  PointCloud<Scalar> target_;
  KdTree<Scalar> tree_;
};

}  // namespace binpick
