#pragma once
/// \file pipeline.hpp
/// The picking cycle of Fig. 2 over the driver concepts (drivers.hpp, gripper.hpp). One call of
/// `PickingPipeline::run_cycle()` is one cycle; it starts with the robot standing at a pull-up point
/// (holding the part picked in the previous cycle, or empty-handed in the first cycle and after a
/// search) and ends at the next pull-up point with the next part in hand.
///
/// Our cycle (Strategy::ours, §III.A):
///  1. data collection: the robot continues the pull-up from B along the tilted lift line A'B to M
///     (Alg. 2 puts M on that line at the working distance from T) and stops there shortly: view 1 is
///     triggered at rest with an exact pose read (the reference, §III.B.2). It then follows the arc
///     M→N at speed v, triggering views 2..n at interval t and reading the kinematics at each trigger
///     (late: the robot is moving);
///  2. data processing, in a worker thread, while the robot follows the dropping path N→C: read the n
///     frames (transfer), stereo depth, fusion with ICP and voting (Alg. 1), 6D pose estimation, choice
///     of the object to grasp, and planning of the grasp path, the next sensing path (Eq. 1 over the
///     *remaining* objects, Alg. 2) and the next dropping path. At C the part is released; the robot
///     waits only if processing is not done yet;
///  3. grasp: C → above the grasp pose → grasp (A) → lift to the next pull-up point B.
/// The object to grasp: the most confident one whose grasp the estimator found clear, whose tool keeps
/// clear of the known bin (`jaw_tool`, bin_volume.hpp) and that lies away from the grips that failed
/// since the last success; objects below `confident_percent` only when no other offers a grasp at
/// all; an object whose grasp the estimator found blocked never, unless `grasp_blocked`. When none
/// offers a grasp and a blocked one lies against a wall, the cycle drags it off the wall instead
/// (`drag_from_wall`, CycleResult::dragged); one away from the walls is dragged away from what
/// crowds it (`drag_apart`), and so is an object at which grips keep failing (`drag_after_failures`);
/// when searching keeps finding nothing, the highest surface in the bin is dragged
/// (`drag_unrecognized_after`); a drag that would end on other surface turns to end clear of it
/// (`drag_clearance`). The first cycle uses a predefined path (Alg. 2 aimed at
/// the bin centre from a home point above it). When nothing is recognized (or no grasp is reachable)
/// the next cycle runs the *search move*:
/// from the home point, an arc over the bin centre with `search_beta_factor` × β coverage — a wider
/// look — counted in CycleResult::search. Searches in a row (no grasp between them) aim in turn at the
/// bin centre and at the centres of its four quarters, each from above it looking outward
/// (`vary_search`): a look that found nothing is not repeated from the same side while parts may lie
/// where it saw them badly. The first search after a grasp, and the path after a grasp of the last
/// recognized object, look instead at surface the fused depth shows that no recognized object
/// explains (`look_at_unexplained`). After a failed grip the next cycle carries nothing to drop, and its planned
/// path is turned about the vertical through B (`relook`): the same views would give the same wrong pose.
///
/// Baselines (§IV.D): `single_view` (A) is ours with n = 1; `random_path` (B) aims each sensing path
/// at a random point of the bin instead of Eq. 1 (also after a drag; it never looks at unexplained
/// surface: its searches are the fixed turn of searches); `stop_and_go` (C) is the conventional cell of Robot
/// Fusion [12]: drop first (B→C direct), then approach the bin and stop at each of n predefined views
/// (exact poses), process serially while the robot waits, then grasp.
///
/// Degenerate sensing paths (Alg. 2 returns a status, about 6 % of realistic plans): the fallbacks, in
/// order, are (1) β/2 with the same n, (2) the target moved to the bin centre, (3) the predefined path.
/// CycleResult::path_source says which one ran.
///
/// Time: every duration is read from the Clock. Hardware durations a simulation cannot produce
/// (image transfer, stereo depth per view) come from `takt` when `model_hardware_time` is set; fusion
/// with ICP, estimation and planning are measured (steady clock) and added to the Clock time at which
/// processing started, so a simulated cell accounts for them as a real one would. Measured time depends
/// on the machine and its load, so a simulated cell's later cycles (where the robot waits, what time it
/// is at each trigger) do too; `fixed_compute_time` replaces it on the Clock by a constant, which makes
/// a simulated picking test bit-reproducible for a seed and thread count (measured times are still
/// reported in CycleResult).
///
/// Failures: an exception from a driver, a pose read that is not a rigid finite pose, a pose read or a
/// frame stamped more than `max_stamp_offset` from its trigger, or fewer frames read back than
/// triggered end the cycle with a status and a message. The pipeline then drains the
/// sensor memory, waits for the robot to stop, returns it to the home point and falls back to the
/// predefined path; the part in hand (if any) is still held and is dropped by the next cycle.
/// Processing runs on one worker thread the pipeline owns (started by the first cycle, joined by the
/// destructor, worker_thread.hpp); run_cycle returns only after the cycle's job has ended. The library
/// never prints.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <exception>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "binpick/active_vision/sensing_path.hpp"
#include "binpick/active_vision/target_center.hpp"
#include "binpick/core/errors.hpp"
#include "binpick/core/pose.hpp"
#include "binpick/cycle/bin_volume.hpp"
#include "binpick/cycle/drivers.hpp"
#include "binpick/cycle/gripper.hpp"
#include "binpick/cycle/takt.hpp"
#include "binpick/cycle/worker_thread.hpp"
#include "binpick/fusion/fuse.hpp"

