#pragma once
/// \file scene.hpp
/// A bin of randomly piled parts (paper §IV.B: 20 parts in a 50 × 25 cm box). Parts are dropped one
/// by one and settle by a simple, seeded, deterministic procedure:
///  1. drop: from above, a part at a fixed orientation and (x, y) falls straight down until its
///     collision spheres touch the floor or a sphere of a part already in the bin — the rest height
///     is the largest of the per-sphere contact heights, so the result never interpenetrates;
///  2. settle: the part is tilted about horizontal axes through its centre in steps that halve, a
///     tilt being kept when the dropped centre ends lower (a descent on the height of the centre of
///     mass), so parts lie flat on the floor or lean on each other instead of balancing on a point or
///     an edge.
/// Removing a part re-drops, in placement order, every part placed after it (a part only ever rests
/// on parts placed before it), so the parts that rested on it settle.
///
/// Base frame: origin at the centre of the bin floor, x along the 50 cm side, z up. Metres.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <vector>

#include "binpick/core/errors.hpp"
#include "binpick/core/pose.hpp"
#include "binpick/sim/detail/random.hpp"
#include "binpick/sim/mesh.hpp"
#include "binpick/sim/parts.hpp"

namespace binpick::sim {

template <typename Scalar>
struct BinGeometry {
  Scalar length = Scalar(0.50);       ///< inner size along x [m]
  Scalar width = Scalar(0.25);        ///< inner size along y [m]
  Scalar wall_height = Scalar(0.10);  ///< [m]
  Scalar wall_thickness = Scalar(0.01);  ///< [m]
};

template <typename Scalar>
struct SceneSettings {
  PartType part_type = PartType::small_screw;  ///< one type per bin, as in the paper's tests
  int num_parts = 20;                           ///< parts dropped into the bin
  Scalar pile_spread = Scalar(0.05);            ///< std. deviation of the drop (x, y) about the bin centre [m]
  Scalar max_initial_tilt = Scalar(0.6);        ///< random tilt off a resting orientation before settling [rad]
  int settle_iterations = 24;                   ///< tilt trials per part (step halves on no improvement)
  BinGeometry<Scalar> bin;
};

template <typename Scalar>
struct PlacedPart {
  int id = 0;                                         ///< stable id (placement number)
  PartType type = PartType::small_screw;
  Isometry3<Scalar> T_base_part = Isometry3<Scalar>::Identity();
};

template <typename Scalar>
class Scene {
 public:
  using Vec3 = Vector3<Scalar>;
  using Mat3 = Matrix3<Scalar>;

  /// An empty bin. Throws std::invalid_argument naming `bin` for a non-positive size.
  explicit Scene(const BinGeometry<Scalar>& bin = {}) : bin_(bin) {
    require(bin.length > 0 && bin.width > 0 && bin.wall_height > 0 && bin.wall_thickness > 0, "bin",
            "sizes must be > 0");
    for (int k = 0; k < kNumPartTypes; ++k) models_[std::size_t(k)] = std::make_shared<const PartModel<Scalar>>(make_part<Scalar>(PartType(k)));
  }

  /// A bin with settings.num_parts parts of settings.part_type, reproducible for a seed. Throws
  /// std::invalid_argument naming the setting for a negative count, a negative spread or an unknown
  /// part type.
  static Scene generate(const SceneSettings<Scalar>& settings, std::uint64_t seed) {
    require(settings.num_parts >= 0, "num_parts", "must be >= 0");
    require(std::isfinite(settings.pile_spread) && settings.pile_spread >= 0, "pile_spread", "must be finite and >= 0");
    require(settings.settle_iterations >= 0, "settle_iterations", "must be >= 0");
    Scene scene(settings.bin);
    scene.settle_iterations_ = settings.settle_iterations;
    const PartModel<Scalar>& model = scene.model(settings.part_type);
    detail::Rng rng(detail::hash_keys(seed, 0x5ce11e5ULL));
    for (int i = 0; i < settings.num_parts; ++i) {
      const Mat3 rest = model.rest_orientations[std::size_t(rng.next() % model.rest_orientations.size())];
      const Scalar yaw = Scalar(rng.uniform(-M_PI, M_PI));
      const Scalar tilt_dir = Scalar(rng.uniform(-M_PI, M_PI));
      const Scalar tilt = Scalar(rng.uniform(0, 1)) * settings.max_initial_tilt;
      const Mat3 R = Eigen::AngleAxis<Scalar>(tilt, Vec3(std::cos(tilt_dir), std::sin(tilt_dir), 0)).toRotationMatrix() *
                     Eigen::AngleAxis<Scalar>(yaw, Vec3::UnitZ()).toRotationMatrix() * rest;
      // One draw per declarator: the order of a call's arguments is unspecified (GCC and Clang
      // differ), and a seed must give the same pile on every compiler.
      const Scalar ny = Scalar(rng.normal()), nx = Scalar(rng.normal());
      const Vector2<Scalar> xy(nx * settings.pile_spread, ny * settings.pile_spread);
      scene.add_part(settings.part_type, R, xy);
    }
    return scene;
  }

