#pragma once
/// \file drivers_sensor.hpp
/// The `SensorDriver` concept: a one-shot 3D camera on the robot's hand (paper §IV.A). The paper
/// captures during motion and processes afterwards (§III.A, data collection phase): a trigger only
/// exposes and stores the frame in the sensor's on-board memory and returns the trigger timestamp —
/// the time the frame's pose must be matched to; the frames are read back later, in capture order.
///
/// \code
/// struct MySensor {
///   using Scalar = float;                      // depth scalar (float or double)
///   using Camera = binpick::PinholeCamera<Scalar>;   // any camera model (core/camera_model.hpp)
///   const Camera& camera() const;              // intrinsics of the depth images
///   Scalar accuracy() const;                   // depth accuracy [m] at the working distance;
///                                              // Alg. 1 votes within δ = 2 × accuracy
///   double trigger();                          // expose now; returns the trigger time [s, Clock time]
///   std::size_t frames_in_memory() const;      // captured, not yet read
///   std::vector<binpick::cycle::DepthFrame<Scalar>> read_frames();  // all stored frames in capture
///                                              // order; clears the on-board memory
/// };
/// \endcode
/// `binpick::cycle::is_sensor_driver<T>` checks the members at compile time.

#include <cstddef>
#include <cstdint>
#include <type_traits>
#include <utility>
#include <vector>

#include "binpick/core/camera_model.hpp"
#include "binpick/core/depth_image.hpp"

namespace binpick::cycle {

/// One captured frame read back from a sensor.
template <typename Scalar>
struct DepthFrame {
  DepthImage<Scalar> depth;   ///< metres, 0 = no measurement
  double trigger_time = 0;    ///< [s] Clock time of the trigger (start of exposure)
  std::uint64_t index = 0;    ///< running capture number of the sensor
};

/// Compile-time check of the SensorDriver concept above.
template <typename T, typename = void>
struct is_sensor_driver : std::false_type {};
template <typename T>
struct is_sensor_driver<
    T, std::void_t<typename T::Scalar, typename T::Camera,
                   std::enable_if_t<is_camera_model<typename T::Camera>::value>,
                   std::enable_if_t<std::is_same<decltype(std::declval<const T&>().camera()),
                                                 const typename T::Camera&>::value>,
                   decltype(typename T::Scalar(std::declval<const T&>().accuracy())),
                   decltype(double(std::declval<T&>().trigger())),
                   decltype(std::size_t(std::declval<const T&>().frames_in_memory())),
                   std::enable_if_t<std::is_same<decltype(std::declval<T&>().read_frames()),
                                                 std::vector<DepthFrame<typename T::Scalar>>>::value>>>
    : std::true_type {};

}  // namespace binpick::cycle