namespace binpick::cycle {

/// How the sensing of a cycle is done (ours and the paper's baselines, §IV.D).
enum class Strategy {
  ours,         ///< multi-view + active vision, sensing parallel to the place action
  single_view,  ///< baseline A: one view + active vision
  random_path,  ///< baseline B: multi-view along a sensing path aimed at a random point of the bin
  stop_and_go,  ///< baseline C: Robot Fusion [12]: stop at each predefined view, process, then grasp
};

inline const char* to_string(Strategy s) {
  switch (s) {
    case Strategy::ours: return "ours";
    case Strategy::single_view: return "A";
    case Strategy::random_path: return "B";
    case Strategy::stop_and_go: return "C";
  }
  return "unknown";
}

/// Settings of the cycle. Units: metres, radians, seconds; speeds in percent of full speed.
template <typename Scalar>
struct PipelineSettings {
  Strategy strategy = Strategy::ours;
  // Sensing parameters (Table III, "Sensing Parameters"; determine them with §III.D.2).
  int num_views = 4;                        ///< n views (forced to 1 for single_view)
  double interval = 0.030;                  ///< t between triggers [s]
  Scalar sensing_speed_percent = Scalar(80);  ///< v along the sensing path [%] (100 % ≈ full_speed)
  Scalar gamma = Scalar(5 * M_PI / 180);    ///< γ of Alg. 2 [rad]
  Scalar working_distance = Scalar(0.30);   ///< r, radius of the sphere S [m]
  Scalar min_elevation = Scalar(0);         ///< lowest sensor elevation over T along the arc [rad]
  Scalar search_beta_factor = Scalar(2);    ///< the search arc covers this × β [-]
  bool vary_search = true;                  ///< searches in a row aim at the bin centre, then its quarters (file comment)
  bool relook = true;                       ///< after a failed grip, turn the next arc about B's vertical (file comment; not for B's random paths)
  // Motion.
  Scalar motion_speed_percent = Scalar(80);  ///< lift, drop, return [%]
  Scalar grasp_speed_percent = Scalar(30);   ///< the last approach to the grasp pose [%]
  Scalar full_speed = Scalar(1.0);           ///< flange speed at 100 % [m/s] (nominal; prices the direct B→C move)
  Scalar full_angular_speed = Scalar(M_PI);  ///< flange rotation speed at 100 % [rad/s] (nominal)
  double stop_time = 0.003;                  ///< standstill at a stop for a view [s] (one exposure)
  // Cell layout (robot base frame).
  Isometry3<Scalar> T_flange_camera = default_hand_eye();  ///< hand-eye: camera pose in the flange frame
  Vector3<Scalar> bin_center = Vector3<Scalar>::Zero();   ///< centre of the bin floor [m]
  Scalar bin_length = Scalar(0.50);        ///< inner size along base x [m]
  Scalar bin_width = Scalar(0.25);         ///< inner size along base y [m]
  Scalar bin_height = Scalar(0.10);        ///< wall height [m]
  Scalar lift_clearance = Scalar(0.05);    ///< pull-up point B above the wall top [m]
  Scalar approach_distance = Scalar(0.05); ///< pre-grasp pose this far back along the approach [m]
  Isometry3<Scalar> T_base_drop = default_drop();  ///< flange pose at the drop point C
  Scalar max_approach_tilt = Scalar(1.05); ///< grasps whose approach deviates more from straight down are skipped [rad]
  // Processing.
  TaktSettings takt;                       ///< Table I constants; hardware durations of the cell
  bool model_hardware_time = true;         ///< add transfer and stereo depth time from `takt` (simulated sensors)
  /// < 0: the Clock advances by the measured compute time of fusion + ICP, estimation and planning (and
  /// of the frame read when model_hardware_time is off) — what a real cell does. >= 0: it advances by
  /// this many seconds per cycle instead, whatever the computer took, so a simulated cell runs the same
  /// cycles on any machine under any load (the reproducible picking test) [s].
  double fixed_compute_time = -1;
  FusionSettings<Scalar> fusion = default_fusion();  ///< sensor_accuracy is replaced by the sensor's
  /// Region of interest: fused depth whose point (base frame) lies outside the bin's inside shrunk by
  /// `crop_margin` from the walls, or above the wall top by more than `crop_height`, is removed before
  /// estimation (walls and rims look like parts to a model fitter; the reference view moves every cycle,
  /// so the region is a volume in the base frame, not a fixed pixel rectangle).
  bool crop_to_bin = true;
  /// [m] Only the walls' inner faces and their noise: a part's outer edge may lie within 1–3 mm of
  /// a wall, and 15 mm left parts beside the long walls unseen for the rest of a run (measured on the
  /// picking test: 10 runs × 5 types, seeds 1 and 2, +7 and +6 parts of 500 at 4 mm).
  Scalar crop_margin = Scalar(0.004);
  Scalar crop_height = Scalar(0.05);       ///< [m] above the wall top
  /// Fused depth lower than this above the bin floor is removed too: the floor is known geometry whose
  /// patches between parts (cut off by holes and ghosts) a model fitter takes for thin parts, and depth
  /// below it is inter-reflection ghosts (SENSOR_MODEL.md); the parts' upper surfaces lie higher [m].
  Scalar crop_floor = Scalar(0.0015);
  /// Grasp points lower than this above the bin floor are not chosen: fingers or cup would hit the
  /// floor, and no part lying on it is grasped that low (such fits are ghosts or floor pieces) [m].
  Scalar min_grasp_height = Scalar(0.002);
  /// The space the tool takes at a grasp, per gripper kind (bin_volume.hpp). A grasp whose tool would
  /// stand in the bin's floor or walls (bin_center, bin_length, bin_width, bin_height), or come within
  /// `tool_margin` of the walls, is never chosen, whatever the estimator found: it checks measured
  /// depth, which barely shows a wall's inner face. The bin also goes to the estimator
  /// (EstimatorInput::bin), so that it picks among an object's grasps one that keeps clear. Defaults:
  /// jaws of 25 mm stroke with fingers 4 × 8 × 30 mm; a cup of 5 mm radius, 40 mm long with its stem.
  /// An empty box: no check for that kind.
  ToolBox<Scalar> jaw_tool = jaw_tool_box(Scalar(0.025), Scalar(0.004), Scalar(0.008), Scalar(0.030));
  ToolBox<Scalar> cup_tool = cup_tool_box(Scalar(0.005), Scalar(0.040));
  Scalar tool_margin = Scalar(0);  ///< [m] see jaw_tool
  /// After a failed grip, objects whose grasp point lies within this of it are chosen only when no other
  /// is left, until a grip succeeds near it (forget_distance): the same fused depth gives the same
  /// wrong pose again [m].
  Scalar retry_distance = Scalar(0.01);
  /// [m] A grip that holds forgets the failed grips within this of its grasp point (taking the part
  /// may free or move its neighbours); those farther away stay remembered (retry_distance,
  /// drag_after_failures). Infinity: a success forgets every failure. With that (the earlier rule),
  /// binpick_sim (ours, 1280 x 1024, seed 4) ended a LAN-connector run with 5 parts left: a
  /// connector lying 52° tilted on two others was gripped 4 times (its jaws hit them), the failures
  /// forgotten each time a part 5-6 cm away was picked, so it was never dragged.
  Scalar forget_distance = Scalar(0.03);
  /// [%] Objects the estimator reports with less confidence are grasped only when no other object
  /// offers a grasp: a last try before the search move. Parts the sensor sees poorly from every side
  /// (a mirror-polished nut lying flat shows only its rims) keep a weak fit, and looking again rarely
  /// shows them better; a run would end on them. Takes effect when the estimator reports such objects
  /// (its own threshold lower than this). 0: every reported object alike.
  Scalar confident_percent = Scalar(0);
  /// Whether an object whose grasp the estimator found blocked (RecognizedObject::grasp_clear false:
  /// the gripper would stand in measured surface) is grasped when no object offers a clear one. Off:
  /// such a cycle runs the search move instead, and the next look comes from another side. Measured
  /// on the picking test (ours, seed 1, 5 runs × 20 parts per type, fixed compute time): with it on,
  /// 0 of the 12 blocked grips tried at 640 × 512 held (7 hit a neighbouring part), and 0 of 5 at
  /// 1280 × 1024. In a real cell such a grip risks the gripper as well.
  bool grasp_blocked = false;
  /// Drag recovery. A part against a wall often offers no grasp at all: every way of closing the jaws
  /// on it puts a finger in the wall, and looking again does not change that (the paper's failed picks,
  /// §IV.D). When no object offers a grasp and one that was skipped as blocked (by the estimator or by
  /// the bin check, jaw_tool) has its centre within `drag_wall_distance` of a wall's inner face, the
  /// cycle drags it instead of searching: the closed tool presses `drag_press` into its top (the
  /// highest fused depth within `drag_radius` of its centre) and moves `drag_distance` straight away
  /// from the wall (from both at a corner); the next cycle looks where it went. At most
  /// `max_drags_in_row` drags between two grips, then searches. Needs a gripper with prepare_drag
  /// (gripper.hpp); CycleResult::dragged counts them.
  bool drag_from_wall = true;
  Scalar drag_wall_distance = Scalar(0.03);  ///< [m] see drag_from_wall
  /// The same drag for a blocked object away from the walls (singulation): straight away from the
  /// nearest other recognized object within `drag_wall_distance`, else away from the surface piled
  /// around it in the fused depth (its points within `drag_wall_distance`, each pulling by its height
  /// above the bin floor; none when they balance, as around a part alone on the floor). Parts left in a
  /// tangle at the end of a run block each other's grasps from every side, often with only the top one
  /// recognized (binpick_sim ours, 1280 × 1024, seed 4: a LAN connector run ended with one connector
  /// leaning 31° on an unrecognized one, blocked in 5 cycles in a row).
  bool drag_apart = true;
  /// An object at which this many remembered grips failed (failures within `retry_distance` of its
  /// grasp point, not forgotten by a success: forget_distance) is dragged (off a wall, or as
  /// drag_apart, else toward the bin centre) instead of gripped again, when no other object offers a
  /// grasp. The cell does not know
  /// why a grip failed: a neighbour the fused depth hides, or a pose the views keep getting wrong; both
  /// change when the part moves. 0: never.
  int drag_after_failures = 2;
  /// After this many cycles in a row that neither grasp nor drag (searches included), a cycle that
  /// finds nothing to grasp or drag drags the highest surface the fused depth shows in the bin
  /// instead of searching again: parts the estimator does not recognize from any side (a tangle, two
  /// parts leaning into one segment) stay where they are otherwise, and the run ends on them
  /// (binpick_sim ours, 1280 × 1024, seed 3, pencil coupler run 2: two couplers, one leaning 41° on
  /// the other, unrecognized in 4 of the last 5 cycles). 0: never.
  int drag_unrecognized_after = 2;
  /// [m] The least height above the floor of a surface the drag of drag_unrecognized_after presses
  /// on: above the fused depth's error on the floor (at 640 × 512 on the simulated metal sensor, a
  /// patch of floor beside a LAN connector measured 2.8 mm high over the tool's whole footprint).
  Scalar drag_surface_height = Scalar(0.004);
  /// [m] A surface at least this high above the floor is dragged (drag_unrecognized_after) with a
  /// quarter of the tool's footprint measured instead of half: a part standing on end shows only its
  /// top, a thin ring or edge with holes around it (a pencil coupler on end: 31 mm).
  Scalar drag_tall_height = Scalar(0.02);
  Scalar drag_distance = Scalar(0.04);       ///< [m]
  Scalar drag_press = Scalar(0.002);         ///< [m]
  Scalar drag_radius = Scalar(0.005);        ///< [m] the closed tool's footprint
  /// [m] A drag ends clear of other parts: where the fused depth shows no surface drag_surface_height
  /// above the floor within this of the dragged part's new centre (none it brings along: points within
  /// this of where it started are its own; outside the view, nothing shows). When the planned
  /// direction ends on such surface, it turns by 30°, then 60° to either side, to the first that ends
  /// clear (as planned when none does). 0: drags go as planned. A part dragged into others may end propped on them, standing or tangled
  /// (binpick_sim ours, 1280 × 1024, seed 5, mirror nut run 0: a flat nut dragged 40 mm into two
  /// leaning ones ended standing among them).
  Scalar drag_clearance = Scalar(0.015);
  int max_drags_in_row = 2;
  /// Where to look when no recognized object is left to look at. The next sensing path after a grasp
  /// of the last recognized object, and the first search after a grasp, aim at the densest patch of
  /// surface the fused depth shows in the bin that no recognized object explains: higher than
  /// drag_surface_height above the floor, lower than half the wall (stereo fattens the wall tops
  /// inward), more than `look_wall_band` off the walls (their inner faces, seen aslant, leave points
  /// there), farther than `look_radius` from every recognized object, at least `look_min_area` of it
  /// within `look_radius`. The search starts above that patch and sweeps toward the bin centre,
  /// instead of looking from the bin centre or a quarter. Without such a patch: the bin centre (Eq. 1's
  /// fallback) and the turn of searches. The reason is what a view sees of a part: a polished face
  /// beside a wall mirrors the wall's inner face into views from the bin's middle. Measured on a lone
  /// LAN connector against a long wall (20 poses, 4 fused views at 1280 × 1024 from 0.3 m): recognized
  /// in 7 of 20 with the views over the bin's centre line, 19 with them over the point half-way to it,
  /// 20 with them above it. Off: the bin centre and the turn of searches. Always off for random_path.
  bool look_at_unexplained = true;
  Scalar look_radius = Scalar(0.02);         ///< [m] see look_at_unexplained
  Scalar look_min_area = Scalar(0.3e-4);     ///< [m²] see look_at_unexplained (0.3 cm²)
  Scalar look_wall_band = Scalar(0.008);     ///< [m] see look_at_unexplained
  std::uint64_t seed = 1;                  ///< random target points of random_path
  bool keep_images = false;                ///< keep the fused depth and votes in the CycleResult
  /// A pose read or a frame stamped further than this from its view's trigger is not matched to the
  /// view (a stale controller sample, a frame of another trigger): the cycle ends with robot_failure
  /// or sensor_failure instead of fusing a view with a wrong pose [s].
  double max_stamp_offset = 0.050;