  /// Drops a part with orientation R_base_part at (x, y) [m] (clamped into the bin) and lets it
  /// settle; returns its id. Throws std::invalid_argument naming `type` or `R_base_part`.
  int add_part(PartType type, const Mat3& R_base_part, const Vector2<Scalar>& xy) {
    require_all_finite(R_base_part, "R_base_part");
    require_all_finite(xy, "xy");
    Isometry3<Scalar> T = Isometry3<Scalar>::Identity();
    T.linear() = Eigen::Quaternion<Scalar>(R_base_part).normalized().toRotationMatrix();
    T.translation() = Vec3(xy.x(), xy.y(), 0);
    require_valid_pose(T, "R_base_part");
    model(type);  // validates the type
    PlacedPart<Scalar> p;
    p.id = next_id_++;
    p.type = type;
    p.T_base_part = T;
    place(p, parts_.size());
    parts_.push_back(p);
    world_.push_back(world_spheres(parts_.back()));
    ++revision_;
    return p.id;
  }

  /// Removes the part with `id` and lets the parts placed after it settle. Returns false when no part
  /// has that id.
  ///
  /// A part settles again when it drops, and also when it touched the removed part or one that moved:
  /// a part leaning on a neighbour with one end on the floor keeps its height when the neighbour goes
  /// (the floor contact sets it), and without a new settle it would stand leaning on nothing.
  bool remove_part(int id) {
    const std::size_t k = index_of(id);
    if (k == parts_.size()) return false;
    std::vector<CollisionSphere<Scalar>> gone = world_[k];  // where support may have been lost
    parts_.erase(parts_.begin() + std::ptrdiff_t(k));
    world_.erase(world_.begin() + std::ptrdiff_t(k));
    for (std::size_t j = k; j < parts_.size(); ++j) {
      const Isometry3<Scalar> T_before = parts_[j].T_base_part;
      const Scalar z = drop(parts_[j].type, T_before.linear(), xy_of(parts_[j]), j);
      parts_[j].T_base_part.translation().z() = z;
      if (z < T_before.translation().z() - Scalar(1e-6) || touches(world_[j], gone)) settle(parts_[j], j);
      if (!parts_[j].T_base_part.isApprox(T_before, Scalar(1e-6)))
        gone.insert(gone.end(), world_[j].begin(), world_[j].end());
      world_[j] = world_spheres(parts_[j]);
    }
    ++revision_;
    return true;
  }

  /// Moves the part with `id` by `delta` (x, y) [m] as a drag over the floor would: it is taken out
  /// (the parts on it settle), turned by `turn` (a rotation in the base frame; a part that tips over
  /// on the way), then dropped again at the new place (clamped into the bin) onto whatever lies there
  /// and settles. It keeps its id. Returns false when no part has that id. Throws
  /// std::invalid_argument naming `delta` when it is not finite, `turn` when it is not a rotation.
  bool move_part(int id, const Vector2<Scalar>& delta, const Mat3& turn = Mat3::Identity()) {
    require_all_finite(delta, "delta");
    Isometry3<Scalar> T_turn = Isometry3<Scalar>::Identity();
    T_turn.linear() = turn;
    require_valid_pose(T_turn, "turn");
    const std::size_t k = index_of(id);
    if (k == parts_.size()) return false;
    PlacedPart<Scalar> p = parts_[k];
    remove_part(id);
    p.T_base_part.linear() = turn * p.T_base_part.linear();
    p.T_base_part.translation().template head<2>() += delta;
    place(p, parts_.size());
    parts_.push_back(p);
    world_.push_back(world_spheres(parts_.back()));
    ++revision_;
    return true;
  }

  const std::vector<PlacedPart<Scalar>>& parts() const { return parts_; }
  const BinGeometry<Scalar>& bin() const { return bin_; }
  /// Increments on every change (renderers rebuild their acceleration structure on a new revision).
  std::uint64_t revision() const { return revision_; }

  /// The model of a part type (built once per scene, shared by copies). Throws std::invalid_argument
  /// naming `type` for an unknown type.
  const PartModel<Scalar>& model(PartType type) const {
    const int k = int(type);
    require(k >= 0 && k < kNumPartTypes, "type", "unknown part type");
    return *models_[std::size_t(k)];
  }

