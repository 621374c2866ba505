#pragma once
// The simulated picking cell used by binpick_sim, binpick_calibrate and the cycle tests: a piled bin,
// the fake robot, the fake stereo sensor on its hand, the simulated clock, the reference estimator
// (which sees only fused depth) and a simulated gripper that judges a grasp against the true scene.
// Ground truth is used here for two things only: rendering and judging whether a grip holds a part
// (as the real world does) — it never reaches the estimator or the pipeline. The drivers are wrapped
// for fault injection (faulty_drivers.hpp); unarmed, the wrappers pass every call through.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <memory>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "binpick/cycle/pipeline.hpp"
#include "binpick/sim.hpp"
#include "binpick/sim/grasp_model.hpp"
#include "binpick/sim/reference_estimator.hpp"
#include "sim_instances.hpp"
#include "faulty_drivers.hpp"

namespace binpick::simcell {

/// Table III "Sensing Parameters" of a part type: n views, interval t [ms], speed v [%].
struct Params {
  int n = 4;
  double t_ms = 30;
  double v_percent = 80;
};

/// Table III of the paper, the defaults until binpick_calibrate has written its own.
inline Params table3(sim::PartType p) {
  switch (p) {
    case sim::PartType::small_screw: return {4, 30, 70};
    case sim::PartType::lan_connector: return {4, 30, 80};
    case sim::PartType::mirror_nut: return {3, 60, 60};
    case sim::PartType::pencil_coupler: return {4, 30, 80};
    case sim::PartType::circle_nut: return {4, 30, 80};
  }
  return {};
}

/// Part types from an option value: "all", or names separated by commas (sim::part_type_from_name).
/// Throws std::invalid_argument for an unknown name or a list naming none.
inline std::vector<sim::PartType> part_types(const std::string& list) {
  std::vector<sim::PartType> out;
  if (list == "all") {
    for (int k = 0; k < sim::kNumPartTypes; ++k) out.push_back(sim::PartType(k));
    return out;
  }
  std::stringstream ss(list);
  std::string name;
  while (std::getline(ss, name, ','))
    if (!name.empty()) out.push_back(sim::part_type_from_name(name));
  if (out.empty()) throw std::invalid_argument("the part type list '" + list + "' names no part type");
  return out;
}

/// Grips by the simulated world's verdict (sim/grasp_model.hpp): what limits a complete rate. A grip
/// that matched no true grasp missed one or more of the tolerances, counted each; the nearest true
/// grasp's errors decide which. With record_offset, also the offsets of the grasp points from their
/// nearest true ones in the camera frame of the view the pose was estimated in (x along the image
/// rows, y down the columns, z away from the camera): their median is the estimator's systematic error.
struct GripLedger {
  static constexpr int kVerdicts = 4;  // the values of sim::PickStatus
  enum Miss { position, approach, closing, kMisses };
  int verdicts[kVerdicts] = {};  // grips per sim::PickStatus (success: held)
  int missed[kMisses] = {};
  int nothing_recognized = 0;  // cycles without a grasp to try (the next one searches)
  int part_collision_in_mesh = 0;  // part collisions that also enter the neighbour's mesh (grasp_model.hpp)
  int grazed_spheres_only = 0;     // grips judged on the mesh whose fingers reached only a neighbour's spheres
  int held_by_jaw_turn = 0;        // grips held with the approach beyond angle_tolerance, turned about the closing axis
  std::vector<double> offset_mm[3];  // per camera axis, grips within 2 x the position tolerance
  int of(sim::PickStatus s) const { return verdicts[int(s)]; }
  int held() const { return of(sim::PickStatus::success); }
  int tried() const { return std::accumulate(std::begin(verdicts), std::end(verdicts), 0); }
  /// One judged grip, against the judge's tolerances.
  template <typename Scalar>
  void record(const sim::PickOutcome<Scalar>& oc, const sim::GraspModelSettings<Scalar>& tol) {
    ++verdicts[int(oc.status)];
    part_collision_in_mesh += oc.status == sim::PickStatus::part_collision && oc.part_collision_in_mesh;
    grazed_spheres_only += oc.grazed_spheres_only;
    held_by_jaw_turn += oc.status == sim::PickStatus::success && oc.angle_error > tol.angle_tolerance;
    if (oc.status != sim::PickStatus::no_matching_grasp) return;
    missed[position] += !(oc.nearest_position_error <= tol.position_tolerance);
    // Jaws free to turn about their closing axis miss on the approach only beyond that turn.
    missed[approach] += oc.approach_by_turn ? !(oc.nearest_jaw_turn <= tol.jaw_turn_tolerance)
                            : !(oc.nearest_angle_error <= tol.angle_tolerance);
    missed[closing] += !(oc.nearest_closing_error <= tol.angle_tolerance);
  }
  /// The offset of one grip (`T_base_camera`: the view its pose was estimated in), when within twice
  /// the position tolerance of a true grasp (a gross misrecognition says nothing about a bias).
  template <typename Scalar>
  void record_offset(const sim::PickOutcome<Scalar>& oc, const sim::GraspModelSettings<Scalar>& tol,
                     const Isometry3<Scalar>& T_base_camera) {
    if (!(oc.nearest_position_error <= 2 * tol.position_tolerance)) return;
    const Vector3<Scalar> o = T_base_camera.linear().transpose() * oc.nearest_offset;
    for (int a = 0; a < 3; ++a) offset_mm[a].push_back(1e3 * double(o[a]));
  }
  /// Median offset along camera axis a [mm], 0 without offsets.
  double offset_median_mm(int a) const {
    std::vector<double> v = offset_mm[a];
    if (v.empty()) return 0;
    const auto mid = v.begin() + std::ptrdiff_t(v.size() / 2);
    std::nth_element(v.begin(), mid, v.end());
    return v.size() % 2 == 1 ? *mid : 0.5 * (*mid + *std::max_element(v.begin(), mid));
  }
  void merge(const GripLedger& o) {
    for (int a = 0; a < 3; ++a) offset_mm[a].insert(offset_mm[a].end(), o.offset_mm[a].begin(), o.offset_mm[a].end());
    for (int k = 0; k < kVerdicts; ++k) verdicts[k] += o.verdicts[k];
    for (int k = 0; k < kMisses; ++k) missed[k] += o.missed[k];
    nothing_recognized += o.nothing_recognized;
    part_collision_in_mesh += o.part_collision_in_mesh;
    grazed_spheres_only += o.grazed_spheres_only;
    held_by_jaw_turn += o.held_by_jaw_turn;
  }
};

/// The simulated gripper: a grip is judged by the simulated world (sim/grasp_model.hpp: a true grasp
/// of a part within tolerance, and no collision of the gripper with the bin or other parts); a held
/// part is removed from the bin (the parts on it settle).
template <typename Scalar_>
class SimGripper {
 public:
  using Scalar = Scalar_;
  SimGripper(sim::Scene<Scalar>& scene, sim::PartType type, const sim::GraspModelSettings<Scalar>& s = {})
      : scene_(&scene), type_(type), s_(s), opening_(sim::widest_opening(scene.model(type))) {}