  /// Camera 10 cm behind the tool point along the approach and 5 cm aside, looking along it.
  static Isometry3<Scalar> default_hand_eye() {
    Isometry3<Scalar> T = Isometry3<Scalar>::Identity();
    T.translation() = Vector3<Scalar>(Scalar(0.05), Scalar(0), Scalar(-0.10));
    return T;
  }
  /// The drop point C beside the bin (about 1 m away, as a place action of ~1.2 s at 80 %), tool down.
  static Isometry3<Scalar> default_drop() {
    Isometry3<Scalar> T = Isometry3<Scalar>::Identity();
    T.linear() = Eigen::AngleAxis<Scalar>(Scalar(M_PI), Vector3<Scalar>::UnitX()).toRotationMatrix();
    T.translation() = Vector3<Scalar>(Scalar(0.15), Scalar(0.95), Scalar(0.30));
    return T;
  }
  /// The library's fusion, with votes kept, and without source normals in the registration: on the
  /// cell's single-shot depth of shiny metal they are noisy and their pair filter biases the pose.
  /// Measured on simulated metal piles (640 x 512, 5 part types x 4 piles, 3 views on the sensing
  /// arc with the fake robot's late kinematics): rms displacement of a view's points from the truth
  /// 0.19 mm mean (worst 0.36 mm) without, 0.72 mm (worst 1.77 mm) with; the picking test (ours,
  /// 10 runs x 10 parts, seed 1, fixed compute time) completed 96 / 37 / 57 / 85 / 96 % of the
  /// screws / LAN connectors / mirror nuts / pencil couplers / circle nuts without, 90 / 36 / 53 /
  /// 82 / 91 % with. (On clean geometry, such as analytic boxes, source normals keep box edges from
  /// sliding: the library keeps them on by default.)
  static FusionSettings<Scalar> default_fusion() {
    FusionSettings<Scalar> f;
    f.compute_votes = true;
    f.source_normals = false;
    return f;
  }
};

enum class CycleStatus {
  picked,              ///< a part was grasped and lifted
  grasp_failed,        ///< the gripper closed on nothing
  nothing_recognized,  ///< no object (or no reachable grasp): the next cycle runs the search move
  sensor_failure,      ///< a trigger threw or a frame never arrived
  robot_failure,       ///< a motion or a pose read failed
  processing_failure,  ///< fusion, estimation or planning threw or returned invalid input
};

inline const char* to_string(CycleStatus s) {
  switch (s) {
    case CycleStatus::picked: return "picked";
    case CycleStatus::grasp_failed: return "grasp_failed";
    case CycleStatus::nothing_recognized: return "nothing_recognized";
    case CycleStatus::sensor_failure: return "sensor_failure";
    case CycleStatus::robot_failure: return "robot_failure";
    case CycleStatus::processing_failure: return "processing_failure";
  }
  return "unknown";
}

/// Where a cycle's sensing path came from.
enum class PathSource {
  predefined,           ///< the first cycle, or after a failure
  planned,              ///< Alg. 2 as planned by the previous cycle
  fallback_half_beta,   ///< Alg. 2 was degenerate; β/2 worked
  fallback_bin_center,  ///< … the target moved to the bin centre worked
  fallback_predefined,  ///< … the predefined path was used
  search,               ///< the search move (nothing recognized before)
  fixed_views,          ///< stop-and-go: the predefined views
};

inline const char* to_string(PathSource s) {
  switch (s) {
    case PathSource::predefined: return "predefined";
    case PathSource::planned: return "planned";
    case PathSource::fallback_half_beta: return "fallback_half_beta";
    case PathSource::fallback_bin_center: return "fallback_bin_center";
    case PathSource::fallback_predefined: return "fallback_predefined";
    case PathSource::search: return "search";
    case PathSource::fixed_views: return "fixed_views";
  }
  return "unknown";
}

/// Everything one cycle did.
template <typename Scalar>
struct CycleResult {
  CycleStatus status = CycleStatus::nothing_recognized;
  std::string error;             ///< what failed (empty unless a failure status)
  int index = 0;                 ///< cycle number of this pipeline, from 0
  bool placed = false;           ///< a part was released at C in this cycle
  bool search = false;           ///< this cycle ran the search move
  bool dragged = false;          ///< instead of a grasp, this cycle dragged (drag_from_wall, drag_apart, drag_after_failures, drag_unrecognized_after)
  int views = 0;                 ///< views fused
  int recognized = 0;            ///< objects the estimator returned
  PathSource path_source = PathSource::predefined;  ///< this cycle's sensing path
  active_vision::SensingPathStatus next_plan_status = active_vision::SensingPathStatus::ok;  ///< Alg. 2 for the next cycle
  Timeline timeline;             ///< robot segments, captures and processing stages (Clock time)
  CycleTakt takt;
  double fusion_ms = 0;          ///< measured: reprojection, ICP, voting
  double icp_ms = 0;             ///< measured: the ICP registration's share of fusion_ms
  double estimation_ms = 0;      ///< measured
  double planning_ms = 0;        ///< measured: grasp choice, Eq. 1, Alg. 2, paths
  // Geometry of the cycle (base frame), e.g. for drawing.
  Vector3<Scalar> target = Vector3<Scalar>::Zero();         ///< T of this cycle's path
  Vector3<Scalar> pull_up = Vector3<Scalar>::Zero();        ///< camera position at the start B
  Vector3<Scalar> drop = Vector3<Scalar>::Zero();           ///< flange position at C
  std::vector<Isometry3<Scalar>> T_base_captures_planned;   ///< camera poses of the path
  std::vector<Isometry3<Scalar>> T_base_captures_read;      ///< camera poses from the kinematics reads
  std::vector<Vector3<Scalar>> objects_base;                ///< recognized object positions
  Isometry3<Scalar> T_base_grasp = Isometry3<Scalar>::Identity();  ///< chosen grasp (when any)
  bool grasp_clear = false;      ///< the estimator found the chosen grasp clear of the measured scene
  // With settings.keep_images:
  DepthImage<Scalar> fused_depth;                           ///< fused depth of view 1 [m]
  std::vector<std::uint8_t> votes;                          ///< votes per pixel, row-major
};

namespace detail {

inline std::uint64_t splitmix64(std::uint64_t& x) {
  std::uint64_t z = (x += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}
inline double uniform01(std::uint64_t& x) { return double(splitmix64(x) >> 11) * (1.0 / 9007199254740992.0); }

template <typename Scalar>
bool is_rigid_finite(const Isometry3<Scalar>& T) {
  if (!T.matrix().allFinite()) return false;
  const Matrix3<Scalar> R = T.linear();
  const Scalar tol = std::is_same<Scalar, float>::value ? Scalar(1e-3) : Scalar(1e-8);
  return (R.transpose() * R - Matrix3<Scalar>::Identity()).cwiseAbs().maxCoeff() < tol && R.determinant() > 0;
}

/// The camera pose `T` re-rolled about its optical axis so that its x axis is as close as possible to
/// `x_ref`: fusion and Alg. 2 need only position and view direction, and keeping the roll of the
/// camera at B spares the wrist a turn.
template <typename Scalar>
Isometry3<Scalar> with_roll_near(const Isometry3<Scalar>& T, const Vector3<Scalar>& x_ref) {
  const Vector3<Scalar> z = T.linear().col(2);
  Vector3<Scalar> x = x_ref - x_ref.dot(z) * z;
  if (!(x.norm() > Scalar(1e-3))) return T;
  x.normalize();
  Isometry3<Scalar> out = T;
  out.linear().col(0) = x;
  out.linear().col(1) = z.cross(x);
  out.linear().col(2) = z;
  return out;
}

}  // namespace detail

/// The cycle of Fig. 2 (see the file comment). Robot, Sensor, Estimator, Clock and Gripper model the
/// concepts of drivers.hpp and gripper.hpp; the scalar and camera of the library side are the
/// sensor's. Drivers are referenced, not owned; the clock must be the one the drivers stamp with.
template <typename Robot, typename Sensor, typename Estimator, typename Clock, typename Gripper>
class PickingPipeline {
  static_assert(is_robot_driver<Robot>::value, "Robot must model RobotDriver (drivers_robot.hpp)");
  static_assert(is_sensor_driver<Sensor>::value, "Sensor must model SensorDriver (drivers_sensor.hpp)");
  static_assert(is_pose_estimator<Estimator>::value, "Estimator must model PoseEstimator (drivers_estimator.hpp)");
  static_assert(is_clock<Clock>::value, "Clock must model Clock (drivers_clock.hpp)");
  static_assert(is_gripper<Gripper>::value, "Gripper must model Gripper (gripper.hpp)");

 public:
  using Scalar = typename Sensor::Scalar;
  using Camera = typename Sensor::Camera;
  using RobotScalar = typename Robot::Scalar;
  using Pose = Isometry3<Scalar>;
  using Vec3 = Vector3<Scalar>;
  static_assert(std::is_same<typename Estimator::Scalar, Scalar>::value && std::is_same<typename Estimator::Camera, Camera>::value,
                "the estimator must take the sensor's scalar and camera");

  /// Throws std::invalid_argument naming the setting that is out of range, or `settings` when the
  /// layout admits no predefined sensing path. The robot should stand still; the first cycle moves it
  /// to the home point above the bin.
  PickingPipeline(Robot& robot, Sensor& sensor, Estimator& estimator, Clock& clock, Gripper& gripper,
                  const PipelineSettings<Scalar>& settings);

  const PipelineSettings<Scalar>& settings() const { return s_; }
  bool holding() const { return holding_; }
  /// β of the sensing path: the arc v·t·(n − 1) seen from T at the working distance [rad].
  Scalar beta() const { return beta_; }
  /// Flange pose of the home point above the bin centre (start of the first cycle and of searches).
  const Pose& T_base_home() const { return T_home_; }
  int searches() const { return searches_; }

  /// One cycle (file comment). Never throws for driver failures: they are a status.
  CycleResult<Scalar> run_cycle();

 private:
  struct Plan {
    std::vector<Pose> T_base_cameras;  // capture poses (camera), n of them
    Vec3 target = Vec3::Zero();
    PathSource source = PathSource::predefined;
    active_vision::SensingPathStatus status = active_vision::SensingPathStatus::ok;
  };
  struct CycleFailure : std::runtime_error {
    CycleFailure(CycleStatus s, const std::string& what) : std::runtime_error(what), status(s) {}
    CycleStatus status;
  };
  struct Capture {
    std::vector<Pose> T_base_cameras_read;
    std::vector<double> trigger_times;
  };
  struct Processed {
    bool ok = false;
    CycleStatus status = CycleStatus::nothing_recognized;
    std::string error;
    int views = 0;
    int recognized = 0;
    bool has_grasp = false;
    Pose T_base_grasp = Pose::Identity();
    GripperKind gripper = GripperKind::two_finger;
    bool grasp_clear = false;
    bool has_drag = false;  // no grasp; drag from T_base_drag_from to T_base_drag_to (plan_drag)
    Pose T_base_drag_from = Pose::Identity(), T_base_drag_to = Pose::Identity();
    Plan next;
    bool has_look = false;  // no grasp: surface no recognized object explains (look_at_unexplained)
    Vec3 look_at = Vec3::Zero();
    active_vision::SensingPathStatus plan_status = active_vision::SensingPathStatus::ok;
    std::vector<Vec3> objects_base;
    double read_s = 0, fusion_s = 0, estimation_s = 0, planning_s = 0;  // measured wall time
    double icp_s = 0;  // the registration's share of fusion_s (FusionResult::registration_ms)
    DepthImage<Scalar> fused;
    std::vector<std::uint8_t> votes;
  };

  static double seconds_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  static Isometry3<RobotScalar> cast_robot(const Pose& T) { return T.template cast<RobotScalar>(); }
  static Pose cast_lib(const Isometry3<RobotScalar>& T) { return T.template cast<Scalar>(); }
  Pose flange_of_camera(const Pose& T_base_camera) const {
    return T_base_camera * s_.T_flange_camera.inverse(Eigen::Isometry);
  }
  Pose camera_of_flange(const Pose& T_base_flange) const { return camera_pose_in_base(T_base_flange, s_.T_flange_camera); }

  Scalar beta_from_motion(int n) const {
    // Arc length v·t·(n − 1) at the working distance (T in P, §III.D.1): β = v t (n − 1) / r.
    const Scalar v = s_.full_speed * s_.sensing_speed_percent / Scalar(100);
    const Scalar b = v * Scalar(s_.interval) * Scalar(std::max(1, n - 1)) / s_.working_distance;
    return std::min(Scalar(M_PI / 2), std::max(Scalar(1e-3), b));
  }

  /// Nominal time of a straight move (the same model as the robot's constant-speed segments).
  double move_time(const Pose& a, const Pose& b, Scalar percent) const {
    const Scalar v = s_.full_speed * percent / Scalar(100), w = s_.full_angular_speed * percent / Scalar(100);
    return std::max(double((b.translation() - a.translation()).norm() / v),
                    double(rotation_angle<Scalar>(relative_pose(a, b)) / w));
  }

  /// The sensing path of Alg. 2 for grasp A, pull-up flange pose at B and target T, with the roll of
  /// the camera at B; no capture poses when Alg. 2 fails (`status` says why). The arc sweeps toward the
  /// drop point C, or toward `sweep_to` (a flange position) when given: a search carries no part, so
  /// its arc may turn any way.
  Plan arc_plan(const Vec3& target, const Vec3& A, const Pose& T_base_B, Scalar beta, PathSource source,
                const Vec3* sweep_to = nullptr) const {
    const Pose cam_B = camera_of_flange(T_base_B);
    const Vec3 d = cam_B.translation() - T_base_B.translation();  // all points as camera positions
    const Vec3 C = (sweep_to ? *sweep_to : s_.T_base_drop.translation()) + d;
    const auto path = active_vision::plan_sensing_path<Scalar>(target, s_.working_distance, A + d, cam_B.translation(), C,
                                                               s_.gamma, beta, std::max(2, n_), s_.min_elevation);
    Plan p;
    p.target = target;
    p.source = source;
    p.status = path.status;
    if (!path.ok()) return p;
    const Vec3 x_ref = cam_B.linear().col(0);
    for (int i = 0; i < n_; ++i) p.T_base_cameras.push_back(detail::with_roll_near(path.T_base_captures[std::size_t(i)], x_ref));
    return p;
  }

