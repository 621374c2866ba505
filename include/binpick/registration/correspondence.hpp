#pragma once
/// \file correspondence.hpp
/// The data-association concept of ICP: given source points already mapped into the target frame,
/// find each one's partner in the target. Two strategies ship:
///  - `KnnAssociation` (knn_association.hpp): exact (or approximate) nearest neighbour in a FLANN
///    kd-tree over any target cloud;
///  - `ProjectiveAssociation` (projective_association.hpp): project into the target depth image and
///    take the closest target point in a small pixel window — no tree, the fast path for depth images.
///
/// An association strategy is a type with these members (all const members must be safe to call
/// concurrently; `associate` must give the same answer for any `num_threads`):
/// \code
/// struct MyAssociation {
///   using Scalar = float;                                 // float or double
///   // Target points [m] and normals (unit, or zero = unknown) in the target frame, by partner index.
///   const Eigen::Matrix<Scalar, 3, 1>& target_point(std::ptrdiff_t i) const;
///   const Eigen::Matrix<Scalar, 3, 1>& target_normal(std::ptrdiff_t i) const;  // only if has_target_normals()
///   bool has_target_normals() const;
///   // partners[i] = index of the partner of queries[i] within max_distance [m] (Euclidean), or -1.
///   // queries are finite; partners is resized to queries.size().
///   void associate(const std::vector<Eigen::Matrix<Scalar, 3, 1>>& queries, Scalar max_distance,
///                  int num_threads, std::vector<std::ptrdiff_t>& partners) const;
///   // Optional, point-wise: the partner of one query, or -1 (same rule as associate). With it,
///   // point-to-plane ICP moves, associates and sums each point in one pass, without per-iteration
///   // arrays (both shipped strategies have it; their associate() is made of it).
///   std::ptrdiff_t partner(const Eigen::Matrix<Scalar, 3, 1>& query, Scalar max_distance) const;
///   // Optional, projective (ProjectiveAssociation has them): when pixel_partner() is true, partner(q)
///   // is the target point at the index project_queries() gives q, if that point is valid (z > 0),
///   // has a normal (when the target has normals) and lies within max_distance. ICP's point-to-plane
///   // pass then projects a block of queries in SIMD packs of `Bytes` (core/detail/simd.hpp) and
///   // applies the rest of the rule itself on the gathered partners.
///   bool pixel_partner() const;
///   template <int Bytes>  // count: a multiple of Pack<Scalar, Bytes>::size; index: -1 = no pixel
///   void project_queries(const Scalar* x, const Scalar* y, const Scalar* z, int count, std::ptrdiff_t* index) const;
///   // Optional, storage (both shipped strategies have it): the targets as arrays, target_point(i) ==
///   // target_points_data()[i] for i < target_count() (target_normals_data() likewise, nullptr without
///   // normals). ICP's point-to-plane pass then gathers a pack of partners at a time (AVX2 gathers).
///   std::size_t target_count() const;
///   const Eigen::Matrix<Scalar, 3, 1>* target_points_data() const;
///   const Eigen::Matrix<Scalar, 3, 1>* target_normals_data() const;
/// };
/// \endcode
/// `binpick::is_association<T>` checks the required members at compile time, `has_point_partner<T>`,
/// `has_pixel_partner<T>` and `has_target_arrays<T>` the optional ones.

#include <cstddef>
#include <type_traits>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "binpick/registration/detail/parallel.hpp"

namespace binpick {

template <typename T, typename = void>
struct is_association : std::false_type {};
template <typename T>
struct is_association<
    T, std::void_t<typename T::Scalar, decltype(std::declval<const T&>().target_point(std::ptrdiff_t())),
                   decltype(std::declval<const T&>().target_normal(std::ptrdiff_t())),
                   decltype(bool(std::declval<const T&>().has_target_normals())),
                   decltype(std::declval<const T&>().associate(
                       std::declval<const std::vector<Eigen::Matrix<typename T::Scalar, 3, 1>>&>(),
                       typename T::Scalar(), int(), std::declval<std::vector<std::ptrdiff_t>&>()))>>
    : std::true_type {};

template <typename T, typename = void>
struct has_point_partner : std::false_type {};
template <typename T>
struct has_point_partner<T, std::void_t<decltype(std::ptrdiff_t(std::declval<const T&>().partner(
                                std::declval<const Eigen::Matrix<typename T::Scalar, 3, 1>&>(), typename T::Scalar())))>>
    : std::true_type {};

template <typename T, typename = void>
struct has_pixel_partner : std::false_type {};
template <typename T>
struct has_pixel_partner<T, std::void_t<decltype(bool(std::declval<const T&>().pixel_partner())),
                                        decltype(std::declval<const T&>().template project_queries<16>(
                                            std::declval<const typename T::Scalar*>(), std::declval<const typename T::Scalar*>(),
                                            std::declval<const typename T::Scalar*>(), int(),
                                            std::declval<std::ptrdiff_t*>()))>> : std::true_type {};

template <typename T, typename = void>
struct has_target_arrays : std::false_type {};
template <typename T>
struct has_target_arrays<
    T, std::void_t<decltype(std::size_t(std::declval<const T&>().target_count())),
                   decltype(static_cast<const Eigen::Matrix<typename T::Scalar, 3, 1>*>(std::declval<const T&>().target_points_data())),
                   decltype(static_cast<const Eigen::Matrix<typename T::Scalar, 3, 1>*>(std::declval<const T&>().target_normals_data()))>>
    : std::true_type {};

namespace registration_detail {
/// associate() of a strategy that has partner(): every query on its own, `num_threads` threads.
template <typename Association, typename Scalar>
void associate_by_partner(const Association& association, const std::vector<Eigen::Matrix<Scalar, 3, 1>>& queries,
                          Scalar max_distance, int num_threads, std::vector<std::ptrdiff_t>& partners) {
  partners.resize(queries.size());
  parallel_for(std::ptrdiff_t(queries.size()), num_threads, [&](std::ptrdiff_t i) {
    partners[std::size_t(i)] = association.partner(queries[std::size_t(i)], max_distance);
  });
}
}  // namespace registration_detail

}  // namespace binpick
