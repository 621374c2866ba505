#pragma once
/// \file geometry.hpp
/// Geometry primitives of the sensing-path planner (paper §III.C.2, Alg. 2): sphere, plane, circle,
/// line, in-plane rotation and the intersections Alg. 2 needs.
#include "binpick/geometry/circle.hpp"
#include "binpick/geometry/in_plane_rotation.hpp"
#include "binpick/geometry/line.hpp"
#include "binpick/geometry/line_circle_intersection.hpp"
#include "binpick/geometry/plane.hpp"
#include "binpick/geometry/sphere.hpp"
#include "binpick/geometry/tolerance.hpp"
