#pragma once
/// \file gripper.hpp
/// The `Gripper` concept: the tool on the flange that picks (two-finger or vacuum, paper Table III).
/// The pipeline moves the flange to the grasp pose and then asks the gripper to close; at the drop
/// point C it opens it.
///
/// \code
/// struct MyGripper {
///   using Scalar = double;
///   // The flange stands at T_base_flange (the grasp pose A, z = approach); close and report whether
///   // something is held. `kind` is the gripper the estimator chose for the object.
///   bool grip(const binpick::Isometry3<Scalar>& T_base_flange, binpick::cycle::GripperKind kind);
///   void release();   // open at the drop point C
///   // Optional: a drag follows (PipelineSettings::drag_from_wall). Close the tool (jaws shut, no
///   // suction); the pipeline then lowers the flange onto a part's top at T_base_from and moves it
///   // straight to T_base_to, dragging the part away from a wall. false: the tool cannot, no drag.
///   bool prepare_drag(const binpick::Isometry3<Scalar>& T_base_from, const binpick::Isometry3<Scalar>& T_base_to);
/// };
/// \endcode
/// `binpick::cycle::is_gripper<T>` checks the members at compile time (`can_drag<T>` the optional
/// one). A failure of the device itself is an exception; a grip that holds nothing is `false` (the
/// cycle counts it as a failed pick).

#include <type_traits>
#include <utility>

#include "binpick/core/pose.hpp"
#include "binpick/cycle/drivers_estimator.hpp"

namespace binpick::cycle {

/// Compile-time check of the Gripper concept above.
template <typename T, typename = void>
struct is_gripper : std::false_type {};
template <typename T>
struct is_gripper<T, std::void_t<typename T::Scalar,
                                 decltype(bool(std::declval<T&>().grip(std::declval<const Isometry3<typename T::Scalar>&>(),
                                                                       GripperKind::two_finger))),
                                 decltype(std::declval<T&>().release())>> : std::true_type {};

/// Whether a Gripper has the optional prepare_drag (above).
template <typename T, typename = void>
struct can_drag : std::false_type {};
template <typename T>
struct can_drag<T, std::void_t<decltype(bool(std::declval<T&>().prepare_drag(
                        std::declval<const Isometry3<typename T::Scalar>&>(), std::declval<const Isometry3<typename T::Scalar>&>())))>>
    : std::true_type {};

}  // namespace binpick::cycle
