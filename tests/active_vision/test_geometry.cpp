// Properties of the geometry primitives (sphere, plane, circle, line, in-plane rotation, intersections)
// for float and double.
#include <cmath>
#include <type_traits>

#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include "binpick/geometry.hpp"
#include "test_support.hpp"

using namespace binpick;
using namespace binpick::geometry;
using binpick::test::uniform;

namespace {

using binpick::test::kPi;

// Length tolerance per scalar for configurations of about a metre [m].
template <typename Scalar>
double tol() {
  return std::is_same<Scalar, float>::value ? 2e-5 : 1e-11;
}

template <typename Scalar>
Vector3<Scalar> random_point(double extent) {
  return Vector3<Scalar>(Scalar(uniform(-extent, extent)), Scalar(uniform(-extent, extent)),
                         Scalar(uniform(-extent, extent)));
}

template <typename Scalar>
Vector3<Scalar> random_unit() {
  Eigen::Vector3d v(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1));
  RC_PRE(v.norm() > 0.1);
  return v.normalized().cast<Scalar>();
}

// A unit vector perpendicular to the unit n.
template <typename Scalar>
Vector3<Scalar> perpendicular(const Vector3<Scalar>& n) {
  const Vector3<Scalar> a = std::abs(n.x()) < Scalar(0.9) ? Vector3<Scalar>::UnitX() : Vector3<Scalar>::UnitY();
  return n.cross(a).normalized();
}

template <typename Scalar>
void plane_through_points_holds_them() {
  const auto a = random_point<Scalar>(1), b = random_point<Scalar>(1), c = random_point<Scalar>(1);
  const auto plane = plane_through_points<Scalar>(a, b, c);
  const double sine = double((b - a).cross(c - a).norm() / ((b - a).norm() * (c - a).norm()));
  RC_PRE(sine > 1e-3);
  RC_ASSERT(plane.has_value());
  RC_ASSERT(std::abs(double(plane->normal.norm()) - 1) <= tol<Scalar>());
  for (const auto* p : {&a, &b, &c}) RC_ASSERT(std::abs(double(plane->signed_distance(*p))) <= tol<Scalar>());
  // Collinear points: c' on the line ab (also beyond b) give no plane. Rounding c' to the scalar moves it
  // off the line by about an ulp of the coordinates, so c' is kept well away from a.
  const Scalar s = Scalar(uniform(0.1, 2)) * (*rc::gen::arbitrary<bool>() ? Scalar(1) : Scalar(-1));
  RC_PRE((b - a).norm() > Scalar(0.1));
  RC_ASSERT(!plane_through_points<Scalar>(a, b, (a + s * (b - a)).eval()).has_value());
  RC_ASSERT(!plane_through_points<Scalar>(a, a, c).has_value());
}

template <typename Scalar>
void sphere_plane_circle_lies_on_both() {
  const auto sphere = Sphere<Scalar>::make(random_point<Scalar>(1), Scalar(uniform(0.05, 1)));
  const auto normal = random_unit<Scalar>();
  const Scalar h = Scalar(uniform(-1.5, 1.5)) * sphere.radius;
  const auto plane = Plane<Scalar>::from_point_normal(sphere.center + h * normal + perpendicular(normal) * Scalar(0.3), normal);
  const auto circle = intersect(sphere, plane);
  if (std::abs(double(h)) >= double(sphere.radius) * (1 + 1e-4)) {
    RC_ASSERT(!circle.has_value());
    return;
  }
  RC_PRE(std::abs(double(h)) < double(sphere.radius) * (1 - 1e-3));
  RC_ASSERT(circle.has_value());
  const Scalar angle = Scalar(uniform(0, 2 * kPi));
  const Vector3<Scalar> e = perpendicular(circle->normal);
  const Vector3<Scalar> x = circle->center + circle->radius * rotate_vector<Scalar>(e, circle->normal, angle);
  RC_ASSERT(std::abs(double(sphere.signed_distance(x))) <= tol<Scalar>());
  RC_ASSERT(std::abs(double(plane.signed_distance(x))) <= tol<Scalar>());
  RC_ASSERT(double(circle->distance(x)) <= tol<Scalar>());
}

template <typename Scalar>
void in_plane_rotation_turns_by_the_angle() {
  const auto normal = random_unit<Scalar>();
  const auto pivot = random_point<Scalar>(1);
  const Line3<Scalar> line{pivot - Scalar(uniform(-1, 1)) * perpendicular(normal), perpendicular(normal)};
  const Line3<Scalar> through_pivot{pivot, line.direction};
  const Scalar angle = Scalar(uniform(-kPi, kPi));
  const auto rotated = rotate_line_in_plane<Scalar>(through_pivot, pivot, normal, angle);
  RC_ASSERT(std::abs(double(angle_between<Scalar>(line.direction, rotated.direction)) - std::abs(double(angle))) <=
            10 * tol<Scalar>() + (std::is_same<Scalar, float>::value ? 1e-3 : 1e-7));
  RC_ASSERT(std::abs(double(rotated.direction.dot(normal))) <= tol<Scalar>());  // stays in the plane
  RC_ASSERT(double(rotated.distance(pivot)) <= tol<Scalar>());                    // keeps the pivot
  // Positive angles turn counter-clockwise about the normal (right-hand rule).
  const Vector3<Scalar> turn = line.direction.cross(rotated.direction);
  RC_ASSERT(double(turn.dot(normal)) * double(angle) >= -tol<Scalar>());
}