  /// Collision spheres of the i-th part in the base frame.
  std::vector<CollisionSphere<Scalar>> world_spheres(const PlacedPart<Scalar>& p) const {
    std::vector<CollisionSphere<Scalar>> out;
    for (const auto& s : model(p.type).spheres) out.push_back({p.T_base_part * s.centre, s.radius});
    return out;
  }

  /// Part mesh in the base frame.
  TriangleMesh<Scalar> part_mesh_in_base(std::size_t i) const {
    TriangleMesh<Scalar> m;
    m.append(model(parts_.at(i).type).mesh, parts_.at(i).T_base_part);
    return m;
  }

  /// The bin (floor and four walls as closed boxes) and the table it stands on, in the base frame.
  TriangleMesh<Scalar> bin_mesh() const {
    TriangleMesh<Scalar> m;
    const Scalar L = bin_.length / 2, W = bin_.width / 2, H = bin_.wall_height, t = bin_.wall_thickness;
    add_box(m, Vec3(-L - t, -W - t, -t), Vec3(L + t, W + t, 0));      // floor
    add_box(m, Vec3(-L - t, -W - t, 0), Vec3(-L, W + t, H));         // walls
    add_box(m, Vec3(L, -W - t, 0), Vec3(L + t, W + t, H));
    add_box(m, Vec3(-L, -W - t, 0), Vec3(L, -W, H));
    add_box(m, Vec3(-L, W, 0), Vec3(L, W + t, H));
    return m;
  }
  TriangleMesh<Scalar> table_mesh() const {
    TriangleMesh<Scalar> m;
    const Scalar z = -bin_.wall_thickness, r = Scalar(1.0);
    m.add_flat(Vec3(-r, -r, z), Vec3(r, -r, z), Vec3(r, r, z));
    m.add_flat(Vec3(-r, -r, z), Vec3(r, r, z), Vec3(-r, r, z));
    return m;
  }

 private:
  static void add_box(TriangleMesh<Scalar>& m, const Vec3& lo, const Vec3& hi) {
    const Vec3 c[8] = {Vec3(lo.x(), lo.y(), lo.z()), Vec3(hi.x(), lo.y(), lo.z()), Vec3(hi.x(), hi.y(), lo.z()),
                       Vec3(lo.x(), hi.y(), lo.z()), Vec3(lo.x(), lo.y(), hi.z()), Vec3(hi.x(), lo.y(), hi.z()),
                       Vec3(hi.x(), hi.y(), hi.z()), Vec3(lo.x(), hi.y(), hi.z())};
    const int f[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4}, {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};
    for (const auto& q : f) {
      m.add_flat(c[q[0]], c[q[1]], c[q[2]]);
      m.add_flat(c[q[0]], c[q[2]], c[q[3]]);
    }
  }

  static Vector2<Scalar> xy_of(const PlacedPart<Scalar>& p) { return p.T_base_part.translation().template head<2>(); }

  /// Clamps (x, y) so every sphere of the part at orientation R stays inside the walls.
  Vector2<Scalar> clamp_xy(const PartModel<Scalar>& m, const Mat3& R, Vector2<Scalar> xy) const {
    const Scalar half[2] = {bin_.length / 2, bin_.width / 2};
    for (int a = 0; a < 2; ++a) {
      const auto [lo, hi] = extent_along(m.spheres, Vec3(R.row(a).transpose()));  // (R * centre)[a]
      const Scalar mn = -half[a] - lo, mx = half[a] - hi;
      xy[a] = mn <= mx ? std::clamp(xy[a], mn, mx) : (mn + mx) / 2;
    }
    return xy;
  }

  /// Rest height of the part origin dropped at (R, xy) onto the floor and parts [0, count).
  Scalar drop(PartType type, const Mat3& R, const Vector2<Scalar>& xy, std::size_t count) const {
    const PartModel<Scalar>& m = model(type);
    Scalar z = Scalar(-1e9);
    std::vector<Vec3> local;
    local.reserve(m.spheres.size());
    for (const auto& s : m.spheres) {
      local.push_back(R * s.centre);
      z = std::max(z, s.radius - local.back().z());  // floor at z = 0
    }
    for (std::size_t j = 0; j < count; ++j) {
      const Vector2<Scalar> d = xy_of(parts_[j]) - xy;
      const Scalar reach = m.bounding_radius + model(parts_[j].type).bounding_radius;
      if (d.squaredNorm() > reach * reach) continue;  // broad phase: bounding cylinders apart
      for (std::size_t i = 0; i < local.size(); ++i) {
        const Scalar xi = xy.x() + local[i].x(), yi = xy.y() + local[i].y(), ri = m.spheres[i].radius;
        for (const auto& w : world_[j]) {
          const Scalar rr = ri + w.radius, dx = xi - w.centre.x(), dy = yi - w.centre.y();
          const Scalar dh2 = dx * dx + dy * dy;
          if (dh2 >= rr * rr) continue;
          z = std::max(z, w.centre.z() - local[i].z() + std::sqrt(rr * rr - dh2));
        }
      }
    }
    return z;
  }

