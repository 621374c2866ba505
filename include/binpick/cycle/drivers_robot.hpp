#pragma once
/// \file drivers_robot.hpp
/// The `RobotDriver` concept: the arm that carries the sensor. It moves the flange through a list of
/// poses at a speed given in percent (the paper's robots take percentages; 100 % ≈ 1 m/s, §III.D.2),
/// and reports the flange pose with the time of the read. A read is exact while the robot stands
/// still (the pull-up stop, §III.B.2) and late while it moves — the imperfect hand-eye
/// synchronization that the fusion's ICP corrects.
///
/// \code
/// struct MyRobot {
///   using Scalar = double;
///   // Starts moving through T_base_flange_path (poses of the flange in the robot base) at
///   // speed_percent in (0, 100] and returns at once with the expected arrival time [s, Clock
///   // time]. Throws std::invalid_argument for an empty path or a speed out of range.
///   double move_along(const std::vector<binpick::Isometry3<Scalar>>& T_base_flange_path,
///                     Scalar speed_percent);
///   bool is_moving() const;                                   // at the current Clock time
///   binpick::cycle::StampedPose<Scalar> read_flange_pose();   // T_base_flange and the read time
/// };
/// \endcode
/// `binpick::cycle::is_robot_driver<T>` checks the members at compile time.

#include <type_traits>
#include <utility>
#include <vector>

#include "binpick/core/pose.hpp"

namespace binpick::cycle {

/// A flange pose as reported by the robot, with the Clock time of the read.
template <typename Scalar>
struct StampedPose {
  Isometry3<Scalar> T_base_flange = Isometry3<Scalar>::Identity();
  double time = 0;  ///< [s] Clock time of the read
};

/// Compile-time check of the RobotDriver concept above.
template <typename T, typename = void>
struct is_robot_driver : std::false_type {};
template <typename T>
struct is_robot_driver<
    T, std::void_t<typename T::Scalar,
                   decltype(double(std::declval<T&>().move_along(
                       std::declval<const std::vector<Isometry3<typename T::Scalar>>&>(), typename T::Scalar()))),
                   decltype(bool(std::declval<const T&>().is_moving())),
                   std::enable_if_t<std::is_same<decltype(std::declval<T&>().read_flange_pose()),
                                                 StampedPose<typename T::Scalar>>::value>>> : std::true_type {};

}  // namespace binpick::cycle