  Vec3 default_target() const { return s_.bin_center + Vec3(0, 0, Scalar(0.01)); }

  Plan home_path(Scalar beta, PathSource source) const {
    const Vec3 A = s_.bin_center;
    return arc_plan(default_target(), A, T_home_, beta, source);
  }

  /// The searches in a row go through (file comment): the bin centre's from the home point, then the
  /// bin's quarters'. A quarter's arc starts above its centre (B moved there from the home point) and
  /// sweeps toward the bin centre, looking outward at the quarter: from the home point toward the drop
  /// point, Alg. 2 found no arc to the quarters on the far side (the home camera lies beyond the
  /// working distance of their centres), and a look from the inside sees parts beside the walls.
  std::vector<Plan> search_plans() const {
    const Scalar beta = std::min(Scalar(M_PI / 2), beta_ * s_.search_beta_factor);
    Plan centre = home_path(beta, PathSource::search);
    if (centre.T_base_cameras.empty()) centre = predefined_;
    std::vector<Plan> out{centre};
    const Scalar sx[4] = {1, -1, -1, 1}, sy[4] = {1, 1, -1, -1};
    for (int q = 0; q < 4 && s_.vary_search; ++q) {
      const Plan p = search_from_above(s_.bin_center + Vec3(sx[q] * s_.bin_length / 4, sy[q] * s_.bin_width / 4, 0), beta);
      if (!p.T_base_cameras.empty()) out.push_back(p);
    }
    return out;
  }

  /// A search arc from B above the floor point A (the home point moved there), aimed at A and sweeping
  /// toward the bin centre (toward the drop point when A lies within look_radius of the centre: the
  /// arc's plane needs a direction); no capture poses when Alg. 2 finds no arc. With `start_above`,
  /// A and B move so that the arc starts above A (Alg. 2 puts M beside B, on the far side from where
  /// the arc sweeps: 13 cm for the search arc of the default settings), the target staying at A.
  Plan search_from_above(const Vec3& A, Scalar beta, bool start_above = false) const {
    const Vec3 target = A + (default_target() - s_.bin_center);
    Pose T_B = T_home_;
    T_B.translation() += A - s_.bin_center;
    const Vec3 inward = T_B.translation() + Scalar(4) * (s_.bin_center - A);
    const bool central = (A - s_.bin_center).template head<2>().norm() < s_.look_radius;
    const Plan p = arc_plan(target, A, T_B, beta, PathSource::search, central ? nullptr : &inward);
    if (!start_above || p.T_base_cameras.empty()) return p;
    Vec3 off = p.T_base_cameras.front().translation() - target;
    off.z() = 0;
    Pose T_B2 = T_B;
    T_B2.translation() -= off;
    const Plan moved = arc_plan(target, A - off, T_B2, beta, PathSource::search, central ? nullptr : &inward);
    return moved.T_base_cameras.empty() ? p : moved;
  }

  /// Alg. 2 with the documented fallbacks (file comment).
  Plan plan_with_fallbacks(const Vec3& target, const Vec3& A, const Pose& T_base_B) const {
    const Plan planned = arc_plan(target, A, T_base_B, beta_, PathSource::planned);
    if (!planned.T_base_cameras.empty()) return planned;
    Plan p = arc_plan(target, A, T_base_B, beta_ / 2, PathSource::fallback_half_beta);
    if (p.T_base_cameras.empty()) p = arc_plan(default_target(), A, T_base_B, beta_, PathSource::fallback_bin_center);
    if (p.T_base_cameras.empty()) {
      p = predefined_;
      p.source = PathSource::fallback_predefined;
    }
    p.status = planned.status;
    return p;
  }

  /// Trigger a view now and read the kinematics (exact at rest, late in motion).
  void capture(Capture& cap, Timeline& tl) {
    double t = 0;
    try {
      t = sensor_->trigger();
    } catch (const std::exception& e) {
      throw CycleFailure(CycleStatus::sensor_failure, std::string("sensor: trigger of view ") +
                                                          std::to_string(cap.trigger_times.size() + 1) + " failed: " + e.what());
    }
    StampedPose<RobotScalar> read;
    try {
      read = robot_->read_flange_pose();
    } catch (const std::exception& e) {
      throw CycleFailure(CycleStatus::robot_failure, std::string("robot: pose read of view ") +
                                                         std::to_string(cap.trigger_times.size() + 1) + " failed: " + e.what());
    }
    if (!detail::is_rigid_finite(read.T_base_flange))
      throw CycleFailure(CycleStatus::robot_failure, "robot: pose read of view " + std::to_string(cap.trigger_times.size() + 1) +
                                                         " is not a rigid finite pose");
    if (!(std::abs(read.time - t) <= s_.max_stamp_offset))
      throw CycleFailure(CycleStatus::robot_failure, "robot: pose read of view " + std::to_string(cap.trigger_times.size() + 1) +
                                                         " is stamped " + std::to_string(int(std::round((read.time - t) * 1e3))) +
                                                         " ms from its trigger (stale sample)");
    const std::size_t k = cap.trigger_times.size() + 1;
    tl.add("exposure " + std::to_string(k), Lane::capture, t, t + s_.takt.exposure);
    tl.add("kinematics " + std::to_string(k), Lane::capture, read.time, read.time + s_.takt.kinematics);
    cap.trigger_times.push_back(t);
    cap.T_base_cameras_read.push_back(camera_of_flange(cast_lib(read.T_base_flange)));
  }

  /// Move and wait for arrival; returns the arrival time. Records a robot segment.
  double move(const std::vector<Pose>& path, Scalar percent, const std::string& name, Timeline& tl) {
    const double t0 = clock_->now();
    std::vector<Isometry3<RobotScalar>> rp;
    for (const auto& p : path) rp.push_back(cast_robot(p));
    const double arrival = robot_->move_along(rp, RobotScalar(percent));
    clock_->sleep_until(arrival);
    tl.add(name, Lane::robot, t0, clock_->now());
    T_at_ = path.back();
    return clock_->now();
  }

  /// The data processing phase (runs in the worker thread; touches only the sensor, fuser, estimator).
  Processed process(const Capture& cap, std::size_t triggered) {
    Processed out;
    using clk = std::chrono::steady_clock;
    try {
      auto t0 = clk::now();
      std::vector<DepthFrame<Scalar>> frames = sensor_->read_frames();
      out.read_s = seconds_since(t0);
      if (frames.size() != triggered) {
        out.status = CycleStatus::sensor_failure;
        out.error = "sensor: read " + std::to_string(frames.size()) + " frames, expected " + std::to_string(triggered) +
                    (frames.size() < triggered ? " (frame " + std::to_string(frames.size() + 1) + " never arrived)" : "");
        return out;
      }
      for (std::size_t i = 0; i < frames.size(); ++i)
        if (!(std::abs(frames[i].trigger_time - cap.trigger_times[i]) <= s_.max_stamp_offset)) {
          out.status = CycleStatus::sensor_failure;
          out.error = "sensor: frame " + std::to_string(i + 1) + " is stamped " +
                      std::to_string(int(std::round((frames[i].trigger_time - cap.trigger_times[i]) * 1e3))) +
                      " ms from its trigger (a frame of another trigger)";
          return out;
        }
      t0 = clk::now();
      std::vector<DepthImageView<Scalar>> views;
      for (const auto& f : frames) views.push_back(f.depth.view());
      FusionSettings<Scalar> fs = s_.fusion;
      fs.sensor_accuracy = sensor_->accuracy();
      FusionResult<Scalar>& fused = fused_;  // kept across cycles: no large allocation per cycle
      fuser_.fuse(views, cap.T_base_cameras_read, fs, fused);
      if (s_.crop_to_bin) {
        uncropped_ = fused.depth;  // the walls and floor, for the estimator's gripper check
        crop(fused);
      }
      out.fusion_s = seconds_since(t0);
      out.icp_s = std::min(out.fusion_s, fused.registration_ms * 1e-3);
      out.views = int(views.size());

      t0 = clk::now();
      EstimatorInput<Scalar, Camera> in;
      in.depth = fused.depth.view();
      in.votes = fused.votes.votes.empty() ? nullptr : fused.votes.votes.data();
      in.camera = &sensor_->camera();
      in.up_camera = fused.T_base_target.linear().transpose() * Vec3::UnitZ();  // kinematics, not the scene
      if (s_.crop_to_bin) in.obstacles = uncropped_.view();
      in.bin = bin_volume();
      in.T_base_camera = fused.T_base_target;
      EstimationResult<Scalar> est = estimator_->estimate(in);
      out.estimation_s = seconds_since(t0);
      if (est.status == EstimationStatus::invalid_input) {
        out.status = CycleStatus::processing_failure;
        out.error = "estimator: invalid input";
        return out;
      }

      t0 = clk::now();
      plan(fused.T_base_target, fused.depth.view(), est, out);
      out.planning_s = seconds_since(t0);
      if (s_.keep_images) {
        out.fused = std::move(fused.depth);
        out.votes = std::move(fused.votes.votes);
      }
      out.ok = true;
    } catch (const std::exception& e) {
      out.status = CycleStatus::processing_failure;
      out.error = std::string("processing: ") + e.what();
    }
    return out;
  }

  /// The bin as the settings give it.
  BinVolume<Scalar> bin_volume() const {
    BinVolume<Scalar> b;
    b.floor_center = s_.bin_center;
    b.length = s_.bin_length;
    b.width = s_.bin_width;
    b.height = s_.bin_height;
    return b;
  }

  /// The region of interest (settings.crop_to_bin), counted in the fusion's time.
  void crop(FusionResult<Scalar>& fused) const {
    const Camera& cam = sensor_->camera();
    const Pose& T = fused.T_base_target;
    const Scalar hx = s_.bin_length / 2 - s_.crop_margin, hy = s_.bin_width / 2 - s_.crop_margin;
    const Scalar z_top = s_.bin_center.z() + s_.bin_height + s_.crop_height;
    const int w = fused.depth.width(), h = fused.depth.height();
    for (int v = 0; v < h; ++v)
      for (int u = 0; u < w; ++u) {
        Scalar& z = fused.depth.data()[std::size_t(v) * std::size_t(w) + std::size_t(u)];
        if (!(z > Scalar(0)) || !std::isfinite(z)) continue;
        const Vec3 p = T * Vec3(cam.backproject(Scalar(u), Scalar(v), z)) - s_.bin_center;
        if (std::abs(p.x()) > hx || std::abs(p.y()) > hy || p.z() + s_.bin_center.z() > z_top || p.z() < s_.crop_floor) {
          z = Scalar(0);
          if (!fused.votes.votes.empty()) fused.votes.votes[std::size_t(v) * std::size_t(w) + std::size_t(u)] = 0;
        }
      }
  }

