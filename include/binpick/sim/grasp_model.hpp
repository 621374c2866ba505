#pragma once
/// \file grasp_model.hpp
/// The simulated world judging a pick: it reads the scene's ground truth (unlike the estimator). A pick
/// at an estimated grasp pose succeeds when
///  1. the grasp lies within the gripper's tolerance of a true grasp of a part of the same type — the
///     part's registered grasps under every symmetry of the part (position, approach axis and, for
///     jaws, the closing axis up to its sign; jaws may also turn about their closing axis by up to
///     GraspModelSettings::jaw_turn_tolerance), and
///  2. the gripper (two-finger jaws: two boxes; vacuum cup: a cylinder; estimator_model.hpp) hits
///     neither the bin (floor and walls) nor any other part — the paper's failed picks came from
///     gripper–box interference (§IV.B). A neighbour is hit by jaws when a finger enters its mesh (an
///     exact box–triangle test, GraspModelSettings::jaws_against_mesh), by a cup when the cup reaches
///     into its collision spheres. The spheres contain the mesh and reach past it (up to about 2 mm
///     on the hex nut's flats, 0.9 mm on the coupler's sides): judged on them, a finger passing half a
///     millimetre beside a nut failed the grip.

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "binpick/core/errors.hpp"
#include "binpick/core/pose.hpp"
#include "binpick/sim/detail/estimator_model.hpp"
#include "binpick/sim/detail/estimator_symmetry.hpp"
#include "binpick/sim/parts.hpp"
#include "binpick/sim/scene.hpp"

