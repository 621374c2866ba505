#pragma once
/// \file brown_conrady_camera.hpp
/// Pinhole camera with Brown–Conrady lens distortion, OpenCV's 5-parameter model (k1, k2, p1, p2, k3):
///   x = X/Z, y = Y/Z, r² = x² + y², radial = 1 + k1 r² + k2 r⁴ + k3 r⁶
///   x_d = x radial + 2 p1 x y + p2 (r² + 2x²),  y_d = y radial + p1 (r² + 2y²) + 2 p2 x y
///   u = fx x_d + cx,  v = fy y_d + cy
/// Backprojection inverts the distortion iteratively (Gauss–Newton on the 2×2 Jacobian, at most
/// `max_undistort_iterations`). Where the inversion does not converge (far outside the lens' valid
/// field) the result of the last iterate is returned; project() of it then falls outside the image.

#include "binpick/core/camera_model.hpp"
#include "binpick/core/scalar_traits.hpp"

namespace binpick {

template <typename Scalar>
struct BrownConradyDistortion {
  Scalar k1 = 0, k2 = 0, p1 = 0, p2 = 0, k3 = 0;  ///< OpenCV order: k1 k2 p1 p2 k3
};

template <typename Scalar_>
class BrownConradyCamera {
 public:
  using Scalar = Scalar_;
  using Vector2 = Eigen::Matrix<Scalar, 2, 1>;
  using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
  static constexpr int max_undistort_iterations = 20;

  /// Throws std::invalid_argument naming the argument for invalid intrinsics (as PinholeCamera) or a
  /// non-finite distortion coefficient.
  BrownConradyCamera(Scalar fx, Scalar fy, Scalar cx, Scalar cy, int width, int height,
                     const BrownConradyDistortion<Scalar>& distortion)
      : fx_(fx), fy_(fy), cx_(cx), cy_(cy), width_(width), height_(height), d_(distortion) {
    detail::require_intrinsics(fx, fy, cx, cy, width, height);
    require(std::isfinite(d_.k1), "k1", "must be finite");
    require(std::isfinite(d_.k2), "k2", "must be finite");
    require(std::isfinite(d_.k3), "k3", "must be finite");
    require(std::isfinite(d_.p1), "p1", "must be finite");
    require(std::isfinite(d_.p2), "p2", "must be finite");
  }

  int width() const { return width_; }
  int height() const { return height_; }
  Scalar fx() const { return fx_; }
  Scalar fy() const { return fy_; }
  Scalar cx() const { return cx_; }
  Scalar cy() const { return cy_; }
  const BrownConradyDistortion<Scalar>& distortion() const { return d_; }

  /// Distorted normalized coordinates of undistorted normalized (x, y).
  Vector2 distort(Scalar x, Scalar y) const {
    const Scalar r2 = x * x + y * y;
    const Scalar radial = Scalar(1) + r2 * (d_.k1 + r2 * (d_.k2 + r2 * d_.k3));
    return Vector2(x * radial + Scalar(2) * d_.p1 * x * y + d_.p2 * (r2 + Scalar(2) * x * x),
                   y * radial + d_.p1 * (r2 + Scalar(2) * y * y) + Scalar(2) * d_.p2 * x * y);
  }

  std::optional<Vector2> project(const Vector3& p) const {
    if (!(p.z() > Scalar(0)) || !p.allFinite()) return std::nullopt;
    const Vector2 xd = distort(p.x() / p.z(), p.y() / p.z());
    const Scalar u = fx_ * xd.x() + cx_;
    const Scalar v = fy_ * xd.y() + cy_;
    if (!detail::pixel_in_image(u, v, width_, height_)) return std::nullopt;
    return Vector2(u, v);
  }

  Vector3 backproject(Scalar u, Scalar v, Scalar depth) const {
    const Vector2 n = undistort(Vector2((u - cx_) / fx_, (v - cy_) / fy_));
    return Vector3(n.x() * depth, n.y() * depth, depth);
  }

  /// Undistorted normalized coordinates whose distortion is `xd` (Gauss–Newton, see file comment).
  Vector2 undistort(const Vector2& xd) const {
    Vector2 x = xd;
    const Scalar tol = ScalarTraits<Scalar>::solve_tolerance();
    for (int it = 0; it < max_undistort_iterations; ++it) {
      const Scalar r2 = x.squaredNorm();
      const Scalar radial = Scalar(1) + r2 * (d_.k1 + r2 * (d_.k2 + r2 * d_.k3));
      const Scalar dradial = d_.k1 + r2 * (Scalar(2) * d_.k2 + Scalar(3) * d_.k3 * r2);  // d radial / d r2
      const Vector2 e = distort(x.x(), x.y()) - xd;
      Eigen::Matrix<Scalar, 2, 2> J;
      J(0, 0) = radial + Scalar(2) * x.x() * x.x() * dradial + Scalar(2) * d_.p1 * x.y() + Scalar(6) * d_.p2 * x.x();
      J(0, 1) = Scalar(2) * x.x() * x.y() * dradial + Scalar(2) * d_.p1 * x.x() + Scalar(2) * d_.p2 * x.y();
      J(1, 0) = Scalar(2) * x.x() * x.y() * dradial + Scalar(2) * d_.p1 * x.x() + Scalar(2) * d_.p2 * x.y();
      J(1, 1) = radial + Scalar(2) * x.y() * x.y() * dradial + Scalar(6) * d_.p1 * x.y() + Scalar(2) * d_.p2 * x.x();
      const Scalar det = J.determinant();
      if (!(std::abs(det) > Scalar(1e-12)) || !std::isfinite(det)) break;
      const Vector2 step = J.inverse() * e;
      x -= step;
      if (!x.allFinite()) return xd;  // diverged: fall back to the distorted coordinates
      if (step.squaredNorm() <= tol * tol * (Scalar(1) + x.squaredNorm())) break;
    }
    return x;
  }

  template <typename NewScalar>
  BrownConradyCamera<NewScalar> cast() const {
    BrownConradyDistortion<NewScalar> d{NewScalar(d_.k1), NewScalar(d_.k2), NewScalar(d_.p1), NewScalar(d_.p2),
                                        NewScalar(d_.k3)};
    return BrownConradyCamera<NewScalar>(NewScalar(fx_), NewScalar(fy_), NewScalar(cx_), NewScalar(cy_), width_,
                                         height_, d);
  }

 private:
  Scalar fx_, fy_, cx_, cy_;
  int width_, height_;
  BrownConradyDistortion<Scalar> d_;
};

using BrownConradyCameraf = BrownConradyCamera<float>;
using BrownConradyCamerad = BrownConradyCamera<double>;

}  // namespace binpick
