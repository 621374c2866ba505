// Properties of the active-vision planner (paper §III.C–D): target center (Eq. 1), sensing path
// (Alg. 2), path parameters and their offline determination; float and double.
#include <algorithm>
#include <cmath>
#include <type_traits>
#include <vector>

#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include "binpick/active_vision.hpp"
#include "test_support.hpp"

using namespace binpick;
using namespace binpick::active_vision;
using binpick::test::uniform;

namespace {

using binpick::test::kDeg;
using binpick::test::kPi;

template <typename Scalar>
constexpr bool is_float() {
  return std::is_same<Scalar, float>::value;
}
// Length [m] and angle [rad] tolerances per scalar, for scenes of about a metre.
template <typename Scalar>
double len_tol() {
  return is_float<Scalar>() ? 3e-5 : 1e-10;
}
template <typename Scalar>
double ang_tol() {
  return is_float<Scalar>() ? 3e-4 : 1e-8;
}

template <typename Scalar>
Vector3<Scalar> v3(double x, double y, double z) {
  return Vector3<Scalar>(Scalar(x), Scalar(y), Scalar(z));
}

// ---- target center --------------------------------------------------------------------------------

template <typename Scalar>
void target_center_in_hull() {
  const int count = *rc::gen::inRange(1, 12);
  std::vector<Vector3<Scalar>> positions;
  std::vector<Scalar> confidences;
  for (int k = 0; k < count; ++k) {
    positions.push_back(v3<Scalar>(uniform(-1, 1), uniform(-1, 1), uniform(-0.2, 0.2)));
    confidences.push_back(*rc::gen::inRange(0, 4) == 0 ? Scalar(0) : Scalar(uniform(0, 100)));
  }
  const bool grasp_one = *rc::gen::arbitrary<bool>();
  const std::size_t grasped = grasp_one ? std::size_t(*rc::gen::inRange(0, count)) : no_grasped_object;
  const Vector3<Scalar> fallback = v3<Scalar>(0.5, 0.25, -1);
  const auto center = target_center(positions, confidences, fallback, grasped);
  RC_ASSERT(center.point.allFinite());
  bool any_weight = false;
  for (int k = 0; k < count; ++k) any_weight |= std::size_t(k) != grasped && confidences[std::size_t(k)] > 0;
  if (!any_weight) {
    RC_ASSERT(center.used_fallback());
    RC_ASSERT(center.point == fallback);
    return;
  }
  RC_ASSERT(center.status == TargetCenterStatus::weighted);
  // In the convex hull of the remaining objects with confidence > 0: no support direction separates it.
  for (int trial = 0; trial < 24; ++trial) {
    Eigen::Vector3d d(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1));
    if (trial < 3) d = Eigen::Vector3d::Unit(trial);
    double support = -1e30;
    for (int k = 0; k < count; ++k)
      if (std::size_t(k) != grasped && confidences[std::size_t(k)] > 0)
        support = std::max(support, d.dot(positions[std::size_t(k)].template cast<double>()));
    RC_ASSERT(d.dot(center.point.template cast<double>()) <= support + len_tol<Scalar>());
  }
  // The grasped object does not take part: moving it changes nothing.
  if (grasp_one) {
    auto moved = positions;
    moved[grasped] += v3<Scalar>(3, -2, 1);
    RC_ASSERT((target_center(moved, confidences, fallback, grasped).point - center.point).norm() <= Scalar(0));
  }
}

template <typename Scalar>
void target_center_equal_weights_is_mean() {
  const int count = *rc::gen::inRange(1, 12);
  const Scalar confidence = Scalar(uniform(1e-3, 1));
  std::vector<Vector3<Scalar>> positions;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (int k = 0; k < count; ++k) {
    positions.push_back(v3<Scalar>(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1)));
    mean += positions.back().template cast<double>() / count;
  }
  const auto center =
      target_center(positions, std::vector<Scalar>(std::size_t(count), confidence), Vector3<Scalar>::Zero().eval());
  RC_ASSERT((center.point.template cast<double>() - mean).norm() <= len_tol<Scalar>());
  RC_ASSERT(center.num_objects == count);
}

// ---- sensing path ---------------------------------------------------------------------------------

