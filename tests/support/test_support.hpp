#pragma once
// Shared helpers of the test executables: rapidcheck generators for cameras, poses and scalars.
#include <cmath>
#include <string>

#include <Eigen/Geometry>
#include <rapidcheck.h>

#include "binpick/core.hpp"

namespace binpick::test {

// One definition for every test file: a module's files compile as one unit (BINPICK_UNITY_TESTS).
constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180;

/// A 3-vector of three calls of `draw` (a seeded generator), made in one fixed order on every
/// compiler: z, then y, then x. `Vector3(draw(), draw(), draw())` leaves the order unspecified (GCC
/// evaluates the arguments right to left, Clang left to right, so a seeded test saw other numbers
/// under each); this is the order GCC's builds used, so seeded tests keep their numbers there.
template <typename Scalar, typename Draw>
Eigen::Matrix<Scalar, 3, 1> draw3(Draw&& draw) {
  const Scalar z = Scalar(draw());
  const Scalar y = Scalar(draw());
  const Scalar x = Scalar(draw());
  return Eigen::Matrix<Scalar, 3, 1>(x, y, z);
}

/// Uniform real in [lo, hi] from rapidcheck (shrinks toward lo), whatever the case's size.
/// rapidcheck scales `inRange` by the size, which starts at 0 and grows by one per 10 discards: drawn
/// at the case's size, the first cases took only the low end of every range (all points of a plane
/// test the same point), and properties with RC_PRE on their draws discarded their way toward
/// giving up under RC_PARAMS max_success=10 (registration/scene.hpp met this first).
inline double uniform(double lo, double hi) {
  const int k = *rc::gen::resize(rc::kNominalSize, rc::gen::inRange(0, 1000001));
  return lo + (hi - lo) * (double(k) / 1000000.0);
}

/// A random rotation of at most max_angle [rad] about a random axis, and a translation of at most
/// max_translation [m] per axis.
template <typename Scalar>
Isometry3<Scalar> random_pose(double max_angle, double max_translation) {
  Eigen::Vector3d axis(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1));
  if (axis.norm() < 1e-3) axis = Eigen::Vector3d::UnitZ();
  const double angle = uniform(-max_angle, max_angle);
  Isometry3<double> T = Isometry3<double>::Identity();
  T.linear() = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(uniform(-max_translation, max_translation), uniform(-max_translation, max_translation),
                                    uniform(-max_translation, max_translation));
  return T.cast<Scalar>();
}

inline std::string data_dir() { return BINPICK_DATA_DIR; }

/// Caps the SIMD level (core/simd_level.hpp) for a scope: kernels with a run-time choice are tested
/// at every level of available_simd_levels().
struct SimdCap {
  explicit SimdCap(SimdLevel level) { set_max_simd_level(level); }
  ~SimdCap() { set_max_simd_level(SimdLevel::avx2); }
  SimdCap(const SimdCap&) = delete;
  SimdCap& operator=(const SimdCap&) = delete;
};

}  // namespace binpick::test
