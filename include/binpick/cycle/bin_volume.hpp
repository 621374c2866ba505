#pragma once
/// \file bin_volume.hpp
/// The known bin against the gripper. The cell knows where its bin stands (PipelineSettings), but an
/// estimator checks its grasps only against measured depth, and a view from above barely measures a
/// wall's inner face: a grasp beside a wall looks clear there, and its fingers hit the wall (the
/// paper's failed picks were gripper-box interference, §IV.D). Two checks use the known geometry:
///  - `BinVolume::blocks(p)`: a point of the gripper (base frame) below the floor or in a wall, for
///    estimators that sample their gripper (EstimatorInput::bin);
///  - `tool_clear_of_bin`: the space the tool takes at a grasp, a box in the grasp frame (`ToolBox`),
///    checked exactly before the pipeline chooses a grasp.
/// Base frame: z up. Metres.

#include <algorithm>
#include <cmath>

#include "binpick/core/errors.hpp"
#include "binpick/core/pose.hpp"

namespace binpick::cycle {

/// The inside of an open box: the floor's centre, inner length (base x) and width (base y), and the
/// wall height. Everything below the wall top and outside the inner rectangle counts as wall (the wall
/// thickness is not needed: the tool cannot reach beyond a wall without passing through it).
template <typename Scalar>
struct BinVolume {
  Vector3<Scalar> floor_center = Vector3<Scalar>::Zero();
  Scalar length = 0;  ///< inner size along base x [m]; 0 = no bin known
  Scalar width = 0;   ///< inner size along base y [m]
  Scalar height = 0;  ///< wall height above the floor [m]

  bool known() const { return length > Scalar(0) && width > Scalar(0); }
  /// Whether the point p (base frame) lies below the floor, or below the wall top and less than
  /// `margin` inside the walls' inner faces. False when no bin is known.
  bool blocks(const Vector3<Scalar>& p, Scalar margin = 0) const {
    if (!known()) return false;
    const Vector3<Scalar> d = p - floor_center;
    if (d.z() < Scalar(0)) return true;
    if (d.z() > height) return false;
    return std::abs(d.x()) > length / 2 - margin || std::abs(d.y()) > width / 2 - margin;
  }
};

/// The space a tool takes around a grasp: an axis-aligned box in the grasp frame (z = approach, from
/// the tool into the part; x = jaw closing). Empty (lo = hi) = no check.
template <typename Scalar>
struct ToolBox {
  Vector3<Scalar> lo = Vector3<Scalar>::Zero(), hi = Vector3<Scalar>::Zero();
  bool empty() const { return !((hi - lo).array() > Scalar(0)).all(); }
};

/// Two-finger jaws open to `stroke` (between the fingers' inner faces), fingers `finger_thickness`
/// along x and `finger_width` along y, reaching `finger_length` back from their tips at the grasp
/// point [m]. Throws std::invalid_argument naming the argument for a negative or non-finite size.
template <typename Scalar>
ToolBox<Scalar> jaw_tool_box(Scalar stroke, Scalar finger_thickness, Scalar finger_width, Scalar finger_length) {
  auto check = [](Scalar v, const char* name) {
    require(std::isfinite(v) && v >= Scalar(0), name, "must be finite and >= 0");
  };
  check(stroke, "stroke");
  check(finger_thickness, "finger_thickness");
  check(finger_width, "finger_width");
  check(finger_length, "finger_length");
  const Scalar hx = stroke / 2 + finger_thickness, hy = finger_width / 2;
  return {Vector3<Scalar>(-hx, -hy, -finger_length), Vector3<Scalar>(hx, hy, Scalar(0))};
}

/// A suction cup of `radius` with its stem, `length` back from the cup's face at the grasp point [m]
/// (the box around the cylinder). Throws std::invalid_argument naming the argument as above.
template <typename Scalar>
ToolBox<Scalar> cup_tool_box(Scalar radius, Scalar length) {
  require(std::isfinite(radius) && radius >= Scalar(0), "radius", "must be finite and >= 0");
  require(std::isfinite(length) && length >= Scalar(0), "length", "must be finite and >= 0");
  return {Vector3<Scalar>(-radius, -radius, -length), Vector3<Scalar>(radius, radius, Scalar(0))};
}

/// Whether `tool` at T_base_grasp stays above the bin's floor and at least `margin` inside its walls
/// wherever it is below the wall top. Exact for the box: the part of a convex box below the wall top
/// is the convex hull of its corners below it and of its edges' crossings of the top, so it lies inside
/// the (convex) inner rectangle iff those points do. True when the bin is unknown or the box empty.
template <typename Scalar>
bool tool_clear_of_bin(const ToolBox<Scalar>& tool, const Isometry3<Scalar>& T_base_grasp, const BinVolume<Scalar>& bin,
                       Scalar margin = 0) {
  if (!bin.known() || tool.empty()) return true;
  Vector3<Scalar> c[8];
  for (int i = 0; i < 8; ++i)
    c[i] = T_base_grasp * Vector3<Scalar>(i & 1 ? tool.hi.x() : tool.lo.x(), i & 2 ? tool.hi.y() : tool.lo.y(),
                                          i & 4 ? tool.hi.z() : tool.lo.z());
  const Scalar top = bin.floor_center.z() + bin.height;
  auto inside = [&](const Vector3<Scalar>& p) {
    const Vector3<Scalar> d = p - bin.floor_center;
    return std::abs(d.x()) <= bin.length / 2 - margin && std::abs(d.y()) <= bin.width / 2 - margin;
  };
  for (int i = 0; i < 8; ++i) {
    if (c[i].z() < bin.floor_center.z()) return false;
    if (c[i].z() <= top && !inside(c[i])) return false;
    for (int b = 1; b < 8; b <<= 1) {  // the edges from corner i to corners differing in one bit
      const int j = i ^ b;
      if (j < i || (c[i].z() <= top) == (c[j].z() <= top)) continue;
      const Scalar t = (top - c[i].z()) / (c[j].z() - c[i].z());
      if (!inside(c[i] + t * (c[j] - c[i]))) return false;
    }
  }
  return true;
}

}  // namespace binpick::cycle
