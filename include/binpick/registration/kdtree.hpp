#pragma once
/// \file kdtree.hpp
/// The FLANN seam of the registration module: a kd-tree over 3-D points (FLANN's single kd-tree,
/// `flann::KDTreeSingleIndex` — the index `flann::Index` builds for `flann::KDTreeSingleIndexParams`,
/// held directly because the wrapper hides its one-query search), exact by default, approximate when
/// `eps` > 0. Only kNN association and kNN normals include this header; the rest of the library
/// compiles without FLANN.

#include <cstddef>
#include <limits>
#include <memory>
#include <vector>

#include <flann/flann.hpp>

#include "binpick/core/errors.hpp"
#include "binpick/core/pose.hpp"

namespace binpick {
namespace registration_detail {
/// FLANN result set of the one nearest point strictly nearer than a bound (the association's maximum
/// distance); it holds no heap memory.
template <typename D>
class NearestWithin final : public flann::ResultSet<D> {
 public:
  explicit NearestWithin(D bound) : worst_(bound) {}
  bool full() const override { return true; }
  void addPoint(D dist, std::size_t index) override {
    if (dist < worst_) {
      worst_ = dist;
      index_ = index;
    }
  }
  D worstDist() const override { return worst_; }
  std::size_t index() const { return index_; }

 private:
  D worst_;
  std::size_t index_ = std::numeric_limits<std::size_t>::max();
};
}  // namespace registration_detail

template <typename Scalar>
struct KdTreeSettings {
  int leaf_max_size = 10;  ///< points per leaf (FLANN's default); larger builds faster, searches slower
  /// Relative approximation: a returned neighbour is within (1 + eps) of the true nearest distance.
  /// 0 = exact search (default).
  Scalar eps = Scalar(0);
};

/// Kd-tree over the finite points of a cloud; queries answer indices into the original cloud.
/// Searches are const and may run concurrently.
template <typename Scalar>
class KdTree {
 public:
  /// Throws std::invalid_argument for leaf_max_size < 1 or a negative / non-finite eps.
  explicit KdTree(const std::vector<Vector3<Scalar>>& points, const KdTreeSettings<Scalar>& settings = {})
      : settings_(settings) {
    require(settings.leaf_max_size >= 1, "leaf_max_size", "must be >= 1");
    require(std::isfinite(settings.eps) && settings.eps >= Scalar(0), "eps", "must be finite and >= 0");
    for (std::size_t i = 0; i < points.size(); ++i) {
      if (!points[i].allFinite()) continue;  // NaN would break the tree's splits
      data_.insert(data_.end(), points[i].data(), points[i].data() + 3);
      ids_.push_back(i);
    }
    if (!ids_.empty()) {
      index_ = std::make_unique<Index>(flann::Matrix<Scalar>(data_.data(), ids_.size(), 3),
                                       flann::KDTreeSingleIndexParams(settings.leaf_max_size));
      index_->buildIndex();
    }
  }
  KdTree(KdTree&&) noexcept = default;
  KdTree& operator=(KdTree&&) noexcept = default;
  KdTree(const KdTree&) = delete;
  KdTree& operator=(const KdTree&) = delete;

  /// Number of (finite) points in the tree.
  std::size_t size() const { return ids_.size(); }

  /// The nearest tree point to `query` (finite) at a squared distance below `bound_squared`, or -1;
  /// `squared_distance` receives its squared distance. Exact (or within eps, as knn()).
  std::ptrdiff_t nearest(const Scalar* query, Scalar bound_squared, Scalar& squared_distance) const {
    if (!index_) return -1;
    registration_detail::NearestWithin<Scalar> result(bound_squared);
    index_->findNeighbors(result, query, search_params(1));
    if (result.index() >= ids_.size()) return -1;
    squared_distance = result.worstDist();
    return std::ptrdiff_t(ids_[result.index()]);
  }

  /// The k nearest tree points of each of `n` queries (row-major n×3 array, finite). Row i of
  /// `indices` / `squared_distances` (n×k) holds them nearest first; entries past the number of tree
  /// points are -1 / +inf.
  void knn(const Scalar* queries, std::size_t n, int k, int num_threads, std::vector<std::ptrdiff_t>& indices,
           std::vector<Scalar>& squared_distances) const {
    require(k >= 1, "k", "must be >= 1");
    const std::size_t kk = std::size_t(k);
    indices.assign(n * kk, -1);
    squared_distances.assign(n * kk, std::numeric_limits<Scalar>::infinity());
    if (n == 0 || !index_) return;
    std::vector<std::size_t> idx(n * kk, std::numeric_limits<std::size_t>::max());
    std::vector<Scalar> d2(n * kk, std::numeric_limits<Scalar>::infinity());
    flann::Matrix<Scalar> q(const_cast<Scalar*>(queries), n, 3);  // FLANN only reads the queries
    flann::Matrix<std::size_t> mi(idx.data(), n, kk);
    flann::Matrix<Scalar> md(d2.data(), n, kk);
    index_->knnSearch(q, mi, md, kk, search_params(num_threads));
    for (std::size_t i = 0; i < n * kk; ++i) {
      if (idx[i] < ids_.size() && d2[i] < std::numeric_limits<Scalar>::infinity()) {
        indices[i] = std::ptrdiff_t(ids_[idx[i]]);
        squared_distances[i] = d2[i];
      }
    }
  }

 private:
  using Index = flann::KDTreeSingleIndex<flann::L2<Scalar>>;
  KdTreeSettings<Scalar> settings_;
  std::vector<Scalar> data_;       // finite points, n×3 (FLANN keeps a pointer into it)
  std::vector<std::size_t> ids_;   // tree row -> original index
  std::unique_ptr<Index> index_;

  flann::SearchParams search_params(int num_threads) const {
    flann::SearchParams params(flann::FLANN_CHECKS_UNLIMITED, float(settings_.eps), true);
    params.cores = num_threads < 1 ? 1 : num_threads;
    return params;
  }
};

}  // namespace binpick