  /// The index of the part with `id`, parts_.size() when there is none.
  std::size_t index_of(int id) const {
    std::size_t k = 0;
    while (k < parts_.size() && parts_[k].id != id) ++k;
    return k;
  }

  /// Whether two sets of spheres touch (within 0.1 mm: resting contact is exact up to rounding).
  static bool touches(const std::vector<CollisionSphere<Scalar>>& a, const std::vector<CollisionSphere<Scalar>>& b) {
    for (const auto& s : a)
      for (const auto& t : b) {
        const Scalar r = s.radius + t.radius + Scalar(1e-4);
        if ((s.centre - t.centre).squaredNorm() < r * r) return true;
      }
    return false;
  }

  /// Drops p at its orientation and (clamped) xy as the part number `index`, then settles it.
  void place(PlacedPart<Scalar>& p, std::size_t index) const {
    const PartModel<Scalar>& m = model(p.type);
    const Vector2<Scalar> xy = clamp_xy(m, p.T_base_part.linear(), xy_of(p));
    p.T_base_part.translation() = Vec3(xy.x(), xy.y(), drop(p.type, p.T_base_part.linear(), xy, index));
    settle(p, index);
  }

  /// Descent on the centre height over tilts about horizontal axes (see file comment): the base x and
  /// y axes, and the horizontal parts of the part's own axes and their horizontal normals. A part on
  /// an edge or a rim can only tip about that edge (or the rim's tangent), which runs along a part
  /// axis or across one; a tilt about any other axis lifts it onto a corner, so with the base axes
  /// alone the descent stopped with the part balancing on the edge.
  void settle(PlacedPart<Scalar>& p, std::size_t index) const {
    const PartModel<Scalar>& m = model(p.type);
    Scalar step = Scalar(0.25);
    Mat3 R = p.T_base_part.linear();
    Vector2<Scalar> xy = xy_of(p);
    Scalar z = p.T_base_part.translation().z();
    for (int it = 0; it < settle_iterations_ && step > Scalar(0.01); ++it) {
      Scalar best_z = z - Scalar(1e-6);
      Mat3 best_R = R;
      Vector2<Scalar> best_xy = xy;
      std::array<Vec3, 8> axes{Vec3::UnitX(), Vec3::UnitY()};
      int num_axes = 2;
      for (int a = 0; a < 3; ++a) {
        const Vec3 h(R(0, a), R(1, a), 0);
        if (!(h.norm() > Scalar(0.1))) continue;  // (nearly) vertical: its horizontal part is noise
        axes[std::size_t(num_axes++)] = h.normalized();
        axes[std::size_t(num_axes++)] = Vec3(-h.y(), h.x(), 0).normalized();
      }
      for (int c = 0; c < 2 * num_axes; ++c) {
        const Vec3& axis = axes[std::size_t(c / 2)];
        const Mat3 Rc = (Eigen::AngleAxis<Scalar>(c % 2 ? -step : step, axis).toRotationMatrix() * R);
        const Vector2<Scalar> xyc = clamp_xy(m, Rc, xy);
        const Scalar zc = drop(p.type, Rc, xyc, index);
        if (zc < best_z) {
          best_z = zc;
          best_R = Rc;
          best_xy = xyc;
        }
      }
      if (best_z < z - Scalar(1e-6)) {
        R = best_R;
        xy = best_xy;
        z = best_z;
      } else {
        step /= 2;
      }
    }
    // Re-orthonormalize (many small rotations) and re-drop so the final pose is exactly resting.
    R = Eigen::Quaternion<Scalar>(R).normalized().toRotationMatrix();
    xy = clamp_xy(m, R, xy);
    p.T_base_part.linear() = R;
    p.T_base_part.translation() = Vec3(xy.x(), xy.y(), drop(p.type, R, xy, index));
  }

  BinGeometry<Scalar> bin_;
  std::vector<PlacedPart<Scalar>> parts_;
  std::vector<std::vector<CollisionSphere<Scalar>>> world_;  // world spheres per part (cache)
  std::array<std::shared_ptr<const PartModel<Scalar>>, kNumPartTypes> models_;
  int next_id_ = 0;
  int settle_iterations_ = 24;
  std::uint64_t revision_ = 0;
};

}  // namespace binpick::sim