  bool grip(const Isometry3<Scalar>& T_base_flange, cycle::GripperKind kind) {
    const auto outcome = sim::evaluate_pick(*scene_, type_, T_base_flange, kind, opening_, s_);
    last_ = outcome.status;
    last_outcome_ = outcome;
    if (!outcome.success()) return false;
    scene_->remove_part(outcome.part_id);
    return true;
  }
  void release() {}
  /// A drag (gripper.hpp): the closed tool pressed at T_base_from and moved to T_base_to drags the
  /// part it presses on (sim::pressed_part; the tool's footprint is the closed jaws' or the cup's) over
  /// the floor by the move's horizontal part (Scene::move_part). Friction is not modelled: the part
  /// follows the tool. A part standing much taller than it is long along the move (a sleeve on end)
  /// is pushed at its top: it tips over in the move's direction (tip_over). Counts the parts moved.
  bool prepare_drag(const Isometry3<Scalar>& T_base_from, const Isometry3<Scalar>& T_base_to) {
    const auto& g = s_.gripper;
    const Scalar radius = std::max({g.finger_clearance + g.finger_thickness, g.finger_width / 2, g.cup_radius});
    const int id = sim::pressed_part(*scene_, Vector3<Scalar>(T_base_from.translation()), radius);
    if (id >= 0) {
      const Vector2<Scalar> delta = (T_base_to.translation() - T_base_from.translation()).template head<2>();
      scene_->move_part(id, delta, tip_over(id, delta));
      ++dragged_;
    }
    return true;
  }
  /// Parts moved by drags so far.
  int dragged() const { return dragged_; }
  /// The judgement of the last grip (the cause column of a failed grasp).
  sim::PickStatus last_status() const { return last_; }
  /// The judge's tolerances.
  const sim::GraspModelSettings<Scalar>& settings() const { return s_; }
  /// The whole judgement of the last grip (errors to the nearest true grasp, for diagnostics).
  const sim::PickOutcome<Scalar>& last_outcome() const { return last_outcome_; }

