#pragma once
/// \file drivers_estimator.hpp
/// The `PoseEstimator` concept: 6D pose estimation on the fused depth of the reference view (the
/// paper uses a template-based CPU method [21], §III.A). Grasp points are registered on the models in
/// advance, so a recognized object comes with its grasp pose (§III.A, "data processing phase").
///
/// \code
/// struct MyEstimator {
///   using Scalar = float;
///   using Camera = binpick::PinholeCamera<Scalar>;
///   binpick::cycle::EstimationResult<Scalar> estimate(
///       const binpick::cycle::EstimatorInput<Scalar, Camera>& input);
/// };
/// \endcode
/// Objects are returned in the frame of the input's camera (the reference view); their confidences
/// weight the next target centre (Eq. 1). `binpick::cycle::is_pose_estimator<T>` checks the members
/// at compile time.

#include <cstdint>
#include <type_traits>
#include <utility>
#include <vector>

#include "binpick/core/camera_model.hpp"
#include "binpick/core/depth_image.hpp"
#include "binpick/core/pose.hpp"
#include "binpick/cycle/bin_volume.hpp"

namespace binpick::cycle {

/// Gripper a part is picked with (paper Table III).
enum class GripperKind { two_finger, vacuum };

/// What the estimator sees: the fused depth of the reference view and, optionally, its votes.
template <typename Scalar, typename Camera>
struct EstimatorInput {
  DepthImageView<Scalar> depth;          ///< fused depth [m], 0 = no measurement
  const std::uint8_t* votes = nullptr;   ///< optional votes per pixel (row-major, depth's size), or null
  const Camera* camera = nullptr;        ///< intrinsics of `depth`; required
  /// The world's up direction in the camera frame (unit), known from the robot's kinematics and the
  /// hand-eye calibration; zero when unknown. Estimators prefer grasps approaching from above.
  Vector3<Scalar> up_camera = Vector3<Scalar>::Zero();
  /// Optional: the same view before any region-of-interest crop (depth's size), where an estimator
  /// that checks its grasps for collisions finds the walls and floor the crop removed; empty = `depth`.
  DepthImageView<Scalar> obstacles;
  /// Optional: the bin, known to the cell (base frame), and the camera's pose in the base frame
  /// (kinematics). An estimator that checks its grasps for collisions rejects those whose gripper
  /// would stand in a wall or the floor (BinVolume::blocks), which a view from above barely
  /// measures. Unknown (length 0) by default.
  BinVolume<Scalar> bin;
  Isometry3<Scalar> T_base_camera = Isometry3<Scalar>::Identity();
};

/// One recognized object.
template <typename Scalar>
struct RecognizedObject {
  int part_type = 0;                                               ///< id of the model (estimator-defined)
  Isometry3<Scalar> T_camera_object = Isometry3<Scalar>::Identity();  ///< object pose in the camera frame
  Scalar confidence_percent = 0;                                   ///< in [0, 100], weights Eq. 1
  Isometry3<Scalar> T_camera_grasp = Isometry3<Scalar>::Identity();   ///< best grasp: z = approach, x = closing
  GripperKind gripper = GripperKind::two_finger;
  /// False when the estimator found the gripper at T_camera_grasp in conflict with the measured
  /// scene (it returns the object anyway; it still weights the next sensing path): the pipeline does
  /// not grasp it unless PipelineSettings::grasp_blocked, then last. Estimators that do not check
  /// leave it true.
  bool grasp_clear = true;
};

enum class EstimationStatus { ok, no_objects, invalid_input };

template <typename Scalar>
struct EstimationResult {
  EstimationStatus status = EstimationStatus::no_objects;
  std::vector<RecognizedObject<Scalar>> objects;  ///< sorted by decreasing confidence
};

/// Compile-time check of the PoseEstimator concept above.
template <typename T, typename = void>
struct is_pose_estimator : std::false_type {};
template <typename T>
struct is_pose_estimator<
    T, std::void_t<typename T::Scalar, typename T::Camera,
                   std::enable_if_t<is_camera_model<typename T::Camera>::value>,
                   std::enable_if_t<std::is_same<
                       decltype(std::declval<T&>().estimate(
                           std::declval<const EstimatorInput<typename T::Scalar, typename T::Camera>&>())),
                       EstimationResult<typename T::Scalar>>::value>>> : std::true_type {};

}  // namespace binpick::cycle