template <typename Scalar>
void line_circle_hits_lie_on_both() {
  const auto normal = random_unit<Scalar>();
  const Circle3<Scalar> circle{random_point<Scalar>(1), normal, Scalar(uniform(0.05, 1))};
  const Vector3<Scalar> dir = rotate_vector<Scalar>(perpendicular(normal), normal, Scalar(uniform(0, 2 * kPi)));
  const Vector3<Scalar> side = normal.cross(dir);
  const Scalar offset = Scalar(uniform(-1.5, 1.5)) * circle.radius;
  const Line3<Scalar> line{circle.center + offset * side + Scalar(uniform(-1, 1)) * dir, dir};
  const auto hits = intersect(line, circle);
  const double rel = std::abs(double(offset)) / double(circle.radius);
  if (rel > 1 + 1e-4) RC_ASSERT(hits.count == 0);
  if (rel < 1 - 1e-3) RC_ASSERT(hits.count == 2);
  for (int i = 0; i < hits.count; ++i) {
    RC_ASSERT(double(circle.distance(hits.points[i])) <= tol<Scalar>());
    RC_ASSERT(double((line.at(hits.t[i]) - hits.points[i]).norm()) <= tol<Scalar>());
  }
  if (hits.count == 2) {
    RC_ASSERT(hits.t[0] <= hits.t[1]);
    // The exit rule: the later hit along the direction, only when it is ahead of the line's point.
    const auto exit = exit_point(line, circle);
    RC_ASSERT(exit.has_value() == (hits.t[1] >= Scalar(0)) || std::abs(double(hits.t[1])) <= tol<Scalar>());
    if (exit) RC_ASSERT(double((*exit - hits.points[1]).norm()) <= tol<Scalar>());
  }
}

}  // namespace

RC_GTEST_PROP(Geometry, PlaneThroughPointsDouble, ()) { plane_through_points_holds_them<double>(); }
RC_GTEST_PROP(Geometry, PlaneThroughPointsFloat, ()) { plane_through_points_holds_them<float>(); }
RC_GTEST_PROP(Geometry, SpherePlaneCircleDouble, ()) { sphere_plane_circle_lies_on_both<double>(); }
RC_GTEST_PROP(Geometry, SpherePlaneCircleFloat, ()) { sphere_plane_circle_lies_on_both<float>(); }
RC_GTEST_PROP(Geometry, InPlaneRotationDouble, ()) { in_plane_rotation_turns_by_the_angle<double>(); }
RC_GTEST_PROP(Geometry, InPlaneRotationFloat, ()) { in_plane_rotation_turns_by_the_angle<float>(); }
RC_GTEST_PROP(Geometry, LineCircleDouble, ()) { line_circle_hits_lie_on_both<double>(); }
RC_GTEST_PROP(Geometry, LineCircleFloat, ()) { line_circle_hits_lie_on_both<float>(); }

TEST(Geometry, LineCircleHandExample) {
  // Unit circle in z = 0 at the origin; the line y = 0.6 along +x meets it at x = ±0.8.
  const Circle3<double> circle{Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), 1.0};
  const Line3<double> line{Eigen::Vector3d(0.5, 0.6, 0), Eigen::Vector3d::UnitX()};
  const auto hits = intersect(line, circle);
  ASSERT_EQ(hits.count, 2);
  EXPECT_NEAR(hits.points[0].x(), -0.8, 1e-12);
  EXPECT_NEAR(hits.t[0], -1.3, 1e-12);
  EXPECT_NEAR(hits.points[1].x(), 0.8, 1e-12);
  EXPECT_NEAR(hits.t[1], 0.3, 1e-12);
  // From x = 0.9 (outside) going -x the hits are at t = 0.1 and 1.7: the exit is x = -0.8. Going +x
  // from there both hits lie behind: no exit.
  const auto exit = exit_point(Line3<double>{Eigen::Vector3d(0.9, 0.6, 0), -Eigen::Vector3d::UnitX()}, circle);
  ASSERT_TRUE(exit.has_value());
  EXPECT_NEAR(exit->x(), -0.8, 1e-12);
  EXPECT_FALSE(exit_point(Line3<double>{Eigen::Vector3d(0.9, 0.6, 0), Eigen::Vector3d::UnitX()}, circle).has_value());
  // Tangent line y = 1: one hit.
  EXPECT_EQ(intersect(Line3<double>{Eigen::Vector3d(0, 1, 0), Eigen::Vector3d::UnitX()}, circle).count, 1);
  // A line perpendicular to the circle's plane: no hit.
  EXPECT_EQ(intersect(Line3<double>{Eigen::Vector3d(0.5, 0, 0), Eigen::Vector3d::UnitZ()}, circle).count, 0);
}

TEST(Geometry, PreconditionsThrow) {
  EXPECT_THROW(Sphere<double>::make(Eigen::Vector3d::Zero(), 0.0), std::invalid_argument);
  EXPECT_THROW(Sphere<double>::make(Eigen::Vector3d(NAN, 0, 0), 1.0), std::invalid_argument);
  EXPECT_THROW(Plane<float>::from_point_normal(Eigen::Vector3f::Zero(), Eigen::Vector3f::Zero()), std::invalid_argument);
  EXPECT_THROW(Line3<double>::through(Eigen::Vector3d::Ones(), Eigen::Vector3d::Ones()), std::invalid_argument);
  EXPECT_THROW(plane_through_points<double>(Eigen::Vector3d(INFINITY, 0, 0), Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX()),
               std::invalid_argument);
}
