#pragma once
/// \file target_center.hpp
/// The target center of the next sensing path (paper §III.C.2, Eq. 1): the confidence-weighted gravity
/// center of the recognized objects that remain in the bin — every recognized object except the one
/// about to be grasped.
///
///   T = sum_k(confidence_k * X_k) / sum_k(confidence_k)                               (Eq. 1)
///
/// Fallback: when no object remains, or all remaining confidences are zero, Eq. 1 is 0/0; the caller's
/// `fallback` point (e.g. the bin center) is returned instead and the status says so. Never NaN.

#include <cstddef>
#include <limits>
#include <vector>

#include "binpick/core/errors.hpp"
#include "binpick/core/pose.hpp"

namespace binpick::active_vision {

enum class TargetCenterStatus {
  weighted,                   ///< Eq. 1 over the remaining objects
  fallback_no_objects,        ///< no object remains: `fallback` returned
  fallback_zero_confidence,   ///< every remaining confidence is 0: `fallback` returned
};

template <typename Scalar>
struct TargetCenter {
  Vector3<Scalar> point = Vector3<Scalar>::Zero();  ///< T in the frame of the positions [m]
  TargetCenterStatus status = TargetCenterStatus::fallback_no_objects;
  int num_objects = 0;                ///< remaining objects that entered Eq. 1 (confidence > 0)
  Scalar total_confidence = Scalar(0);  ///< sum of their confidences
  bool used_fallback() const { return status != TargetCenterStatus::weighted; }
};

/// No object is being grasped (all positions remain).
inline constexpr std::size_t no_grasped_object = std::numeric_limits<std::size_t>::max();

/// Eq. 1 over `positions` (X_k, e.g. the translations of the estimated object poses, in the base frame)
/// with `confidences` (any non-negative scale: percentages or [0, 1]); the object at `grasped_index` is
/// left out (pass `no_grasped_object` when the list already holds only the remaining objects).
/// Throws `std::invalid_argument` when the sizes differ, a position is not finite, a confidence is
/// negative or not finite, `grasped_index` is out of range (other than `no_grasped_object`), or
/// `fallback` is not finite.
template <typename Scalar>
TargetCenter<Scalar> target_center(const std::vector<Vector3<Scalar>>& positions, const std::vector<Scalar>& confidences,
                                   const Vector3<Scalar>& fallback, std::size_t grasped_index = no_grasped_object) {
  require(positions.size() == confidences.size(), "confidences", "must have one entry per position");
  require(grasped_index == no_grasped_object || grasped_index < positions.size(), "grasped_index",
          "must index a position or be no_grasped_object");
  require_all_finite(fallback, "fallback");
  Scalar max_confidence = Scalar(0);
  for (std::size_t k = 0; k < positions.size(); ++k) {
    require_all_finite(positions[k], "positions");
    require(std::isfinite(confidences[k]) && confidences[k] >= Scalar(0), "confidences", "must be finite and >= 0");
    if (k != grasped_index && confidences[k] > max_confidence) max_confidence = confidences[k];
  }
  TargetCenter<Scalar> result;
  result.point = fallback;
  const std::size_t remaining = positions.size() - (grasped_index == no_grasped_object ? 0 : 1);
  if (remaining == 0) return result;
  if (!(max_confidence > Scalar(0))) {
    result.status = TargetCenterStatus::fallback_zero_confidence;
    return result;
  }
  // Weights scaled by the largest confidence (so tiny confidences do not underflow in float) and the
  // sum taken relative to one of the positions (so large base coordinates do not cancel).
  Vector3<Scalar> reference = fallback;
  for (std::size_t k = 0; k < positions.size(); ++k)
    if (k != grasped_index && confidences[k] > Scalar(0)) {
      reference = positions[k];
      break;
    }
  Vector3<Scalar> weighted_offset = Vector3<Scalar>::Zero();
  Scalar weight_sum = Scalar(0);
  for (std::size_t k = 0; k < positions.size(); ++k) {
    if (k == grasped_index || !(confidences[k] > Scalar(0))) continue;
    const Scalar w = confidences[k] / max_confidence;  // in (0, 1]
    weighted_offset += w * (positions[k] - reference);
    weight_sum += w;
    result.total_confidence += confidences[k];
    ++result.num_objects;
  }
  result.point = reference + weighted_offset / weight_sum;  // weight_sum >= 1 (the largest weight is 1)
  result.status = TargetCenterStatus::weighted;
  return result;
}

}  // namespace binpick::active_vision
