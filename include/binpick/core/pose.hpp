#pragma once
/// \file pose.hpp
/// Poses and frame helpers. A pose `T_a_b` maps points of frame `b` into frame `a`
/// (`p_a = T_a_b * p_b`). Units: metres, radians.

#include <Eigen/Geometry>

#include "binpick/core/errors.hpp"
#include "binpick/core/scalar_traits.hpp"

namespace binpick {

template <typename Scalar>
using Isometry3 = Eigen::Transform<Scalar, 3, Eigen::Isometry>;
template <typename Scalar>
using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
template <typename Scalar>
using Vector2 = Eigen::Matrix<Scalar, 2, 1>;
template <typename Scalar>
using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;

using Isometry3f = Isometry3<float>;
using Isometry3d = Isometry3<double>;

/// Throws `std::invalid_argument` naming `argument` unless `T` is finite, its last row is [0 0 0 1]
/// and its rotation is orthonormal with determinant +1 (within the scalar's tolerance).
template <typename Scalar>
void require_valid_pose(const Isometry3<Scalar>& T, const char* argument) {
  const auto& m = T.matrix();
  if (!m.allFinite()) detail::throw_invalid_argument(argument, "pose has NaN or inf entries");
  const Scalar tol = ScalarTraits<Scalar>::orthonormal_tolerance();
  const Matrix3<Scalar> R = m.template topLeftCorner<3, 3>();
  if (!((R.transpose() * R - Matrix3<Scalar>::Identity()).cwiseAbs().maxCoeff() <= tol) ||
      !(R.determinant() > Scalar(0)))
    detail::throw_invalid_argument(argument, "pose rotation is not orthonormal (det +1)");
  if (!(std::abs(m(3, 0)) + std::abs(m(3, 1)) + std::abs(m(3, 2)) + std::abs(m(3, 3) - 1) <= tol))
    detail::throw_invalid_argument(argument, "pose last row must be [0 0 0 1]");
}

/// The sensor pose from the robot's flange pose and the hand-eye calibration:
/// `T_base_camera = T_base_flange * T_flange_camera`.
template <typename Scalar>
Isometry3<Scalar> camera_pose_in_base(const Isometry3<Scalar>& T_base_flange,
                                      const Isometry3<Scalar>& T_flange_camera) {
  return T_base_flange * T_flange_camera;
}

/// The relative pose that maps points of camera `view` into camera `ref`:
/// `T_ref_view = T_base_ref^-1 * T_base_view`.
template <typename Scalar>
Isometry3<Scalar> relative_pose(const Isometry3<Scalar>& T_base_ref, const Isometry3<Scalar>& T_base_view) {
  return T_base_ref.inverse(Eigen::Isometry) * T_base_view;
}

/// A camera pose at `position` looking at `target` (z forward), with x = z × `axis` normalized and
/// y = z × x (OpenCV convention). For a sensing arc `axis` is the sweep axis k, so x points along the
/// travel; with `axis` = base y, a camera looking down (−z) has image x along base +x. If z is (nearly)
/// parallel to `axis`, a perpendicular of z is used for x instead (never NaN).
/// Preconditions (not checked): position != target, unit axis.
template <typename Scalar>
Isometry3<Scalar> camera_looking_at(const Vector3<Scalar>& position, const Vector3<Scalar>& target,
                                    const Vector3<Scalar>& axis) {
  const Vector3<Scalar> z = (target - position).normalized();
  Vector3<Scalar> x = z.cross(axis);
  const Scalar x_len = x.norm();
  if (x_len > ScalarTraits<Scalar>::degenerate_tolerance()) {
    x /= x_len;
  } else {
    x = z.unitOrthogonal();
  }
  Isometry3<Scalar> T = Isometry3<Scalar>::Identity();
  T.linear().col(0) = x;
  T.linear().col(1) = z.cross(x);
  T.linear().col(2) = z;
  T.translation() = position;
  return T;
}

/// Rotation angle [rad] and translation norm [m] of a pose (e.g. a correction).
template <typename Scalar>
Scalar rotation_angle(const Isometry3<Scalar>& T) {
  // Through the quaternion (atan2): accurate for small angles, unlike acos of the trace.
  const Eigen::Quaternion<Scalar> q(T.linear());
  return Scalar(2) * std::atan2(q.vec().norm(), std::abs(q.w()));
}

}  // namespace binpick