// A bin-picking scene in a random base frame: bin 50 cm x 25 cm x 10 cm, lift 5..20 cm above the
// grasp, drop 30..80 cm to the side, r = 0.2..0.5 m.
template <typename Scalar>
SensingPathRequest<Scalar> random_request() {
  const Isometry3<double> T_base_bin = binpick::test::random_pose<double>(kPi, 1.0);
  auto in_base = [&](double x, double y, double z) -> Vector3<Scalar> { return (T_base_bin * Eigen::Vector3d(x, y, z)).cast<Scalar>(); };
  const double ax = uniform(-0.25, 0.25), ay = uniform(-0.125, 0.125), az = uniform(0, 0.1);
  SensingPathRequest<Scalar> q;
  q.grasp = in_base(ax, ay, az);
  q.lift = in_base(ax, ay, az + uniform(0.05, 0.2));
  const double side = *rc::gen::arbitrary<bool>() ? 1 : -1;
  q.drop = in_base(side * uniform(0.3, 0.8), uniform(-0.3, 0.3), uniform(0, 0.3));
  q.target = in_base(uniform(-0.25, 0.25), uniform(-0.125, 0.125), uniform(0, 0.1));
  q.radius = Scalar(uniform(0.2, 0.5));
  q.gamma = Scalar(uniform(0, 10) * kDeg);
  q.beta = Scalar(uniform(2, 90) * kDeg);
  q.num_views = *rc::gen::inRange(2, 11);
  return q;
}