namespace binpick::sim {

template <typename Scalar>
struct GraspModelSettings {
  Scalar position_tolerance = Scalar(0.003);   ///< grasp point within this of a true grasp point [m]
  Scalar angle_tolerance = Scalar(0.2);        ///< approach (and jaw closing) axes within this [rad] (≈ 11°)
  /// Jaws: how far [rad] their approach may turn about the true closing axis (≈ 29°); 0 = the approach
  /// axis within angle_tolerance, as for cups (the judge before this setting). Parallel jaws lie in
  /// two planes normal to the closing axis, and a turn about that axis leaves both planes where they
  /// are: the jaws clamp the same faces, only the fingers' patches turn on them. A turn about any
  /// other axis tilts the closing axis, which angle_tolerance bounds. Collisions are judged at the
  /// turned pose as at any other. Past about 30° a finger's 8 mm patch leaves a small part's face.
  Scalar jaw_turn_tolerance = Scalar(0.5);
  Scalar sample_spacing = Scalar(0.001);       ///< gripper shape sampled this finely against the bin [m]
  /// Jaws hit a neighbour when a finger enters its mesh; false: when a finger reaches into its
  /// collision spheres (the judge before the mesh test; up to 2 mm stricter). Cups: spheres either way.
  bool jaws_against_mesh = true;
  GripperGeometry<Scalar> gripper;             ///< the shapes (same defaults as the estimator's)
};

enum class PickStatus {
  success,
  no_matching_grasp,   ///< no part of that type has a true grasp within tolerance
  bin_collision,       ///< the gripper hits the floor or a wall
  part_collision,      ///< the gripper hits a neighbouring part
};

inline const char* to_string(PickStatus s) {
  switch (s) {
    case PickStatus::success: return "success";
    case PickStatus::no_matching_grasp: return "no_matching_grasp";
    case PickStatus::bin_collision: return "bin_collision";
    default: return "part_collision";
  }
}

template <typename Scalar>
struct PickOutcome {
  PickStatus status = PickStatus::no_matching_grasp;
  int part_index = -1;  ///< index into scene.parts() of the part the grasp matched, -1 if none
  int part_id = -1;     ///< its stable id (Scene::remove_part takes it)
  Scalar position_error = std::numeric_limits<Scalar>::infinity();  ///< to the matched true grasp [m]
  Scalar angle_error = std::numeric_limits<Scalar>::infinity();     ///< approach axis error [rad]
  Scalar closing_error = 0;  ///< jaw closing axis error (two-finger) [rad]
  /// Jaws: the turn about the true closing axis between the approaches, left once the closing axes
  /// are aligned [rad]; a grip held with angle_error above angle_tolerance was held by that turn.
  /// 0 unless approach_by_turn (as is nearest_jaw_turn once a part of the type lies near).
  Scalar jaw_turn = 0;
  /// When no grasp matched: the errors to the nearest true grasp of any part of the type regardless of
  /// the tolerances (diagnostics of why a pose missed; infinite when the bin holds none nearby).
  Scalar nearest_position_error = std::numeric_limits<Scalar>::infinity();  ///< [m]
  Scalar nearest_angle_error = std::numeric_limits<Scalar>::infinity();     ///< approach [rad]
  Scalar nearest_closing_error = std::numeric_limits<Scalar>::infinity();   ///< closing (two-finger) [rad]
  Scalar nearest_jaw_turn = std::numeric_limits<Scalar>::infinity();        ///< turn about the closing axis [rad]
  /// The approach was judged by the turn about the closing axis (jaws, jaw_turn_tolerance > 0), not
  /// by the approach axis' angle.
  bool approach_by_turn = false;
  /// The estimated grasp point minus the nearest true grasp point, base frame [m] (zero when no part
  /// of the type lies near; nearest_position_error is its norm otherwise). Averaged over many picks it
  /// shows an estimator's systematic error, e.g. a sensor's edge fattening pulling fits to one side.
  Vector3<Scalar> nearest_offset = Vector3<Scalar>::Zero();
  /// With status part_collision: whether the gripper overlaps the neighbour's mesh (jaws: an exact
  /// box–triangle test), not only the spheres that contain it. Cups: always true (not tested). Always
  /// true for jaws with jaws_against_mesh.
  bool part_collision_in_mesh = false;
  /// With jaws_against_mesh: the fingers reached into a neighbour's spheres but entered no mesh (a
  /// grazing pass, no collision; the judge on spheres would have failed the grip).
  bool grazed_spheres_only = false;
  bool success() const { return status == PickStatus::success; }
};

/// The widest opening among a part's registered grasps [m]: what a two-finger gripper that opens to
/// one stroke for every pick of the part must open to (the simulated cell's gripper does).
template <typename Scalar>
Scalar widest_opening(const PartModel<Scalar>& model) {
  Scalar w = 0;
  for (const auto& g : model.grasps) w = std::max(w, g.opening);
  return w;
}

/// Calls f(T_base_grasp) for every true grasp of a part of `model` lying at T_base_part: each
/// registered grasp under each of `symmetries` (detail::symmetry_rotations of the part's symmetry,
/// computed once by the caller; they fix the part origin). What evaluate_pick matches a pick against.
template <typename Scalar, typename F>
void for_each_true_grasp(const PartModel<Scalar>& model, const std::vector<Matrix3<Scalar>>& symmetries,
                         const Isometry3<Scalar>& T_base_part, F&& f) {
  for (const Matrix3<Scalar>& S : symmetries) {
    Isometry3<Scalar> T_sym = Isometry3<Scalar>::Identity();
    T_sym.linear() = S;
    for (const auto& g : model.grasps) f(Isometry3<Scalar>(T_base_part * T_sym * g.T_part_grasp));
  }
}

namespace detail {

/// Whether the axis-aligned box [lo, hi] and the triangle (a, b, c) overlap: the separating-axis
/// test over the box's 3 face normals, the triangle's normal and the 9 edge cross products.
template <typename Scalar>
bool box_overlaps_triangle(const Vector3<Scalar>& lo, const Vector3<Scalar>& hi, const Vector3<Scalar>& a,
                           const Vector3<Scalar>& b, const Vector3<Scalar>& c) {
  using V = Vector3<Scalar>;
  const V centre = (lo + hi) / 2, half = (hi - lo) / 2;
  const V v[3] = {a - centre, b - centre, c - centre};
  const auto separated = [&](const V& axis) {
    const Scalar p0 = axis.dot(v[0]), p1 = axis.dot(v[1]), p2 = axis.dot(v[2]);
    const Scalar r = half.dot(axis.cwiseAbs());
    return std::min({p0, p1, p2}) > r || std::max({p0, p1, p2}) < -r;
  };
  for (int k = 0; k < 3; ++k)
    if (separated(V::Unit(k))) return false;
  const V e[3] = {v[1] - v[0], v[2] - v[1], v[0] - v[2]};
  if (separated(e[0].cross(e[1]))) return false;
  for (int k = 0; k < 3; ++k)
    for (int j = 0; j < 3; ++j)
      if (separated(V::Unit(k).cross(e[j]))) return false;
  return true;
}

}  // namespace detail

/// Whether a finger of jaws at T_grasp_base (the inverse of the grasp pose) with `opening` enters
/// the mesh of scene.parts()[index] (exact; the part's bounding sphere first).
template <typename Scalar>
bool jaws_enter_part_mesh(const Scene<Scalar>& scene, std::size_t index, const Isometry3<Scalar>& T_grasp_base,
                          const GripperGeometry<Scalar>& gripper, Scalar opening) {
  const auto boxes = detail::finger_boxes(gripper, opening);
  Scalar reach = 0;  // of the fingers from the grasp point
  for (const auto& b : boxes) reach = std::max(reach, b.lo.cwiseAbs().cwiseMax(b.hi.cwiseAbs()).norm());
  const auto& part = scene.parts().at(index);
  const auto& model = scene.model(part.type);
  const Isometry3<Scalar> T = T_grasp_base * part.T_base_part;
  if (T.translation().norm() > reach + model.bounding_radius) return false;
  for (const auto& t : model.mesh.triangles) {
    const Vector3<Scalar> a = T * model.mesh.vertices[std::size_t(t[0])], b = T * model.mesh.vertices[std::size_t(t[1])],
                          c = T * model.mesh.vertices[std::size_t(t[2])];
    for (const auto& box : boxes)
      if (detail::box_overlaps_triangle(box.lo, box.hi, a, b, c)) return true;
  }
  return false;
}

/// Whether a finger enters the mesh of any part of `scene` other than parts()[skip].
template <typename Scalar>
bool jaws_enter_mesh(const Scene<Scalar>& scene, int skip, const Isometry3<Scalar>& T_grasp_base,
                     const GripperGeometry<Scalar>& gripper, Scalar opening) {
  for (std::size_t i = 0; i < scene.parts().size(); ++i)
    if (int(i) != skip && jaws_enter_part_mesh(scene, i, T_grasp_base, gripper, opening)) return true;
  return false;
}

/// Judges a pick of a `type` part at T_base_grasp (gripper `kind`, jaw `opening` [m]) in `scene`.
/// Throws std::invalid_argument naming `T_base_grasp` for an invalid pose.
template <typename Scalar>
PickOutcome<Scalar> evaluate_pick(const Scene<Scalar>& scene, PartType type, const Isometry3<Scalar>& T_base_grasp,
                                  cycle::GripperKind kind, Scalar opening, const GraspModelSettings<Scalar>& settings = {}) {
  require_valid_pose(T_base_grasp, "T_base_grasp");
  PickOutcome<Scalar> out;
  const PartModel<Scalar>& model = scene.model(type);
  const auto syms = detail::symmetry_rotations<Scalar>(detail::part_symmetry(type), 360);
  const Vector3<Scalar> a_est = T_base_grasp.linear().col(2), x_est = T_base_grasp.linear().col(0);
  const bool jaws = kind == cycle::GripperKind::two_finger;
  const bool turn_free = jaws && settings.jaw_turn_tolerance > Scalar(0);
  out.approach_by_turn = turn_free;
  // 1. The nearest matching true grasp.
  Scalar best = std::numeric_limits<Scalar>::infinity(), nearest = best;
  for (std::size_t i = 0; i < scene.parts().size(); ++i) {
    const auto& part = scene.parts()[i];
    if (part.type != type) continue;
    if ((part.T_base_part.translation() - T_base_grasp.translation()).norm() > model.bounding_radius + settings.position_tolerance)
      continue;
    for_each_true_grasp(model, syms, part.T_base_part, [&](const Isometry3<Scalar>& T_true) {
      const Scalar dp = (T_true.translation() - T_base_grasp.translation()).norm();
      const Scalar da = std::acos(std::clamp(T_true.linear().col(2).dot(a_est), Scalar(-1), Scalar(1)));
      // Jaws are symmetric: x and −x close alike.
      const Vector3<Scalar> x_true = T_true.linear().col(0);
      const Scalar dx = jaws ? std::acos(std::clamp(std::abs(x_true.dot(x_est)), Scalar(0), Scalar(1))) : Scalar(0);
      // What is left between the approaches once the closing axes are aligned: a turn about x_true.
      Scalar turn = 0;
      if (turn_free) {
        const Vector3<Scalar> x_near = x_true.dot(x_est) < Scalar(0) ? Vector3<Scalar>(-x_est) : x_est;
        const Vector3<Scalar> a_aligned = Eigen::Quaternion<Scalar>::FromTwoVectors(x_near, x_true) * a_est;
        turn = std::acos(std::clamp(a_aligned.dot(T_true.linear().col(2)), Scalar(-1), Scalar(1)));
      }
      const bool approach_ok = turn_free ? turn <= settings.jaw_turn_tolerance : da <= settings.angle_tolerance;
      const Scalar near_cost = dp / settings.position_tolerance + (da + dx) / settings.angle_tolerance;
      if (near_cost < nearest) {
        nearest = near_cost;
        out.nearest_position_error = dp;
        out.nearest_angle_error = da;
        out.nearest_closing_error = dx;
        out.nearest_jaw_turn = turn;
        out.nearest_offset = T_base_grasp.translation() - T_true.translation();
      }
      if (dp > settings.position_tolerance || !approach_ok || dx > settings.angle_tolerance) return;
      const Scalar cost = dp / settings.position_tolerance + da / settings.angle_tolerance;
      if (cost < best) {
        best = cost;
        out.part_index = int(i);
        out.part_id = part.id;
        out.position_error = dp;
        out.angle_error = da;
        out.closing_error = dx;
        out.jaw_turn = turn;
      }
    });
  }
  if (out.part_index < 0) return out;

  // 2. Collisions at the estimated grasp pose: bin boxes by samples, neighbours' spheres exactly.
  const auto& bin = scene.bin();
  const Scalar L = bin.length / 2, W = bin.width / 2;
  for (const Vector3<Scalar>& q : detail::gripper_samples(settings.gripper, kind, opening, settings.sample_spacing)) {
    const Vector3<Scalar> p = T_base_grasp * q;
    const bool below_floor = p.z() < Scalar(0);
    // The four walls (scene.hpp bin_mesh): the frame between the inner and outer rectangles.
    const Scalar ax = std::abs(p.x()), ay = std::abs(p.y()), t = bin.wall_thickness;
    const bool in_wall = p.z() <= bin.wall_height && ax <= L + t && ay <= W + t && (ax >= L || ay >= W);
    if (below_floor || in_wall) {
      out.status = PickStatus::bin_collision;
      return out;
    }
  }
  const Isometry3<Scalar> T_grasp_base = T_base_grasp.inverse(Eigen::Isometry);
  const auto& gg = settings.gripper;
  const auto fingers = detail::finger_boxes(gg, opening);  // once, not per sphere
  for (std::size_t i = 0; i < scene.parts().size(); ++i) {
    if (int(i) == out.part_index) continue;
    for (const auto& s : scene.world_spheres(scene.parts()[i])) {
      const Vector3<Scalar> c = T_grasp_base * s.centre;
      bool hit = false;
      if (jaws) {
        for (const auto& b : fingers) {
          const Vector3<Scalar> q = c.cwiseMax(b.lo).cwiseMin(b.hi);
          hit = hit || (q - c).squaredNorm() < s.radius * s.radius;
        }
      } else {
        const Scalar dz = c.z() - std::clamp(c.z(), -gg.cup_length, Scalar(0));
        const Scalar dr = std::max(c.template head<2>().norm() - gg.cup_radius, Scalar(0));
        hit = dz * dz + dr * dr < s.radius * s.radius;
      }
      if (!hit) continue;
      // The spheres contain the mesh: only a part whose spheres the fingers reach can be entered.
      const bool judged_on_spheres = !jaws || !settings.jaws_against_mesh;
      const bool in_mesh = !jaws || (judged_on_spheres ? jaws_enter_mesh(scene, out.part_index, T_grasp_base, gg, opening)
                                                       : jaws_enter_part_mesh(scene, i, T_grasp_base, gg, opening));
      if (judged_on_spheres || in_mesh) {
        out.status = PickStatus::part_collision;
        out.part_collision_in_mesh = in_mesh;
        out.grazed_spheres_only = false;
        return out;
      }
      out.grazed_spheres_only = true;
      break;  // this part is not entered: its other spheres need no test
    }
  }
  out.status = PickStatus::success;
  return out;
}

/// The part a closed tool pressing down at `tip` (base frame; a vertical cylinder of `radius` [m] above
/// the tip) rests on: of the parts with a collision sphere within the cylinder's reach and reaching
/// above the tip, the one reaching highest (the tool presses on its top). Its id, or -1 when the tool
/// presses on none. What a drag moves (SimGripper::prepare_drag).
template <typename Scalar>
int pressed_part(const Scene<Scalar>& scene, const Vector3<Scalar>& tip, Scalar radius) {
  int id = -1;
  Scalar highest = tip.z();
  for (std::size_t i = 0; i < scene.parts().size(); ++i)
    for (const auto& s : scene.world_spheres(scene.parts()[i])) {
      const Scalar reach = s.radius + radius, top = s.centre.z() + s.radius;
      if ((s.centre - tip).template head<2>().squaredNorm() >= reach * reach || !(top > highest)) continue;
      highest = top;
      id = scene.parts()[i].id;
    }
  return id;
}

}  // namespace binpick::sim
