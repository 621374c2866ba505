#pragma once
/// \file camera_model.hpp
/// The camera-model concept and the pinhole model.
///
/// A camera model is a small value type passed as a template parameter (like small_gicp's projection
/// policy). Camera frame: x right, y down, z forward (OpenCV). Pixel (u, v) = (column, row); integer
/// coordinates are pixel centres. Depth is the z coordinate in the camera frame (not the ray length).
///
/// \code
/// struct MyCamera {
///   using Scalar = float;                       // float or double
///   int width() const;                          // image size [px], > 0
///   int height() const;
///   // Pixel of a point in the camera frame [m]; std::nullopt when the point is not finite, is not in
///   // front of the camera (z <= 0) or its pixel rounds to outside [0, width) x [0, height).
///   std::optional<Eigen::Matrix<Scalar, 2, 1>> project(const Eigen::Matrix<Scalar, 3, 1>& p) const;
///   // The point [m] at pixel (u, v) whose z coordinate is `depth`; the inverse of project.
///   Eigen::Matrix<Scalar, 3, 1> backproject(Scalar u, Scalar v, Scalar depth) const;
/// };
/// \endcode
/// `binpick::is_camera_model<T>` checks the members at compile time. Models in the library:
/// `PinholeCamera<Scalar>` (here) and `BrownConradyCamera<Scalar>` (brown_conrady_camera.hpp).

#include <cmath>
#include <optional>
#include <type_traits>
#include <utility>

#include <Eigen/Core>

#include "binpick/core/errors.hpp"

namespace binpick {

/// Compile-time check of the camera-model concept above.
template <typename T, typename = void>
struct is_camera_model : std::false_type {};
template <typename T>
struct is_camera_model<
    T, std::void_t<typename T::Scalar, decltype(std::declval<const T&>().width()),
                   decltype(std::declval<const T&>().height()),
                   decltype(std::declval<const T&>().project(std::declval<const Eigen::Matrix<typename T::Scalar, 3, 1>&>())),
                   decltype(std::declval<const T&>().backproject(typename T::Scalar(), typename T::Scalar(),
                                                                   typename T::Scalar()))>> : std::true_type {};

namespace detail {
template <typename Scalar>
inline void require_intrinsics(Scalar fx, Scalar fy, Scalar cx, Scalar cy, int width, int height) {
  require(std::isfinite(fx) && fx > Scalar(0), "fx", "focal length must be finite and > 0");
  require(std::isfinite(fy) && fy > Scalar(0), "fy", "focal length must be finite and > 0");
  require(std::isfinite(cx), "cx", "must be finite");
  require(std::isfinite(cy), "cy", "must be finite");
  require(width > 0, "width", "must be > 0");
  require(height > 0, "height", "must be > 0");
}
/// True when pixel (u, v) rounds into the image.
template <typename Scalar>
inline bool pixel_in_image(Scalar u, Scalar v, int width, int height) {
  return u >= Scalar(-0.5) && v >= Scalar(-0.5) && u < Scalar(width) - Scalar(0.5) &&
         v < Scalar(height) - Scalar(0.5);
}
}  // namespace detail

/// Ideal pinhole camera: u = fx x/z + cx, v = fy y/z + cy.
template <typename Scalar_>
class PinholeCamera {
 public:
  using Scalar = Scalar_;
  using Vector2 = Eigen::Matrix<Scalar, 2, 1>;
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;

  /// Throws std::invalid_argument naming the argument for a non-finite or non-positive focal length,
  /// a non-finite principal point or a non-positive image size.
  PinholeCamera(Scalar fx, Scalar fy, Scalar cx, Scalar cy, int width, int height)
      : fx_(fx), fy_(fy), cx_(cx), cy_(cy), width_(width), height_(height) {
    detail::require_intrinsics(fx, fy, cx, cy, width, height);
  }

  int width() const { return width_; }
  int height() const { return height_; }
  Scalar fx() const { return fx_; }
  Scalar fy() const { return fy_; }
  Scalar cx() const { return cx_; }
  Scalar cy() const { return cy_; }

  std::optional<Vector2> project(const Vector3& p) const {
    if (!(p.z() > Scalar(0)) || !p.allFinite()) return std::nullopt;
    const Scalar inv_z = Scalar(1) / p.z();
    const Scalar u = fx_ * p.x() * inv_z + cx_;
    const Scalar v = fy_ * p.y() * inv_z + cy_;
    if (!detail::pixel_in_image(u, v, width_, height_)) return std::nullopt;
    return Vector2(u, v);
  }

  Vector3 backproject(Scalar u, Scalar v, Scalar depth) const {
    return Vector3((u - cx_) / fx_ * depth, (v - cy_) / fy_ * depth, depth);
  }

  template <typename NewScalar>
  PinholeCamera<NewScalar> cast() const {
    return PinholeCamera<NewScalar>(NewScalar(fx_), NewScalar(fy_), NewScalar(cx_), NewScalar(cy_), width_, height_);
  }

 private:
  Scalar fx_, fy_, cx_, cy_;
  int width_, height_;
};

using PinholeCameraf = PinholeCamera<float>;
using PinholeCamerad = PinholeCamera<double>;

}  // namespace binpick