template <typename Scalar>
void sensing_path_properties() {
  const SensingPathRequest<Scalar> q = random_request<Scalar>();
  const auto path = plan_sensing_path(q);
  RC_CLASSIFY(path.ok(), "plan ok");
  // Independent reference geometry, in double.
  const Eigen::Vector3d A = q.grasp.template cast<double>(), B = q.lift.template cast<double>(),
                        C = q.drop.template cast<double>(), T = q.target.template cast<double>();
  const double r = double(q.radius);
  const Eigen::Vector3d u = (B - A).normalized();
  const Eigen::Vector3d k = u.cross(C - B).normalized();  // plane normal, oriented as the sweep axis
  const double h = k.dot(T - A);
  RC_ASSERT(std::abs(double(path.length_bc) - (C - B).norm()) <= len_tol<Scalar>());
  if (path.status == SensingPathStatus::sphere_misses_plane) RC_ASSERT(std::abs(h) >= r * (1 - 1e-4));
  if (std::abs(h) < r * (1 - 1e-3)) RC_ASSERT(path.status != SensingPathStatus::sphere_misses_plane);
  if (path.status == SensingPathStatus::coverage_exceeds_arc) {
    const double rho = std::sqrt(r * r - h * h);
    RC_ASSERT(double(q.beta) >= 2 * std::asin(rho / r) * (1 - 1e-4));
  }
  if (!path.ok()) {
    RC_ASSERT(path.T_base_captures.empty());
    return;
  }
  const Eigen::Vector3d M = path.start.template cast<double>(), N = path.end.template cast<double>();
  // M and N on S and in P.
  for (const Eigen::Vector3d& X : {M, N}) {
    RC_ASSERT(std::abs((X - T).norm() - r) <= len_tol<Scalar>());
    RC_ASSERT(std::abs(k.dot(X - A)) <= len_tol<Scalar>());
  }
  // Angle MTN = β at T.
  const double mtn = std::atan2((M - T).cross(N - T).norm(), (M - T).dot(N - T));
  RC_ASSERT(std::abs(mtn - double(q.beta)) <= ang_tol<Scalar>());
  // A'B: through B, in P, at angle γ to AB, tilted toward C; M ahead of B on it.
  const Eigen::Vector3d d = path.tilted_lift_line.direction.template cast<double>();
  RC_ASSERT(std::abs(std::atan2(u.cross(d).norm(), u.dot(d)) - double(q.gamma)) <= ang_tol<Scalar>());
  RC_ASSERT(std::abs(k.dot(d)) <= ang_tol<Scalar>());
  RC_ASSERT(double(path.tilted_lift_line.distance(q.lift)) <= len_tol<Scalar>());
  RC_ASSERT(k.cross(u).dot(d) >= -ang_tol<Scalar>());
  RC_ASSERT((M - B).dot(d) >= -len_tol<Scalar>());
  RC_ASSERT(((M - B) - (M - B).dot(d) * d).norm() <= 10 * len_tol<Scalar>());
  // N on the drop side: the arc M -> N turns about k (the sense that turns AB toward C).
  const Eigen::Vector3d c = path.arc.center.template cast<double>();
  RC_ASSERT((M - c).cross(N - c).dot(k) >= -len_tol<Scalar>());
  // The n capture poses: on S, optical axis through T, orthonormal, M first, N last, equal steps,
  // x along the travel, never below the horizontal through T.
  RC_ASSERT(int(path.T_base_captures.size()) == q.num_views);
  double step = -1;
  for (std::size_t i = 0; i < path.T_base_captures.size(); ++i) {
    const Isometry3<double> P = path.T_base_captures[i].template cast<double>();
    const Eigen::Vector3d X = P.translation();
    const Eigen::Matrix3d R = P.linear();
    RC_ASSERT((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() <= ang_tol<Scalar>());
    RC_ASSERT(R.determinant() > 0);
    RC_ASSERT(std::abs((X - T).norm() - r) <= len_tol<Scalar>());
    RC_ASSERT((R.col(2) - (T - X).normalized()).norm() <= ang_tol<Scalar>());
    RC_ASSERT(std::abs(k.dot(X - A)) <= len_tol<Scalar>());
    RC_ASSERT((X - T).dot(u) >= -len_tol<Scalar>());
    if (i + 1 < path.T_base_captures.size()) {
      const Eigen::Vector3d next = path.T_base_captures[i + 1].translation().template cast<double>();
      RC_ASSERT(R.col(0).dot(next - X) > 0);
      if (step < 0) step = (next - X).norm();
      RC_ASSERT(std::abs((next - X).norm() - step) <= 10 * len_tol<Scalar>());
    }
  }
  RC_ASSERT((path.T_base_captures.front().translation().template cast<double>() - M).norm() <= len_tol<Scalar>());
  RC_ASSERT((path.T_base_captures.back().translation().template cast<double>() - N).norm() <= len_tol<Scalar>());
  // Lengths: the arc is at least its chord, and the detour at least the straight move.
  const double polyline = (M - B).norm() + (N - M).norm() + (C - N).norm();
  RC_ASSERT(double(path.length_bmnc) >= polyline - 10 * len_tol<Scalar>());
  RC_ASSERT(double(path.length_bmnc) >= double(path.length_bc) - 10 * len_tol<Scalar>());
  // Neighbouring views are α apart at T, α the target angle of the central step (parameters.hpp).
  if (q.num_views >= 2) {
    const Eigen::Vector3d X0 = path.T_base_captures[0].translation().template cast<double>();
    const Eigen::Vector3d X1 = path.T_base_captures[1].translation().template cast<double>();
    const double alpha = std::atan2((X0 - T).cross(X1 - T).norm(), (X0 - T).dot(X1 - T));
    const double rho = double(path.arc.radius);
    const double expected = double(central_to_target_angle<double>(double(path.central_angle) / (q.num_views - 1), r,
                                                                   std::min(rho, r)));
    RC_ASSERT(std::abs(alpha - expected) <= ang_tol<Scalar>());
  }
}

// With T in P, Alg. 2 lines 4–5 hold literally: N is where the line MT, rotated by β about T within P,
// meets L. Differential check against the geometry primitives.
template <typename Scalar>
void sensing_path_literal_when_target_in_plane() {
  SensingPathRequest<Scalar> q = random_request<Scalar>();
  const auto plane = geometry::plane_through_points<Scalar>(q.grasp, q.lift, q.drop);
  RC_PRE(plane.has_value());
  q.target = plane->project(q.target);
  const auto path = plan_sensing_path(q);
  RC_PRE(path.ok());
  const Vector3<Scalar> k = path.plane.normal;
  const geometry::Line3<Scalar> mt{q.target, (path.start - q.target).normalized()};
  const auto rotated = geometry::rotate_line_in_plane<Scalar>(mt, q.target, k, q.beta);
  const auto N = geometry::exit_point(rotated, path.arc);
  RC_ASSERT(N.has_value());
  RC_ASSERT(double((*N - path.end).norm()) <= 10 * len_tol<Scalar>());
  RC_ASSERT(std::abs(double(path.central_angle - q.beta)) <= ang_tol<Scalar>());
}

// ---- parameters -----------------------------------------------------------------------------------

template <typename Scalar>
void parameters_round_trip() {
  const double r = uniform(0.2, 0.5);
  const double rho = r * uniform(0.1, 1.0);
  MotionParameters<Scalar> motion{Scalar(uniform(0.05, 1.0)), Scalar(uniform(0.005, 0.08)), *rc::gen::inRange(2, 11)};
  // Keep the sweep within half the arc, and the views resolvable (n from the ratio of angles).
  const double max_speed = 0.9 * kPi * rho / ((motion.num_views - 1) * double(motion.interval));
  motion.speed = Scalar(std::min(double(motion.speed), max_speed));
  RC_PRE(double(motion.speed * motion.interval) / rho > 1e-3);
  const auto angles = path_angles_from_motion(motion, Scalar(r), Scalar(rho));
  RC_ASSERT(angles.alpha > Scalar(0));
  RC_ASSERT(angles.beta >= angles.alpha * Scalar(1 - 1e-5));
  // The chord of one step seen from T and from the arc's center is the same.
  const double step = double(motion.speed * motion.interval) / rho;
  RC_ASSERT(std::abs(r * std::sin(double(angles.alpha) / 2) - rho * std::sin(step / 2)) <= len_tol<Scalar>());
  if (rho == r) RC_ASSERT(std::abs(double(angles.beta) - step * (motion.num_views - 1)) <= ang_tol<Scalar>());
  const auto back = motion_from_path_angles(angles, motion.interval, Scalar(r), Scalar(rho));
  RC_ASSERT(back.num_views == motion.num_views);
  RC_ASSERT(std::abs(double(back.speed - motion.speed)) <= 1e3 * ang_tol<Scalar>() * double(motion.speed));
  RC_ASSERT(back.interval == motion.interval);
}

template <typename Scalar>
void parameters_in_plane_formula() {
  const Scalar r = Scalar(uniform(0.2, 0.5));
  const MotionParameters<Scalar> motion{Scalar(uniform(0.05, 0.8)), Scalar(0.01), *rc::gen::inRange(2, 11)};
  const auto angles = path_angles_from_motion(motion, r);
  const double beta = double(motion.speed) * 0.01 * (motion.num_views - 1) / double(r);  // Fig. 8
  RC_ASSERT(std::abs(double(angles.beta) - beta) <= ang_tol<Scalar>());
  RC_ASSERT(std::abs(double(angles.alpha) - beta / (motion.num_views - 1)) <= ang_tol<Scalar>());
}

}  // namespace