  /// Choose the object to grasp, and plan the grasp and the next sensing path (Eq. 1, Alg. 2).
  void plan(const Pose& T_base_ref, const DepthImageView<Scalar>& depth, const EstimationResult<Scalar>& est, Processed& out) {
    out.recognized = int(est.objects.size());
    std::vector<Vec3> positions;
    std::vector<Scalar> confidences;
    for (const auto& o : est.objects) {
      positions.push_back(T_base_ref * o.T_camera_object.translation());
      confidences.push_back(std::max(Scalar(0), o.confidence_percent));
    }
    out.objects_base = positions;
    // The object to grasp, among those whose grasp lies above the floor and within the tilt limit (and
    // is clear, unless grasp_blocked): the first (objects come sorted by confidence) of the best tier —
    // 0: the estimator found its grasp clear and it is away from the grips that failed since the last
    // success, 1: clear, 2: blocked; the same three again (3-5) for objects below confident_percent.
    std::size_t chosen = active_vision::no_grasped_object;
    int best_tier = 6, chosen_failures = 0;
    std::vector<std::size_t> blocked;  // skipped for a blocked grasp: what a drag may free
    for (std::size_t k = 0; k < est.objects.size() && best_tier > 0; ++k) {
      const Pose T = T_base_ref * est.objects[k].T_camera_grasp;
      if (!detail::is_rigid_finite(T)) continue;
      if (T.translation().z() - s_.bin_center.z() < s_.min_grasp_height) continue;
      if (-T.linear().col(2).z() < std::cos(s_.max_approach_tilt)) continue;
      const ToolBox<Scalar>& tool = est.objects[k].gripper == GripperKind::vacuum ? s_.cup_tool : s_.jaw_tool;
      if ((!est.objects[k].grasp_clear && !s_.grasp_blocked) || !tool_clear_of_bin(tool, T, bin_volume(), s_.tool_margin)) {
        blocked.push_back(k);
        continue;
      }
      const int failures = int(std::count_if(failed_grasps_.begin(), failed_grasps_.end(), [&](const Vec3& f) {
        return (f - T.translation()).norm() < s_.retry_distance;
      }));
      const int tier = (!est.objects[k].grasp_clear ? 2 : failures > 0 ? 1 : 0) +
                       (est.objects[k].confidence_percent < s_.confident_percent ? 3 : 0);
      if (tier < best_tier) {
        best_tier = tier;
        chosen = k;
        chosen_failures = failures;
        out.T_base_grasp = T;
      }
    }
    if (chosen != active_vision::no_grasped_object) {
      out.gripper = est.objects[chosen].gripper;
      out.grasp_clear = est.objects[chosen].grasp_clear;
    }
    if (chosen != active_vision::no_grasped_object && s_.drag_after_failures > 0 &&
        chosen_failures >= s_.drag_after_failures && best_tier % 3 != 0)
      plan_drag(T_base_ref, depth, {chosen}, positions, out, true);
    if (chosen == active_vision::no_grasped_object || out.has_drag) {
      out.has_grasp = false;
      out.status = CycleStatus::nothing_recognized;
      if (!out.has_drag) plan_drag(T_base_ref, depth, blocked, positions, out);
      if (!out.has_drag && s_.drag_unrecognized_after > 0 && searches_in_row_ + 1 >= s_.drag_unrecognized_after)
        plan_unrecognized_drag(T_base_ref, depth, positions, out);
      if (!out.has_drag && s_.look_at_unexplained && searches_in_row_ == 0)
        out.has_look = unexplained_surface(T_base_ref, depth, positions, out.look_at);
      return;
    }
    out.has_grasp = true;
    out.status = CycleStatus::picked;
    // Next pull-up point B: vertically above A at the clearance over the wall top (§III.C.2).
    const Vec3 A = out.T_base_grasp.translation();
    Pose T_B = out.T_base_grasp;
    T_B.translation().z() = std::max(A.z() + Scalar(0.02), s_.bin_center.z() + s_.bin_height + s_.lift_clearance);
    Vec3 target;
    if (s_.strategy == Strategy::random_path) {
      target = random_target();
    } else {
      // Eq. 1; when no recognized object remains, where the fused depth shows something else.
      auto tc = active_vision::target_center<Scalar>(positions, confidences, default_target(), chosen);
      Vec3 look;
      if (tc.status != active_vision::TargetCenterStatus::weighted && s_.look_at_unexplained &&
          unexplained_surface(T_base_ref, depth, positions, look))
        tc.point = look + (default_target() - s_.bin_center);
      target = tc.point;
    }
    out.next = plan_with_fallbacks(target, A, T_B);
    out.plan_status = out.next.status;
    next_B_ = T_B;
  }

  /// Baseline B's aim for every sensing path it plans: a random point of the bin floor area (not Eq. 1,
  /// nor where a drag ends).
  Vec3 random_target() {
    const Scalar u = Scalar(detail::uniform01(rng_) - 0.5), w = Scalar(detail::uniform01(rng_) - 0.5);
    return s_.bin_center + Vec3(u * s_.bin_length * Scalar(0.8), w * s_.bin_width * Scalar(0.8), Scalar(0.01));
  }

  /// A drag of the first of the `candidates` with a direction to drag it in (drag_direction; with
  /// `anyway`, drag_direction_or_centre), and the next sensing path, aimed at where the drag ends.
  /// Leaves `out` without a drag when none applies.
  void plan_drag(const Pose& T_base_ref, const DepthImageView<Scalar>& depth, const std::vector<std::size_t>& candidates,
                 const std::vector<Vec3>& positions, Processed& out, bool anyway = false) {
    if (!can_drag<Gripper>::value || drags_in_row_ >= s_.max_drags_in_row) return;
    for (const std::size_t k : candidates) {
      if (!positions[k].allFinite()) continue;
      const Vec3 away = anyway ? drag_direction_or_centre(T_base_ref, depth, positions[k], positions, k)
                               : drag_direction(T_base_ref, depth, positions[k], positions, k);
      if (away.isZero()) continue;
      set_drag(T_base_ref, depth, positions[k], away, out);
      return;
    }
  }

  /// Nothing offers a grasp or a drag for drag_unrecognized_after cycles in a row: a drag of the
  /// highest surface the fused depth shows inside the bin, along drag_direction, else (away from the
  /// walls) toward the bin centre, along +x when within drag_distance of it. The surface stands at
  /// least drag_surface_height above the floor, drag_radius + drag_wall_distance / 2 off the walls'
  /// inner faces and drag_wall_distance from every recognized object; a point counts with the median
  /// height within drag_radius of it.
  void plan_unrecognized_drag(const Pose& T_base_ref, const DepthImageView<Scalar>& depth, const std::vector<Vec3>& positions,
                              Processed& out) {
    if (!can_drag<Gripper>::value || drags_in_row_ >= s_.max_drags_in_row || depth.empty()) return;
    const Camera& cam = sensor_->camera();
    // A grid of about a third of the tool's radius (in pixels at the bin floor's depth).
    const Vec3 floor_ref = T_base_ref.inverse(Eigen::Isometry) * s_.bin_center;
    const auto c = cam.project(floor_ref), e = cam.project(Vec3(floor_ref + Vec3(s_.drag_radius, 0, 0)));
    const Scalar r_px = c && e ? (*e - *c).norm() : Scalar(3);
    const int step = std::max(1, int(std::lround(std::min(r_px, Scalar(300)) / 3)));
    const int w = (depth.width() + step - 1) / step, h = (depth.height() + step - 1) / step;
    std::vector<Scalar> height(std::size_t(w) * std::size_t(h), -std::numeric_limits<Scalar>::infinity());
    std::vector<Vec3> point(height.size(), Vec3::Zero());
    const Scalar hx = s_.bin_length / 2 - drag_wall_margin(), hy = s_.bin_width / 2 - drag_wall_margin();
    for (int j = 0; j < h; ++j)
      for (int i = 0; i < w; ++i) {
        const Scalar z = depth.depth(i * step, j * step);
        if (!(z > Scalar(0)) || !std::isfinite(z)) continue;
        const Vec3 b = T_base_ref * Vec3(cam.backproject(Scalar(i * step), Scalar(j * step), z));
        const Vec3 d = b - s_.bin_center;
        if (std::abs(d.x()) > hx || std::abs(d.y()) > hy || d.z() > s_.bin_height) continue;
        if (std::any_of(positions.begin(), positions.end(), [&](const Vec3& o) {
              return (o - b).template head<2>().norm() < s_.drag_wall_distance;
            }))
          continue;  // recognized objects have their own rules (drag_from_wall, drag_apart)
        const std::size_t k = std::size_t(j) * std::size_t(w) + std::size_t(i);
        height[k] = d.z();
        point[k] = b;
      }
    // Each grid point counts with the median height measured within the tool's radius (±3 cells):
    // the tool needs surface to press on, and a spike of noise on the floor does not make one. Shiny
    // metal leaves holes in the depth: half of the 49 cells measured is enough, and a quarter for a
    // surface drag_tall_height above the floor (the ring on top of a pencil coupler standing on end,
    // 31 mm high, fills 10-20 of them around its bore: it was never dragged; a quarter everywhere
    // dragged low surfaces that cost a mirror-nut run 3 parts).
    constexpr int r = 3, cells = (2 * r + 1) * (2 * r + 1);
    Scalar best = s_.drag_surface_height;
    std::size_t at = height.size();
    Scalar window[cells];
    for (int j = r; j + r < h; ++j)
      for (int i = r; i + r < w; ++i) {
        if (!(height[std::size_t(j) * std::size_t(w) + std::size_t(i)] > best)) continue;
        int measured = 0;
        for (int dj = -r; dj <= r; ++dj)
          for (int di = -r; di <= r; ++di) {
            const Scalar z = height[std::size_t(j + dj) * std::size_t(w) + std::size_t(i + di)];
            if (z > -std::numeric_limits<Scalar>::infinity()) window[measured++] = z;  // else a hole
          }
        if (4 * measured < cells) continue;  // under a quarter
        std::nth_element(window, window + measured / 2, window + measured);
        if (2 * measured < cells && !(window[measured / 2] >= s_.drag_tall_height)) continue;  // under half, low
        if (window[measured / 2] > best) {
          best = window[measured / 2];
          at = std::size_t(j) * std::size_t(w) + std::size_t(i);
        }
      }
    if (at == height.size()) return;
    const Vec3 p = point[at];
    set_drag(T_base_ref, depth, p, drag_direction_or_centre(T_base_ref, depth, p, positions, positions.size()), out);
  }