 private:
  /// The turn of a dragged part: a quarter turn toward `delta` about the horizontal axis across it
  /// when the part's collision spheres reach more than 1.5 times higher than they extend along
  /// `delta` (a sleeve on end: 3 times; no part type lying in a rest orientation tips: test_cycle's
  /// SimGripper test); else none.
  Matrix3<Scalar> tip_over(int id, const Vector2<Scalar>& delta) const {
    const Scalar len = delta.norm();
    if (!(len > Scalar(1e-6))) return Matrix3<Scalar>::Identity();
    const Vector3<Scalar> u(delta.x() / len, delta.y() / len, 0);
    const auto& parts = scene_->parts();
    const auto it = std::find_if(parts.begin(), parts.end(), [&](const auto& p) { return p.id == id; });
    if (it == parts.end()) return Matrix3<Scalar>::Identity();
    const auto spheres = scene_->world_spheres(*it);
    const auto [z0, z1] = sim::extent_along(spheres, Vector3<Scalar>(Vector3<Scalar>::UnitZ()));
    const auto [a0, a1] = sim::extent_along(spheres, u);
    if (!(z1 - z0 > Scalar(1.5) * (a1 - a0))) return Matrix3<Scalar>::Identity();
    return Eigen::AngleAxis<Scalar>(Scalar(M_PI / 2), Vector3<Scalar>::UnitZ().cross(u)).toRotationMatrix();
  }

  sim::Scene<Scalar>* scene_;
  sim::PartType type_;
  sim::GraspModelSettings<Scalar> s_;
  Scalar opening_ = 0;
  sim::PickStatus last_ = sim::PickStatus::success;
  sim::PickOutcome<Scalar> last_outcome_;
  int dragged_ = 0;
};

static_assert(cycle::is_gripper<SimGripper<float>>::value, "SimGripper models Gripper");

/// The pipeline of the cell, over the fault-injecting wrappers of the fake drivers.
using CellPipeline = cycle::PickingPipeline<FaultyRobot<float>, FaultySensor<float>,
                                            sim::ReferenceEstimator<float, PinholeCamera<float>>, sim::SimClock,
                                            SimGripper<float>>;

}  // namespace binpick::simcell

// Compiled once in sim_cell.cpp (see sim_instances.hpp).
extern template class binpick::simcell::SimGripper<float>;
extern template class binpick::cycle::PickingPipeline<
    binpick::simcell::FaultyRobot<float>, binpick::simcell::FaultySensor<float>,
    binpick::sim::ReferenceEstimator<float, binpick::PinholeCamera<float>>, binpick::sim::SimClock,
    binpick::simcell::SimGripper<float>>;

namespace binpick::simcell {

struct CellOptions {
  sim::PartType part = sim::PartType::small_screw;
  int parts = 20;
  std::uint64_t seed = 1;
  int width = 640, height = 512;
  int threads = 1;
  /// The sensor's vignetting (sim::MetalErrorSettings::vignetting_power; 0 = none, the default).
  float vignetting = 0;
  /// The judge's verdict on jaws beside a neighbour (sim::GraspModelSettings::jaws_against_mesh).
  bool jaws_against_mesh = true;
  /// How far jaws may turn about their closing axis (sim::GraspModelSettings::jaw_turn_tolerance).
  float jaw_turn_tolerance = sim::GraspModelSettings<float>{}.jaw_turn_tolerance;
};

/// One bin with its drivers and a pipeline over them.
struct Cell {
  using S = float;
  static constexpr S kWeakConfidence = 20;  ///< [%] the estimator's threshold in the cell
  using Camera = PinholeCamera<S>;
  using Robot = FaultyRobot<S>;
  using Sensor = FaultySensor<S>;
  using Pipeline = CellPipeline;
  sim::Scene<S> scene;
  int initial_parts = 0;
  sim::SimClock clock;
  std::unique_ptr<sim::FakeRobot<S>> fake_robot;
  std::unique_ptr<sim::FakeSensor<S>> fake_sensor;
  std::unique_ptr<Robot> robot;
  std::unique_ptr<Sensor> sensor;
  std::unique_ptr<sim::ReferenceEstimator<S, Camera>> estimator;
  std::unique_ptr<SimGripper<S>> gripper;
  std::unique_ptr<Pipeline> pipeline;