RC_GTEST_PROP(TargetCenter, InConvexHullDouble, ()) { target_center_in_hull<double>(); }
RC_GTEST_PROP(TargetCenter, InConvexHullFloat, ()) { target_center_in_hull<float>(); }
RC_GTEST_PROP(TargetCenter, EqualWeightsIsMeanDouble, ()) { target_center_equal_weights_is_mean<double>(); }
RC_GTEST_PROP(TargetCenter, EqualWeightsIsMeanFloat, ()) { target_center_equal_weights_is_mean<float>(); }

TEST(TargetCenter, HandExampleAndFallbacks) {
  // Eq. 1 by hand: objects at x = 0, 1, 4 with confidences 90, 10 (grasped: left out), 30:
  // T = (90 * 0 + 30 * 4) / (90 + 30) = 120 / 120 = 1.
  const std::vector<Eigen::Vector3d> X{{0, 0, 0}, {1, 0, 0}, {4, 0, 0}};
  const auto center = target_center(X, std::vector<double>{90, 10, 30}, Eigen::Vector3d(9, 9, 9), 1);
  EXPECT_EQ(center.status, TargetCenterStatus::weighted);
  EXPECT_NEAR(center.point.x(), 1.0, 1e-15);
  EXPECT_EQ(center.num_objects, 2);
  EXPECT_DOUBLE_EQ(center.total_confidence, 120.0);
  const Eigen::Vector3d bin_center(0.1, 0.2, 0.3);
  EXPECT_EQ(target_center(std::vector<Eigen::Vector3d>{}, std::vector<double>{}, bin_center).status,
            TargetCenterStatus::fallback_no_objects);
  const auto only_grasped = target_center(std::vector<Eigen::Vector3d>{{1, 1, 1}}, std::vector<double>{50}, bin_center, 0);
  EXPECT_EQ(only_grasped.status, TargetCenterStatus::fallback_no_objects);
  EXPECT_EQ(only_grasped.point, bin_center);
  const auto zero = target_center(X, std::vector<double>{0, 0, 0}, bin_center);
  EXPECT_EQ(zero.status, TargetCenterStatus::fallback_zero_confidence);
  EXPECT_EQ(zero.point, bin_center);
  // Tiny float confidences neither underflow nor make NaN.
  const std::vector<Eigen::Vector3f> Xf{{0, 0, 0}, {2, 0, 0}};
  const auto tiny = target_center(Xf, std::vector<float>{1e-44f, 1e-44f}, Eigen::Vector3f::Zero().eval());
  EXPECT_EQ(tiny.status, TargetCenterStatus::weighted);
  EXPECT_NEAR(tiny.point.x(), 1.0f, 1e-6f);
}

TEST(TargetCenter, PreconditionsThrow) {
  const std::vector<Eigen::Vector3d> X{{0, 0, 0}, {1, 0, 0}};
  const Eigen::Vector3d f = Eigen::Vector3d::Zero();
  EXPECT_THROW(target_center(X, std::vector<double>{1, -1}, f), std::invalid_argument);
  EXPECT_THROW(target_center(X, std::vector<double>{1, NAN}, f), std::invalid_argument);
  EXPECT_THROW(target_center(X, std::vector<double>{1, INFINITY}, f), std::invalid_argument);
  EXPECT_THROW(target_center(X, std::vector<double>{1}, f), std::invalid_argument);
  EXPECT_THROW(target_center(X, std::vector<double>{1, 1}, f, 2), std::invalid_argument);
  EXPECT_THROW(target_center(X, std::vector<double>{1, 1}, Eigen::Vector3d(NAN, 0, 0)), std::invalid_argument);
  EXPECT_THROW(target_center(std::vector<Eigen::Vector3d>{{0, NAN, 0}}, std::vector<double>{1}, f), std::invalid_argument);
}