  /// A drag starting on the surface at p (drag_press into the highest fused depth within drag_radius)
  /// and moving drag_distance along `away` (kept off the walls), and the next sensing path, aimed at
  /// where the drag ends (random_path: at random).
  void set_drag(const Pose& T_base_ref, const DepthImageView<Scalar>& depth, const Vec3& p, const Vec3& away, Processed& out) {
    Pose T_from = Pose::Identity();
    T_from.linear() = Vec3(1, -1, -1).asDiagonal();  // the tool straight down
    T_from.translation() = p;
    T_from.translation().z() = std::max(surface_top(T_base_ref, depth, p) - s_.drag_press,
                                        s_.bin_center.z() + s_.min_grasp_height);
    // The tool stays off the walls.
    const Scalar hx = s_.bin_length / 2 - drag_wall_margin(), hy = s_.bin_width / 2 - drag_wall_margin();
    const auto end_of = [&](const Vec3& dir) {
      Vec3 e = T_from.translation() + s_.drag_distance * dir.normalized();
      e.x() = std::clamp(e.x(), s_.bin_center.x() - hx, s_.bin_center.x() + hx);
      e.y() = std::clamp(e.y(), s_.bin_center.y() - hy, s_.bin_center.y() + hy);
      return e;
    };
    Pose T_to = T_from;
    T_to.translation() = end_of(away);
    if (s_.drag_clearance > 0 && !drag_ends_clear(T_base_ref, depth, p, T_to.translation()))
      for (const Scalar turn : {Scalar(M_PI / 6), Scalar(-M_PI / 6), Scalar(M_PI / 3), Scalar(-M_PI / 3)}) {
        const Vec3 e = end_of(Eigen::AngleAxis<Scalar>(turn, Vec3::UnitZ()) * away);
        if (!drag_ends_clear(T_base_ref, depth, p, e)) continue;
        T_to.translation() = e;
        break;
      }
    out.has_drag = true;
    out.T_base_drag_from = T_from;
    out.T_base_drag_to = T_to;
    Pose T_B = T_to;
    T_B.translation().z() = s_.bin_center.z() + s_.bin_height + s_.lift_clearance;
    out.next = plan_with_fallbacks(s_.strategy == Strategy::random_path ? random_target() : T_to.translation(),
                                   T_to.translation(), T_B);
    out.plan_status = out.next.status;
    next_B_ = T_B;
  }

  /// Whether a drag from p to `end` ends clear of other parts (drag_clearance).
  bool drag_ends_clear(const Pose& T_base_ref, const DepthImageView<Scalar>& depth, const Vec3& p, const Vec3& end) const {
    int surface = 0;
    for_each_point_near(T_base_ref, depth, end, s_.drag_clearance, [&](const Vec3& b) {
      const Scalar to_end = (b - end).template head<2>().norm(), to_start = (b - p).template head<2>().norm();
      surface += to_end < s_.drag_clearance && !(to_start < s_.drag_clearance) &&
                 b.z() - s_.bin_center.z() > s_.drag_surface_height;
    });
    // Fewer points are strays. At the ends the 16 drags of binpick_sim ours (mirror nuts, 1280 x 1024,
    // seeds 5 and 6) tried, a count was 0 or else 7, 24 or 69: polished parts leaning on others show
    // few points.
    return surface < 3;
  }

  /// Where to drag what lies at p (base frame, horizontal; zero: nowhere): off the walls whose inner
  /// face lies within drag_wall_distance (drag_from_wall; from both at a corner), else (drag_apart)
  /// away from the nearest recognized object within drag_wall_distance (`positions` but the k-th, the
  /// one at p if any), else away from the surface piled around it (pile_side).
  Vec3 drag_direction(const Pose& T_base_ref, const DepthImageView<Scalar>& depth, const Vec3& p,
                      const std::vector<Vec3>& positions, std::size_t k) const {
    const Vec3 off = off_walls(p);
    if (!off.isZero()) return s_.drag_from_wall ? off : Vec3::Zero();
    if (!s_.drag_apart) return Vec3::Zero();
    Scalar nearest = s_.drag_wall_distance;
    Vec3 away = Vec3::Zero();
    for (std::size_t j = 0; j < positions.size(); ++j) {
      const Vec3 e = p - positions[j];
      const Scalar dist = e.template head<2>().norm();
      if (j == k || !(dist < nearest) || !(dist > Scalar(1e-3))) continue;
      nearest = dist;
      away = Vec3(e.x(), e.y(), 0);
    }
    return away.isZero() ? -pile_side(T_base_ref, depth, p) : away;
  }

  /// drag_direction, else, away from the walls, toward the bin centre (along +x within drag_distance
  /// of it): for a drag that must move the part although the depth shows nothing to drag it away from
  /// (a part alone, or beside a neighbour the sensor misses; moving it is what changes the situation).
  Vec3 drag_direction_or_centre(const Pose& T_base_ref, const DepthImageView<Scalar>& depth, const Vec3& p,
                                const std::vector<Vec3>& positions, std::size_t k) const {
    const Vec3 away = drag_direction(T_base_ref, depth, p, positions, k);
    if (!away.isZero() || !off_walls(p).isZero()) return away;
    const Vec3 to_centre(s_.bin_center.x() - p.x(), s_.bin_center.y() - p.y(), Scalar(0));
    return to_centre.norm() > s_.drag_distance ? to_centre : Vec3::UnitX();
  }

  /// Off the walls whose inner face lies within drag_wall_distance of p (horizontally; from both at a
  /// corner, not normalized); zero when p is near none.
  Vec3 off_walls(const Vec3& p) const {
    const Vec3 d = p - s_.bin_center;
    const auto off = [&](Scalar half, Scalar x) {
      return half - std::abs(x) < s_.drag_wall_distance ? (x > 0 ? Scalar(-1) : Scalar(1)) : Scalar(0);
    };
    return Vec3(off(s_.bin_length / 2, d.x()), off(s_.bin_width / 2, d.y()), Scalar(0));
  }

  /// How far off the walls' inner faces a drag ends or starts unrecognized (set_drag,
  /// plan_unrecognized_drag) [m]: a stereo sensor fattens the wall tops inward.
  Scalar drag_wall_margin() const { return s_.drag_radius + s_.drag_wall_distance / 2; }

  /// The floor point (base frame) below the densest patch of surface in `depth` (view at T_base_ref)
  /// that no recognized object (`positions`) explains (look_at_unexplained); false when no patch
  /// holds look_min_area. Points are counted with their footprint on a grid of look_radius cells; a
  /// patch is a cell with its 8 neighbours, and its point is the mean of their points.
  bool unexplained_surface(const Pose& T_base_ref, const DepthImageView<Scalar>& depth, const std::vector<Vec3>& positions,
                           Vec3& floor_point) const {
    if (depth.empty()) return false;  // look_radius >= 1 mm: validated
    const Camera& cam = sensor_->camera();
    const int step = std::max(1, depth.width() / 320);  // about 320 samples per row: well under a millisecond
    const int gx = std::max(1, int(std::ceil(s_.bin_length / s_.look_radius))), gy = std::max(1, int(std::ceil(s_.bin_width / s_.look_radius)));
    std::vector<Scalar> area(std::size_t(gx) * std::size_t(gy), Scalar(0));
    std::vector<Vector2<Scalar>> sum(area.size(), Vector2<Scalar>::Zero());
    const Scalar hx = s_.bin_length / 2, hy = s_.bin_width / 2;
    const Scalar wx = hx - s_.look_wall_band, wy = hy - s_.look_wall_band;
    for (int v = 0; v < depth.height(); v += step)
      for (int u = 0; u < depth.width(); u += step) {
        const Scalar z = depth.depth(u, v);
        if (!(z > Scalar(0)) || !std::isfinite(z)) continue;
        const Vec3 c = cam.backproject(Scalar(u), Scalar(v), z);
        const Vec3 d = T_base_ref * c - s_.bin_center;
        if (!d.allFinite() || std::abs(d.x()) >= wx || std::abs(d.y()) >= wy) continue;
        if (d.z() < s_.drag_surface_height || d.z() > s_.bin_height / 2) continue;
        const Vector2<Scalar> xy = d.template head<2>();
        if (std::any_of(positions.begin(), positions.end(), [&](const Vec3& o) {
              return (o.template head<2>() - s_.bin_center.template head<2>() - xy).norm() < s_.look_radius;
            }))
          continue;
        const int i = std::clamp(int((xy.x() + hx) / s_.look_radius), 0, gx - 1), j = std::clamp(int((xy.y() + hy) / s_.look_radius), 0, gy - 1);
        const Scalar side = (Vec3(cam.backproject(Scalar(u + step), Scalar(v), z)) - c).norm();  // the sample's footprint
        area[std::size_t(j) * std::size_t(gx) + std::size_t(i)] += side * side;
        sum[std::size_t(j) * std::size_t(gx) + std::size_t(i)] += side * side * xy;
      }
    Scalar best = s_.look_min_area;
    Vector2<Scalar> at = Vector2<Scalar>::Zero();
    bool found = false;
    for (int j = 0; j < gy; ++j)
      for (int i = 0; i < gx; ++i) {
        Scalar a = 0;
        Vector2<Scalar> m = Vector2<Scalar>::Zero();
        for (int dj = -1; dj <= 1; ++dj)
          for (int di = -1; di <= 1; ++di) {
            if (i + di < 0 || j + dj < 0 || i + di >= gx || j + dj >= gy) continue;
            a += area[std::size_t(j + dj) * std::size_t(gx) + std::size_t(i + di)];
            m += sum[std::size_t(j + dj) * std::size_t(gx) + std::size_t(i + di)];
          }
        if (a > Scalar(0) && a >= best) {
          best = a;
          at = m / a;
          found = true;
        }
      }
    if (found) floor_point = s_.bin_center + Vec3(at.x(), at.y(), Scalar(0));
    return found;
  }

  /// The side of p where the surface of `depth` (view at T_base_ref) piles up: the mean horizontal
  /// direction from p to its points within drag_wall_distance, each weighted by its height above the
  /// bin floor (unit length; zero when the weights balance to within a tenth, as around a part lying
  /// alone, whose own points surround its centre, or when the depth shows nothing there).
  Vec3 pile_side(const Pose& T_base_ref, const DepthImageView<Scalar>& depth, const Vec3& p) const {
    Vec3 sum = Vec3::Zero();
    Scalar total = 0;
    for_each_point_near(T_base_ref, depth, p, s_.drag_wall_distance, [&](const Vec3& b) {
      const Vec3 e(b.x() - p.x(), b.y() - p.y(), Scalar(0));
      const Scalar w = std::max(b.z() - s_.bin_center.z(), Scalar(0)), n = e.norm();
      if (!(n > Scalar(1e-4))) return;
      sum += w / n * e;
      total += w;
    });
    return total > Scalar(0) && sum.norm() >= Scalar(0.1) * total ? Vec3(sum.normalized()) : Vec3::Zero();
  }

  /// Calls f(b) for every point b of `depth` (view at T_base_ref; base frame) within `radius` of p
  /// horizontally.
  template <typename F>
  void for_each_point_near(const Pose& T_base_ref, const DepthImageView<Scalar>& depth, const Vec3& p, Scalar radius,
                           F&& f) const {
    const Camera& cam = sensor_->camera();
    const Vec3 q = T_base_ref.inverse(Eigen::Isometry) * p;
    const auto c = cam.project(q), e = cam.project(Vec3(q + Vec3(radius, 0, 0)));
    if (!c || !e || depth.empty()) return;
    const int r = int(std::ceil(std::min((*e - *c).norm(), Scalar(256)))) + 1;
    const int u0 = int(std::lround(c->x())), v0 = int(std::lround(c->y()));
    for (int v = std::max(0, v0 - r); v <= std::min(depth.height() - 1, v0 + r); ++v)
      for (int u = std::max(0, u0 - r); u <= std::min(depth.width() - 1, u0 + r); ++u) {
        const Scalar z = depth.depth(u, v);
        if (!(z > Scalar(0)) || !std::isfinite(z)) continue;
        const Vec3 b = T_base_ref * Vec3(cam.backproject(Scalar(u), Scalar(v), z));
        if ((b - p).template head<2>().norm() <= radius) f(b);
      }
  }