  Cell(const CellOptions& o, cycle::PipelineSettings<S> ps) {
    sim::SceneSettings<S> ss;
    ss.part_type = o.part;
    ss.num_parts = o.parts;
    scene = sim::Scene<S>::generate(ss, o.seed);
    initial_parts = int(scene.parts().size());
    sim::FakeRobotSettings<S> rs;
    rs.seed = o.seed;
    fake_robot = std::make_unique<sim::FakeRobot<S>>(clock, ps.T_base_drop, rs);
    sim::StereoSensorSettings<S> st;
    st.width = o.width;
    st.height = o.height;
    st.seed = o.seed;
    st.num_threads = o.threads;
    st.errors.vignetting_power = o.vignetting;
    fake_sensor = std::make_unique<sim::FakeSensor<S>>(scene, *fake_robot, clock, ps.T_flange_camera, st);
    robot = std::make_unique<Robot>(*fake_robot, clock);
    sensor = std::make_unique<Sensor>(*fake_sensor, *fake_robot);
    sim::ReferenceEstimatorSettings<S> es;
    es.num_threads = o.threads;
    es.gripper.approach_opening = sim::widest_opening(scene.model(o.part));  // as SimGripper opens
    // Nuts lie flat side by side, and a cluster of them is not floor (measured in the setting's doc).
    if (o.part == sim::PartType::mirror_nut || o.part == sim::PartType::circle_nut) es.cluster_min_height = S(0.002);
    // The pipeline's check against the known bin: the gripper the judge and the estimator model.
    const auto& g = es.gripper;
    ps.jaw_tool = cycle::jaw_tool_box(g.approach_opening + 2 * g.finger_clearance, g.finger_thickness, g.finger_width,
                                      g.finger_length);
    ps.jaw_tool.lo.z() += g.tip_depth;  // the fingers' tips sit tip_depth past the grasp point
    ps.jaw_tool.hi.z() += g.tip_depth;
    ps.cup_tool = cycle::cup_tool_box(g.cup_radius, g.cup_length);
    // Weak fits are reported too; the pipeline grasps them only when no confident object offers a
    // grasp (PipelineSettings::confident_percent, at the estimator's default threshold).
    ps.confident_percent = es.min_confidence;
    es.min_confidence = kWeakConfidence;
    estimator = std::make_unique<sim::ReferenceEstimator<S, Camera>>(scene.model(o.part), es);
    sim::GraspModelSettings<S> judge;
    judge.jaws_against_mesh = o.jaws_against_mesh;
    judge.jaw_turn_tolerance = o.jaw_turn_tolerance;
    gripper = std::make_unique<SimGripper<S>>(scene, o.part, judge);
    ps.fusion.num_threads = o.threads;
    pipeline = std::make_unique<Pipeline>(*robot, *sensor, *estimator, clock, *gripper, ps);
  }
  int remaining() const { return int(scene.parts().size()); }

  /// Arms a fault for the next cycle (Fault::none disarms both drivers).
  void arm(const Arm& a) {
    robot->arm(a.fault != Fault::none && !on_sensor(a) ? a : Arm{});
    sensor->arm(on_sensor(a) ? a : Arm{});
  }
  /// Whether the fault armed for the last cycle was injected.
  bool fired(const Arm& a) const {
    return a.fault != Fault::none && (on_sensor(a) ? sensor->armed().fired : robot->armed().fired);
  }
  /// Frame faults are the sensor's to inject, the others the robot's.
  static bool on_sensor(const Arm& a) { return a.fault == Fault::frame_lost || a.fault == Fault::frame_late; }
  /// Whether cycle `r` fused a view whose pose read is far from where the camera truly was. Late reads
  /// in motion are off by latency x speed (about 2 cm here), which registration absorbs; 5 cm is far
  /// beyond that. Ground truth, for judging the run only.
  bool fused_wrong_pose(const cycle::CycleResult<S>& r) const {
    if (r.views == 0 || r.status == cycle::CycleStatus::sensor_failure || r.status == cycle::CycleStatus::robot_failure) return false;
    const auto& truth = sensor->truth();
    for (std::size_t k = 0; k < r.T_base_captures_read.size() && k < truth.size(); ++k)
      if ((r.T_base_captures_read[k].translation() - truth[k].translation()).norm() > S(0.05)) return true;
    return false;
  }
};

}  // namespace binpick::simcell