RC_GTEST_PROP(SensingPath, PropertiesDouble, ()) { sensing_path_properties<double>(); }
RC_GTEST_PROP(SensingPath, PropertiesFloat, ()) { sensing_path_properties<float>(); }
RC_GTEST_PROP(SensingPath, LiteralAlg2WhenTargetInPlaneDouble, ()) { sensing_path_literal_when_target_in_plane<double>(); }
RC_GTEST_PROP(SensingPath, LiteralAlg2WhenTargetInPlaneFloat, ()) { sensing_path_literal_when_target_in_plane<float>(); }

// A worked example, computed by hand (base frame, metres):
//   A = (0, 0, 0), B = (0, 0, 0.1), C = (0.5, 0, 0.1): P is the plane y = 0; lift u = +z, toward-drop
//   w = +x, sweep axis k = u × w = +y.
//   T = (0.1, 0.1, 0), r = 0.3: h = dist(T, P) = 0.1, L has center c = (0.1, 0, 0) and radius
//   rho = sqrt(0.09 - 0.01) = sqrt(0.08) = 0.2828427.
//   γ = 5°: A'B = B + s (sin γ, 0, cos γ) = B + s (0.0871557, 0, 0.9961947).
//   M on L: (s sin γ - 0.1)^2 + (0.1 + s cos γ)^2 = 0.08
//        => s^2 + 0.2 (cos γ - sin γ) s + 0.02 - 0.08 = 0 => s^2 + 0.1818078 s - 0.06 = 0
//        => s = -0.0909039 + sqrt(0.0909039^2 + 0.06) = -0.0909039 + 0.2612729 = 0.1703690 (the root
//           ahead of B); M = (0.1703690 * 0.0871557, 0, 0.1 + 0.1703690 * 0.9961947)
//             = (0.0148486, 0, 0.2697207).
//   β = 60°: the triangle TMN is equilateral, |MN| = r = 0.3; the central angle has the same chord:
//        2 rho sin(phi / 2) = 0.3 => sin(phi / 2) = 0.3 / 0.5656854 = 0.5303301 => phi = 1.1179797 rad.
//   N = c + R_y(phi) (M - c), M - c = (-0.0851514, 0, 0.2697207), cos phi = 0.4375, sin phi = 0.8992184:
//        N = (0.1 - 0.0851514 * 0.4375 + 0.2697207 * 0.8992184, 0,
//             0.0851514 * 0.8992184 + 0.2697207 * 0.4375) = (0.3052841, 0, 0.1945725).
//   Lengths: |BM| = s = 0.1703690; arc = rho phi = 0.2828427 * 1.1179797 = 0.3162124;
//        |NC| = |(0.1947159, 0, -0.0945725)| = 0.2164676; length_bmnc = 0.7030490; length_bc = 0.5.
TEST(SensingPath, WorkedExampleByHand) {
  const auto path = plan_sensing_path<double>(Eigen::Vector3d(0.1, 0.1, 0), 0.3, Eigen::Vector3d(0, 0, 0),
                                              Eigen::Vector3d(0, 0, 0.1), Eigen::Vector3d(0.5, 0, 0.1), 5 * kDeg,
                                              60 * kDeg, 3);
  ASSERT_TRUE(path.ok()) << to_string(path.status);
  EXPECT_NEAR(path.arc.radius, 0.2828427, 1e-7);
  EXPECT_NEAR(path.start.x(), 0.0148486, 1e-7);
  EXPECT_NEAR(path.start.y(), 0.0, 1e-12);
  EXPECT_NEAR(path.start.z(), 0.2697207, 1e-7);
  EXPECT_NEAR(path.central_angle, 1.1179797, 1e-7);
  EXPECT_NEAR(path.end.x(), 0.3052841, 1e-7);
  EXPECT_NEAR(path.end.y(), 0.0, 1e-12);
  EXPECT_NEAR(path.end.z(), 0.1945725, 1e-7);
  EXPECT_NEAR(path.length_bmnc, 0.7030490, 1e-7);
  EXPECT_NEAR(path.length_bc, 0.5, 1e-12);
  // The start camera looks from M at T, x along the travel (toward +x), y = z × x.
  const Eigen::Vector3d z = (Eigen::Vector3d(0.1, 0.1, 0) - path.start).normalized();
  EXPECT_NEAR((path.T_base_start.linear().col(2) - z).norm(), 0, 1e-12);
  EXPECT_GT(path.T_base_start.linear().col(0).x(), 0.9);
  ASSERT_EQ(path.T_base_captures.size(), 3u);
  EXPECT_NEAR((path.T_base_captures[2].translation() - path.end).norm(), 0, 1e-12);
}