  /// The highest point of `depth` (view at T_base_ref) within drag_radius of p horizontally, base z;
  /// p's own z when the depth shows nothing there.
  Scalar surface_top(const Pose& T_base_ref, const DepthImageView<Scalar>& depth, const Vec3& p) const {
    Scalar top = p.z();
    bool found = false;
    for_each_point_near(T_base_ref, depth, p, s_.drag_radius, [&](const Vec3& b) {
      top = found ? std::max(top, b.z()) : b.z();
      found = true;
    });
    return top;
  }

  /// The next sensing path after the `failures`-th failed grip in a row: the planned one (same target,
  /// same B) with its arc turned about the vertical through B — half a turn from the drop side first,
  /// then a quarter turn either way, then the drop side again. With nothing in hand the arc need not
  /// lead toward C, and the views that gave a wrong pose are not taken again from the same side (the
  /// same fused depth gives the same pose). Falls back to `planned` when Alg. 2 finds no such arc.
  Plan relook(const Plan& planned, const Vec3& A, std::size_t failures) const {
    if (planned.T_base_cameras.empty() || failures == 0) return planned;
    const Scalar turns[4] = {Scalar(M_PI), Scalar(M_PI / 2), Scalar(-M_PI / 2), Scalar(0)};
    const Vec3 B = next_B_.translation();
    Vec3 to_drop = s_.T_base_drop.translation() - B;
    to_drop.z() = 0;
    if (!(to_drop.norm() > Scalar(1e-3))) return planned;
    const Vec3 sweep_to = B + Eigen::AngleAxis<Scalar>(turns[(failures - 1) % 4], Vec3::UnitZ()) * to_drop;
    const Plan p = arc_plan(planned.target, A, next_B_, beta_, planned.source, &sweep_to);
    return p.T_base_cameras.empty() ? planned : p;
  }

  /// Records the processing stages from `t_start` and returns the Clock time processing ends.
  double record_processing(const Processed& p, double t_start, std::size_t n, Timeline& tl, CycleResult<Scalar>& r) const {
    double t = t_start;
    auto stage = [&](const char* name, double d, bool measured) {
      tl.add(name, Lane::processing, t, t + d, measured);
      t += d;
    };
    if (s_.model_hardware_time) {
      stage("transfer", s_.takt.transfer * double(n), false);
      stage("stereo depth", s_.takt.stereo_depth * double(n), false);
    } else if (s_.fixed_compute_time < 0) {
      stage("transfer", p.read_s, true);
    }
    if (s_.fixed_compute_time >= 0) {
      stage("compute (fixed)", s_.fixed_compute_time, false);
    } else {
      stage("ICP", p.icp_s, true);  // registration of views 2..n comes first in the fusion
      stage("fusion", p.fusion_s - p.icp_s, true);
      stage("estimation", p.estimation_s, true);
      stage("planning", p.planning_s, true);
    }
    r.fusion_ms = p.fusion_s * 1e3;
    r.icp_ms = p.icp_s * 1e3;
    r.estimation_ms = p.estimation_s * 1e3;
    r.planning_ms = p.planning_s * 1e3;
    r.takt.processing = t - t_start;
    r.takt.processing_compute = p.fusion_s + p.estimation_s + p.planning_s;
    return t;
  }

  void take_processed(Processed& p, CycleResult<Scalar>& r) {
    r.views = p.views;
    r.recognized = p.recognized;
    r.objects_base = p.objects_base;
    r.next_plan_status = p.plan_status;
    if (p.has_grasp) {
      r.T_base_grasp = p.T_base_grasp;
      r.grasp_clear = p.grasp_clear;
    }
    if (s_.keep_images) {
      r.fused_depth = std::move(p.fused);
      r.votes = std::move(p.votes);
    }
  }

  /// After processing: grasp (or search) and end at the next pull-up point.
  void finish(Processed& p, CycleResult<Scalar>& r, Timeline& tl) {
    if (!p.ok) throw CycleFailure(p.status, p.error);
    if (!p.has_grasp) {
      if (p.has_drag && drag(p, r, tl)) return;
      ++searches_;
      Plan look;
      if (p.has_look) look = search_from_above(p.look_at, std::min(Scalar(M_PI / 2), beta_ * s_.search_beta_factor), true);
      next_ = !look.T_base_cameras.empty() ? look : searches_in_turn_[std::size_t(searches_in_row_) % searches_in_turn_.size()];
      ++searches_in_row_;
      move({T_home_}, s_.motion_speed_percent, "to home (search)", tl);
      r.status = CycleStatus::nothing_recognized;
      return;
    }
    Pose pre = p.T_base_grasp;
    pre.translation() -= s_.approach_distance * p.T_base_grasp.linear().col(2);
    const double t_appr0 = clock_->now();
    move({pre}, s_.motion_speed_percent, "approach", tl);
    approach_time_ = clock_->now() - t_appr0;
    approach_from_ = pre;
    move({p.T_base_grasp}, s_.grasp_speed_percent, "grasp", tl);
    bool held = false;
    try {
      held = gripper_->grip(cast_robot(p.T_base_grasp), p.gripper);
    } catch (const std::exception& e) {
      throw CycleFailure(CycleStatus::robot_failure, std::string("gripper: ") + e.what());
    }
    move({pre, next_B_}, s_.motion_speed_percent, "lift A->B", tl);
    searches_in_row_ = 0;
    drags_in_row_ = 0;
    holding_ = held;
    const Vec3 at = p.T_base_grasp.translation();
    if (held) {
      failed_grasps_.erase(std::remove_if(failed_grasps_.begin(), failed_grasps_.end(),
                                          [&](const Vec3& f) { return !((f - at).norm() > s_.forget_distance); }),
                           failed_grasps_.end());
      failures_in_row_ = 0;
    } else {
      if (failed_grasps_.size() == kMaxRememberedFailures) failed_grasps_.erase(failed_grasps_.begin());
      failed_grasps_.push_back(at);
      ++failures_in_row_;
    }
    next_ = held || !s_.relook || s_.strategy == Strategy::random_path ? p.next : relook(p.next, at, failures_in_row_);
    r.status = held ? CycleStatus::picked : CycleStatus::grasp_failed;
  }

  /// The drag planned by plan_drag: above its start at the pull-up height, the tool closed, pressed,
  /// dragged, lifted to the next pull-up point. False when the gripper declines (then the caller searches).
  bool drag(const Processed& p, CycleResult<Scalar>& r, Timeline& tl) {
    bool ready = false;
    if constexpr (can_drag<Gripper>::value) {
      try {
        ready = gripper_->prepare_drag(cast_robot(p.T_base_drag_from), cast_robot(p.T_base_drag_to));
      } catch (const std::exception& e) {
        throw CycleFailure(CycleStatus::robot_failure, std::string("gripper: ") + e.what());
      }
    }
    if (!ready) return false;
    Pose above = p.T_base_drag_from;
    above.translation().z() = next_B_.translation().z();
    move({above}, s_.motion_speed_percent, "to drag", tl);
    move({p.T_base_drag_from}, s_.grasp_speed_percent, "press", tl);
    move({p.T_base_drag_to}, s_.grasp_speed_percent, "drag", tl);
    move({next_B_}, s_.motion_speed_percent, "lift after drag", tl);
    ++drags_in_row_;
    next_ = p.next;
    r.dragged = true;
    r.status = CycleStatus::nothing_recognized;
    return true;
  }

  void run_nonstop(CycleResult<Scalar>& r) {
    Timeline& tl = r.timeline;
    const double t_start = clock_->now();
    const Pose T_B = T_at_;
    const bool holding_at_start = holding_;
    Plan plan = next_;
    r.path_source = plan.source;
    r.search = plan.source == PathSource::search;
    r.target = plan.target;
    r.pull_up = camera_of_flange(T_B).translation();
    r.T_base_captures_planned = plan.T_base_cameras;

    // Data collection: B→M, stop, view 1 (exact), arc M→N with views 2..n at interval t (late reads).
    Capture cap;
    const Scalar v = s_.sensing_speed_percent;
    move({flange_of_camera(plan.T_base_cameras[0])}, v, "sensing B->M", tl);
    const double t_stop = clock_->now();
    capture(cap, tl);
    clock_->sleep_until(t_stop + s_.stop_time);
    tl.add("stop M (view 1)", Lane::robot, t_stop, clock_->now());
    if (n_ >= 2) {
      std::vector<Pose> arc;
      for (int i = 1; i < n_; ++i) arc.push_back(flange_of_camera(plan.T_base_cameras[std::size_t(i)]));
      const double t0 = clock_->now();
      std::vector<Isometry3<RobotScalar>> rp;
      for (const auto& p : arc) rp.push_back(cast_robot(p));
      double arrival = 0;
      try {
        arrival = robot_->move_along(rp, RobotScalar(v));
      } catch (...) {
        drain();
        throw;
      }
      // Triggers every t; when the arc takes longer than (n - 1)·t (a wider search arc, or the wrist
      // turn dominating), the triggers are spread over the whole arc instead so views stay on their poses.
      const double step = std::max(s_.interval, (arrival - t0) / double(n_ - 1));
      try {
        for (int i = 1; i < n_; ++i) {
          clock_->sleep_until(t0 + double(i) * step);
          capture(cap, tl);
        }
      } catch (...) {
        clock_->sleep_until(arrival);
        drain();
        throw;
      }
      clock_->sleep_until(arrival);
      tl.add("sensing M->N", Lane::robot, t0, clock_->now());
      T_at_ = arc.back();
    }
    r.T_base_captures_read = cap.T_base_cameras_read;
    const double t_collect_end = cap.trigger_times.back() + s_.takt.exposure;

    // Data processing in a worker thread while the robot drops the part (N→C).
    const std::size_t triggered = cap.trigger_times.size();
    Processed p;
    worker_.start([this, &cap, triggered, &p] { p = process(cap, triggered); });
    double t_place_end = clock_->now();
    if (holding_at_start) {
      try {
        t_place_end = move({s_.T_base_drop}, s_.motion_speed_percent, "drop N->C", tl);
        gripper_->release();
        holding_ = false;
        r.placed = true;
      } catch (...) {
        try {  // never leave the job running; the drop's failure is the one reported
          worker_.wait();
        } catch (...) {
        }
        drain();
        throw;
      }
    }
    worker_.wait();
    const double t_ready = record_processing(p, t_collect_end, triggered, tl, r);
    take_processed(p, r);
    const double t_wait0 = clock_->now();
    clock_->sleep_until(t_ready);
    if (clock_->now() > t_wait0) tl.add("wait for processing", Lane::robot, t_wait0, clock_->now());
    r.takt.robot_wait = clock_->now() - t_wait0;
    r.takt.detour = holding_at_start ? std::max(0.0, (t_place_end - t_start) - move_time(T_B, s_.T_base_drop, s_.motion_speed_percent))
                                     : (t_place_end - t_start);
    finish(p, r, tl);
    r.takt.cycle_time = clock_->now() - t_start;
  }

