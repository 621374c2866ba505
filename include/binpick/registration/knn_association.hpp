#pragma once
/// \file knn_association.hpp
/// Nearest-neighbour data association in a FLANN kd-tree (see correspondence.hpp for the concept).
/// Works on any target cloud; exact by default (`KdTreeSettings::eps` = 0), approximate when eps > 0.

#include <cstddef>
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

  void associate(const std::vector<Vector3<Scalar>>& queries, Scalar max_distance, int num_threads,
                 std::vector<std::ptrdiff_t>& partners) const {
    const Scalar max_d2 = max_distance * max_distance;
    // Vector3 is three packed scalars, so the query vector is already FLANN's n×3 row-major matrix.
    static_assert(sizeof(Vector3<Scalar>) == 3 * sizeof(Scalar), "Vector3 must be packed");
    std::vector<Scalar> d2;
    tree_.knn(queries.empty() ? nullptr : queries.front().data(), queries.size(), 1, num_threads, partners, d2);
    for (std::size_t i = 0; i < partners.size(); ++i)
      if (!(d2[i] <= max_d2)) partners[i] = -1;
  }

 private:
  PointCloud<Scalar> target_;
  KdTree<Scalar> tree_;
};

}  // namespace binpick