TEST(SensingPath, WorkedExampleByHandFloat) {
  SensingPathRequest<float> q;
  q.target = Eigen::Vector3f(0.1f, 0.1f, 0);
  q.radius = 0.3f;
  q.grasp = Eigen::Vector3f(0, 0, 0);
  q.lift = Eigen::Vector3f(0, 0, 0.1f);
  q.drop = Eigen::Vector3f(0.5f, 0, 0.1f);
  q.beta = float(60 * kDeg);  // γ keeps its default of 5°
  q.num_views = 4;
  const auto path = plan_sensing_path(q);
  ASSERT_TRUE(path.ok()) << to_string(path.status);
  EXPECT_NEAR(path.start.x(), 0.0148486f, 2e-6f);
  EXPECT_NEAR(path.start.z(), 0.2697207f, 2e-6f);
  EXPECT_NEAR(path.end.x(), 0.3052841f, 2e-6f);
  EXPECT_NEAR(path.end.z(), 0.1945725f, 2e-6f);
  EXPECT_NEAR(path.length_bmnc, 0.7030490f, 4e-6f);
  EXPECT_EQ(path.T_base_captures.size(), 4u);
}

TEST(SensingPath, DegenerateGeometry) {
  const Eigen::Vector3d T(0, 0, 0), A(0, 0, 0.05), B(0, 0, 0.15), C(0.5, 0, 0.15);
  // Picking straight below the drop point: A, B, C collinear, no plane P.
  EXPECT_EQ(plan_sensing_path<double>(T, 0.3, A, B, Eigen::Vector3d(0, 0, 0.4), 0.1, 0.5, 5).status,
            SensingPathStatus::collinear_points);
  // Drop point equal to the lift point: no plane either.
  EXPECT_EQ(plan_sensing_path<double>(T, 0.3, A, B, B, 0.1, 0.5, 5).status, SensingPathStatus::collinear_points);
  // The target 0.4 m beside P with r = 0.3: S misses P.
  EXPECT_EQ(plan_sensing_path<double>(Eigen::Vector3d(0, 0.4, 0), 0.3, A, B, C, 0.1, 0.5, 5).status,
            SensingPathStatus::sphere_misses_plane);
  // The lift point far above the sphere: the tilted lift line meets L only behind B.
  EXPECT_EQ(plan_sensing_path<double>(T, 0.3, A, Eigen::Vector3d(0, 0, 1.0), Eigen::Vector3d(0.5, 0, 1.0), 0.1, 0.5, 5)
                .status,
            SensingPathStatus::no_start_point);
  // β beyond what the arc offers: T 0.2 m off P, rho = sqrt(0.05), max angle 2 asin(0.745) = 96.3°.
  EXPECT_EQ(plan_sensing_path<double>(Eigen::Vector3d(0, 0.2, 0), 0.3, A, B, C, 0.1, 100 * kDeg, 5).status,
            SensingPathStatus::coverage_exceeds_arc);
  // 90° fits the arc (with the elevation limit relaxed: N ends below T's horizontal plane here).
  EXPECT_TRUE(plan_sensing_path<double>(Eigen::Vector3d(0, 0.2, 0), 0.3, A, B, C, 0.1, 90 * kDeg, 5, -1.5).ok());
  // β = 150° from near the top sweeps the sensor below the target's horizontal plane.
  const auto low = plan_sensing_path<double>(T, 0.3, A, B, C, 0.1, 150 * kDeg, 5);
  EXPECT_EQ(low.status, SensingPathStatus::below_min_elevation);
  EXPECT_TRUE(low.T_base_captures.empty());
  EXPECT_TRUE(low.start.allFinite() && low.end.allFinite());
  // A stricter elevation limit rejects a path the default accepts.
  EXPECT_TRUE(plan_sensing_path<double>(T, 0.3, A, B, C, 0.1, 60 * kDeg, 5).ok());
  EXPECT_EQ(plan_sensing_path<double>(T, 0.3, A, B, C, 0.1, 60 * kDeg, 5, 45 * kDeg).status,
            SensingPathStatus::below_min_elevation);
  // Every status has a message.
  for (auto s : {SensingPathStatus::ok, SensingPathStatus::collinear_points, SensingPathStatus::sphere_misses_plane,
                 SensingPathStatus::no_start_point, SensingPathStatus::coverage_exceeds_arc,
                 SensingPathStatus::below_min_elevation})
    EXPECT_STRNE(to_string(s), "unknown");
}