  void run_stop_and_go(CycleResult<Scalar>& r) {
    Timeline& tl = r.timeline;
    const double t_start = clock_->now();
    const Pose T_B = T_at_;
    r.path_source = PathSource::fixed_views;
    r.target = predefined_.target;
    r.pull_up = camera_of_flange(T_B).translation();
    r.T_base_captures_planned = predefined_.T_base_cameras;
    double t_c = t_start;
    if (holding_) {  // conventional order: place first (direct B→C)
      t_c = move({s_.T_base_drop}, s_.motion_speed_percent, "drop B->C", tl);
      gripper_->release();
      holding_ = false;
      r.placed = true;
    }
    const Pose T_from = T_at_;
    // Approach: stop at each predefined view, trigger at rest (exact pose).
    Capture cap;
    try {
      for (int i = 0; i < n_; ++i) {
        move({flange_of_camera(predefined_.T_base_cameras[std::size_t(i)])}, s_.motion_speed_percent,
             "to view " + std::to_string(i + 1), tl);
        const double t_stop = clock_->now();
        capture(cap, tl);
        clock_->sleep_until(t_stop + s_.stop_time);
        tl.add("stop view " + std::to_string(i + 1), Lane::robot, t_stop, clock_->now());
      }
    } catch (...) {
      drain();
      throw;
    }
    r.T_base_captures_read = cap.T_base_cameras_read;
    const double t_views_end = clock_->now();
    // Serial processing while the robot stands.
    Processed p = process(cap, cap.trigger_times.size());
    const double t_ready = record_processing(p, t_views_end, cap.trigger_times.size(), tl, r);
    take_processed(p, r);
    clock_->sleep_until(t_ready);
    tl.add("wait for processing", Lane::robot, t_views_end, clock_->now());
    r.takt.robot_wait = clock_->now() - t_views_end;
    finish(p, r, tl);
    // Sensing cost: the way through the views plus the way from the last view to the pre-grasp pose,
    // beyond the direct move from where the views started to the pre-grasp pose.
    const double direct = p.has_grasp ? move_time(T_from, approach_from_, s_.motion_speed_percent) : 0.0;
    const double via_views = (t_views_end - t_c) + (p.has_grasp ? approach_time_ : 0.0);
    r.takt.detour = std::max(0.0, via_views - direct);
    r.takt.cycle_time = clock_->now() - t_start;
  }

  /// Leave the cell consistent after a failure (file comment).
  void fail(CycleResult<Scalar>& r, CycleStatus status, const std::string& what) {
    r.status = status;
    r.error = what;
    drain();
    next_ = predefined_;
    try {
      for (int i = 0; i < 6000 && robot_->is_moving(); ++i) clock_->sleep_until(clock_->now() + 0.01);
      move({T_home_}, s_.motion_speed_percent, "to home (recover)", r.timeline);
    } catch (const std::exception& e) {
      r.error += std::string("; robot: return to home failed: ") + e.what();
    }
  }

  void drain() {
    try {
      if (sensor_->frames_in_memory() > 0) sensor_->read_frames();
    } catch (...) {
    }
  }

  Robot* robot_;
  Sensor* sensor_;
  Estimator* estimator_;
  Clock* clock_;
  Gripper* gripper_;
  PipelineSettings<Scalar> s_;
  Fuser<Scalar, Camera> fuser_;
  FusionResult<Scalar> fused_;  // the worker's last fusion (its buffers serve the next)
  DepthImage<Scalar> uncropped_;  // its depth before the crop (kept across cycles too)
  detail::WorkerThread worker_;  // runs process() of run_nonstop
  std::uint64_t rng_;
  int n_ = 1;
  Scalar beta_ = 0;
  Pose T_home_ = Pose::Identity();
  Pose T_at_ = Pose::Identity();   // flange pose the robot stands at between cycles
  Pose next_B_ = Pose::Identity();
  Pose approach_from_ = Pose::Identity();
  double approach_time_ = 0;
  Plan predefined_, next_;
  // Grasp points of the failed grips not forgotten by a success near them (forget_distance), the
  // oldest dropped beyond kMaxRememberedFailures; and the failed grips since the last success (relook).
  static constexpr std::size_t kMaxRememberedFailures = 32;
  std::vector<Vec3> failed_grasps_;
  std::size_t failures_in_row_ = 0;
  bool first_ = true;
  bool holding_ = false;
  int cycles_ = 0;
  int searches_ = 0;
  int searches_in_row_ = 0;  ///< searches since the last grasp
  int drags_in_row_ = 0;     ///< drags since the last grasp
  std::vector<Plan> searches_in_turn_;  ///< search_plans()
};

// The constructor and run_cycle() are defined out of the class so that they are not inline: an explicit
// instantiation declaration (`extern template class PickingPipeline<...>;`) then keeps every translation
// unit that includes it from instantiating the whole cycle (fusion, ICP, estimation, planning) again.
template <typename Robot, typename Sensor, typename Estimator, typename Clock, typename Gripper>
PickingPipeline<Robot, Sensor, Estimator, Clock, Gripper>::PickingPipeline(Robot& robot, Sensor& sensor, Estimator& estimator,
                                                                           Clock& clock, Gripper& gripper,
                                                                           const PipelineSettings<Scalar>& settings)
    : robot_(&robot), sensor_(&sensor), estimator_(&estimator), clock_(&clock), gripper_(&gripper), s_(settings),
      fuser_(sensor.camera()), rng_(settings.seed) {
  const auto& s = settings;
  require(s.num_views >= 1 && s.num_views <= 64, "num_views", "must be in [1, 64]");
  require(std::isfinite(s.interval) && s.interval > 0, "interval", "must be finite and > 0");
  for (Scalar p : {s.sensing_speed_percent, s.motion_speed_percent, s.grasp_speed_percent})
    require(std::isfinite(p) && p > 0 && p <= 100, "speed_percent", "speeds must be in (0, 100]");
  require(std::isfinite(s.full_speed) && s.full_speed > 0, "full_speed", "must be finite and > 0");
  require(std::isfinite(s.full_angular_speed) && s.full_angular_speed > 0, "full_angular_speed", "must be finite and > 0");
  require(std::isfinite(s.working_distance) && s.working_distance > 0, "working_distance", "must be finite and > 0");
  require(std::isfinite(s.search_beta_factor) && s.search_beta_factor >= 1, "search_beta_factor", "must be >= 1");
  require(std::isfinite(s.stop_time) && s.stop_time >= 0, "stop_time", "must be finite and >= 0");
  require(std::isfinite(s.fixed_compute_time), "fixed_compute_time", "must be finite (< 0: measured)");
  require(std::isfinite(s.max_stamp_offset) && s.max_stamp_offset > 0, "max_stamp_offset", "must be finite and > 0");
  require(std::isfinite(s.lift_clearance) && s.lift_clearance >= 0, "lift_clearance", "must be finite and >= 0");
  require(std::isfinite(s.approach_distance) && s.approach_distance >= 0, "approach_distance", "must be finite and >= 0");
  require(std::isfinite(s.crop_floor) && s.crop_floor >= 0, "crop_floor", "must be finite and >= 0");
  require(std::isfinite(s.tool_margin) && s.tool_margin >= 0, "tool_margin", "must be finite and >= 0");
  for (Scalar d : {s.drag_wall_distance, s.drag_distance, s.drag_press, s.drag_radius})
    require(std::isfinite(d) && d >= 0, "drag_distance", "drag_wall_distance, drag_distance, drag_press and drag_radius must be finite and >= 0");
  require(std::isfinite(s.drag_clearance) && s.drag_clearance >= 0, "drag_clearance", "must be finite and >= 0");
  require(s.max_drags_in_row >= 0, "max_drags_in_row", "must be >= 0");
  require(s.drag_after_failures >= 0, "drag_after_failures", "must be >= 0");
  require(s.drag_unrecognized_after >= 0, "drag_unrecognized_after", "must be >= 0");
  require(std::isfinite(s.drag_surface_height), "drag_surface_height", "must be finite");
  require(std::isfinite(s.drag_tall_height), "drag_tall_height", "must be finite");
  require(std::isfinite(s.look_radius) && s.look_radius >= Scalar(0.001), "look_radius",
          "must be finite and >= 0.001 m (the grid of look_radius cells covers the bin)");
  require(std::isfinite(s.look_min_area) && s.look_min_area >= 0, "look_min_area", "must be finite and >= 0");
  require(std::isfinite(s.look_wall_band) && s.look_wall_band >= 0, "look_wall_band", "must be finite and >= 0");
  require(s.jaw_tool.lo.allFinite() && s.jaw_tool.hi.allFinite(), "jaw_tool", "must be finite");
  require(s.cup_tool.lo.allFinite() && s.cup_tool.hi.allFinite(), "cup_tool", "must be finite");
  require(std::isfinite(s.min_grasp_height), "min_grasp_height", "must be finite");
  require(std::isfinite(s.retry_distance) && s.retry_distance >= 0, "retry_distance", "must be finite and >= 0");
  require(s.forget_distance >= 0, "forget_distance", "must be >= 0 (infinity: a success forgets every failure)");
  require(std::isfinite(s.confident_percent) && s.confident_percent >= 0 && s.confident_percent <= 100, "confident_percent",
          "must be in [0, 100]");
  require(s.bin_length > 0 && s.bin_width > 0 && s.bin_height > 0, "bin_length", "bin sizes must be > 0");
  require_all_finite(s.bin_center, "bin_center");
  require_valid_pose(s.T_flange_camera, "T_flange_camera");
  require_valid_pose(s.T_base_drop, "T_base_drop");
  sensing_scheme_time(1, s.interval, s.takt);  // validates the takt constants
  if (s.strategy == Strategy::single_view) s_.num_views = 1;
  // B differs from ours only in where its sensing paths aim: looking at surface no object explains is
  // an aim of active vision.
  if (s.strategy == Strategy::random_path) s_.look_at_unexplained = false;
  n_ = s_.num_views;
  beta_ = beta_from_motion(n_);
  T_home_ = Pose::Identity();
  T_home_.linear() = Eigen::AngleAxis<Scalar>(Scalar(M_PI), Vec3::UnitX()).toRotationMatrix();
  T_home_.translation() = s_.bin_center + Vec3(0, 0, s_.bin_height + s_.lift_clearance);
  predefined_ = home_path(beta_, PathSource::predefined);
  require(!predefined_.T_base_cameras.empty(), "settings", "the cell layout admits no predefined sensing path");
  searches_in_turn_ = search_plans();
  next_ = predefined_;
}

template <typename Robot, typename Sensor, typename Estimator, typename Clock, typename Gripper>
CycleResult<typename Sensor::Scalar> PickingPipeline<Robot, Sensor, Estimator, Clock, Gripper>::run_cycle() {
  CycleResult<Scalar> r;
  r.index = cycles_++;
  r.drop = s_.T_base_drop.translation();
  try {
    if (first_) {
      // Bring the robot to the home point (not part of any cycle's takt).
      const double arrival = robot_->move_along({cast_robot(T_home_)}, RobotScalar(s_.motion_speed_percent));
      clock_->sleep_until(arrival);
      first_ = false;
      T_at_ = T_home_;
    }
    if (s_.strategy == Strategy::stop_and_go)
      run_stop_and_go(r);
    else
      run_nonstop(r);
  } catch (const CycleFailure& f) {
    fail(r, f.status, f.what());
  } catch (const std::exception& e) {
    fail(r, CycleStatus::robot_failure, std::string("robot: ") + e.what());
  }
  return r;
}

}  // namespace binpick::cycle