TEST(SensingPath, PreconditionsThrow) {
  const Eigen::Vector3d T(0, 0, 0), A(0, 0, 0.05), B(0, 0, 0.15), C(0.5, 0, 0.15);
  EXPECT_THROW(plan_sensing_path<double>(T, 0.0, A, B, C, 0.1, 0.5, 5), std::invalid_argument);
  EXPECT_THROW(plan_sensing_path<double>(T, 0.3, A, A, C, 0.1, 0.5, 5), std::invalid_argument);
  EXPECT_THROW(plan_sensing_path<double>(T, 0.3, A, B, C, -0.1, 0.5, 5), std::invalid_argument);
  EXPECT_THROW(plan_sensing_path<double>(T, 0.3, A, B, C, 0.1, 0.0, 5), std::invalid_argument);
  EXPECT_THROW(plan_sensing_path<double>(T, 0.3, A, B, C, 0.1, 4.0, 5), std::invalid_argument);
  EXPECT_THROW(plan_sensing_path<double>(T, 0.3, A, B, C, 0.1, 0.5, 1), std::invalid_argument);
  EXPECT_THROW(plan_sensing_path<double>(Eigen::Vector3d(NAN, 0, 0), 0.3, A, B, C, 0.1, 0.5, 5), std::invalid_argument);
  EXPECT_THROW(plan_sensing_path<float>(Eigen::Vector3f::Zero(), 0.3f, Eigen::Vector3f(0, 0, 0.05f),
                                        Eigen::Vector3f(0, 0, 0.15f), Eigen::Vector3f(INFINITY, 0, 0), 0.1f, 0.5f, 5),
               std::invalid_argument);
}

RC_GTEST_PROP(Parameters, RoundTripDouble, ()) { parameters_round_trip<double>(); }
RC_GTEST_PROP(Parameters, RoundTripFloat, ()) { parameters_round_trip<float>(); }
RC_GTEST_PROP(Parameters, InPlaneFormulaDouble, ()) { parameters_in_plane_formula<double>(); }
RC_GTEST_PROP(Parameters, InPlaneFormulaFloat, ()) { parameters_in_plane_formula<float>(); }

TEST(Parameters, ArcAnglesByHand) {
  // T in P: the angles agree. T 0.1 m off P with r = 0.3: rho = sqrt(0.08); a central angle of 90°
  // has the chord rho * sqrt(2) = 0.4, so sin(theta / 2) = 0.2 / 0.3 and theta = 2 asin(2/3) = 83.62°.
  EXPECT_NEAR(central_to_target_angle(0.7, 0.3, 0.3), 0.7, 1e-15);
  EXPECT_NEAR(central_to_target_angle(kPi / 2, 0.3, std::sqrt(0.08)), 2 * std::asin(2.0 / 3.0), 1e-12);
  EXPECT_NEAR(target_to_central_angle(2 * std::asin(2.0 / 3.0), 0.3, std::sqrt(0.08)), kPi / 2, 1e-12);
  EXPECT_THROW(target_to_central_angle(3.0, 0.3, std::sqrt(0.08)), std::invalid_argument);
  EXPECT_THROW(central_to_target_angle(4.0, 0.3, 0.3), std::invalid_argument);
  EXPECT_THROW(central_to_target_angle(1.0, 0.3, 0.4), std::invalid_argument);
  // Motion limits.
  EXPECT_THROW(path_angles_from_motion(MotionParameters<double>{1.0, 0.5, 5}, 0.3), std::invalid_argument);
  EXPECT_THROW(path_angles_from_motion(MotionParameters<double>{0.5, 0.01, 1}, 0.3), std::invalid_argument);
  EXPECT_THROW(motion_from_path_angles(PathAngles<double>{0.2, 0.1}, 0.01, 0.3), std::invalid_argument);
}

// The offline determination on a table computed by hand. Counts (10 trials): 2, 2, 2, 2, 4, 4, 4, 6, 6, 8.
// mean = 40 / 10 = 4; squared deviations 4 * 4 + 0 + 2 * 4 + 16 = 40, sigma = sqrt(40 / 10) = 2.
// Band [mean + sigma, mean + 2 sigma] = [6, 8]: the trials with 6, 6 and 8 (edges included).
// Their n: 5, 5, 3 -> n = 5. Highest v among n = 5: 0.6 m/s (t = 0.01 s).
// With r = 0.3 and T in P: alpha = v t / r = 0.006 / 0.3 = 0.02 rad, beta = 4 * alpha = 0.08 rad.
// Outside the band: a faster n = 5 trial (1.0 m/s, count 4) and an n = 3 trial at 0.8 m/s.
TEST(Parameters, OfflineDeterminationByHand) {
  using Trial = ParameterTrial<double>;
  const std::vector<Trial> trials{{0.2, 0.01, 3, 2}, {0.8, 0.01, 3, 2}, {0.3, 0.02, 7, 2}, {0.5, 0.01, 9, 2},
                                  {1.0, 0.01, 5, 4}, {0.4, 0.01, 4, 4}, {0.2, 0.02, 6, 4}, {0.4, 0.01, 5, 6},
                                  {0.6, 0.01, 5, 6}, {0.7, 0.01, 3, 8}};
  const auto selection = select_path_parameters(trials, 0.3);
  ASSERT_TRUE(selection.ok());
  EXPECT_NEAR(selection.mean, 4.0, 1e-12);
  EXPECT_NEAR(selection.sigma, 2.0, 1e-12);
  EXPECT_EQ(selection.trials_in_band, 3u);
  EXPECT_EQ(selection.trials_with_n, 2u);
  EXPECT_EQ(selection.motion.num_views, 5);
  EXPECT_DOUBLE_EQ(selection.motion.speed, 0.6);
  EXPECT_DOUBLE_EQ(selection.motion.interval, 0.01);
  EXPECT_NEAR(selection.angles.alpha, 0.02, 1e-12);
  EXPECT_NEAR(selection.angles.beta, 0.08, 1e-12);
  // The float table gives the same choice.
  std::vector<ParameterTrial<float>> trials_f;
  for (const auto& t : trials)
    trials_f.push_back({float(t.speed), float(t.interval), t.num_views, float(t.recognized)});
  const auto selection_f = select_path_parameters(trials_f, 0.3f);
  ASSERT_TRUE(selection_f.ok());
  EXPECT_EQ(selection_f.motion.num_views, 5);
  EXPECT_FLOAT_EQ(selection_f.motion.speed, 0.6f);
}

TEST(Parameters, OfflineDeterminationDegenerate) {
  using Trial = ParameterTrial<double>;
  // Too few trials, or bad entries: errors.
  EXPECT_THROW(select_path_parameters(std::vector<Trial>{}, 0.3), std::invalid_argument);
  EXPECT_THROW(select_path_parameters(std::vector<Trial>{{0.5, 0.01, 5, 3}, {0.5, 0.01, 5, 4}}, 0.3),
               std::invalid_argument);
  EXPECT_THROW(select_path_parameters(std::vector<Trial>{{0.5, 0.01, 5, 3}, {0.5, 0.01, 5, 4}, {0.5, 0.01, 1, 4}}, 0.3),
               std::invalid_argument);
  EXPECT_THROW(select_path_parameters(std::vector<Trial>{{0.5, 0.01, 5, 3}, {0.5, 0.01, 5, -4}, {0.5, 0.01, 5, 4}}, 0.3),
               std::invalid_argument);
  // A skewed table with an empty band: counts 1 x5, 5 x4, 9: mean 3.4, sigma 2.653, band [6.05, 8.71].
  std::vector<Trial> skewed;
  for (int i = 0; i < 5; ++i) skewed.push_back({0.5, 0.01, 5, 1});
  for (int i = 0; i < 4; ++i) skewed.push_back({0.5, 0.01, 5, 5});
  skewed.push_back({0.5, 0.01, 5, 9});
  const auto empty = select_path_parameters(skewed, 0.3);
  EXPECT_EQ(empty.status, ParameterSelectionStatus::empty_band);
  EXPECT_EQ(empty.trials_in_band, 0u);
  // All counts equal: sigma = 0, every trial is kept; ties in n go to the smaller n.
  const auto flat = select_path_parameters(std::vector<Trial>{{0.5, 0.01, 6, 3}, {0.7, 0.01, 4, 3}, {0.2, 0.01, 6, 3},
                                                              {0.3, 0.01, 4, 3}},
                                           0.3);
  ASSERT_TRUE(flat.ok());
  EXPECT_EQ(flat.trials_in_band, 4u);
  EXPECT_EQ(flat.motion.num_views, 4);
  EXPECT_DOUBLE_EQ(flat.motion.speed, 0.7);
  // A selection that sweeps more than half the arc keeps (v, t, n) and says so.
  const auto long_arc = select_path_parameters(std::vector<Trial>{{1.0, 0.2, 9, 3}, {1.0, 0.2, 9, 3}, {1.0, 0.2, 9, 3}}, 0.3);
  EXPECT_EQ(long_arc.status, ParameterSelectionStatus::arc_too_long);
  EXPECT_EQ(long_arc.motion.num_views, 9);
}
