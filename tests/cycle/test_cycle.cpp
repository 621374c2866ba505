// The picking cycle: Table I / Eq. 2, the timeline, and the pipeline of Fig. 2 in the simulated cell —
// a small pile emptied, processing overlapping the drop, driver failures ending a cycle cleanly, and
// the strategies compared on a fixed seed.
#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <future>
#include <limits>
#include <memory>
#include <stdexcept>
#include <thread>

#include "binpick/cycle.hpp"
#include "binpick/sim.hpp"
#include "sim_cell.hpp"
#include "test_support.hpp"

using namespace binpick;
using S = float;
using Camera = PinholeCamera<S>;

// ---------------------------------------------------------------------------------------------------
// Table I / Eq. 2

TEST(Takt, PaperMaximumIs1682ms) {
  EXPECT_NEAR(cycle::sensing_scheme_total(4, 0.030), 1.682, 1e-9);
  const auto t = cycle::sensing_scheme_time(4, 0.030);
  EXPECT_NEAR(t.images, 0.372 + 0.090, 1e-12);  // 3n + 90n + t(n-1)
  EXPECT_NEAR(t.kinematics, 0.080, 1e-12);
  EXPECT_NEAR(t.depth_3d, 0.920, 1e-12);
}

RC_GTEST_PROP(Takt, Eq2HoldsForAnyViewsAndInterval, ()) {
  const int n = *rc::gen::inRange(1, 11);
  const double t = *rc::gen::inRange(0, 81) * 1e-3;
  RC_ASSERT(std::abs(cycle::sensing_scheme_total(n, t) - (0.343 * n + t * (n - 1) + 0.220)) < 1e-9);
}

TEST(Takt, EveryConstantIsASetting) {
  cycle::TaktSettings s;
  s.stereo_depth = 0;
  s.fusion_per_view = 0;
  EXPECT_NEAR(cycle::sensing_scheme_total(4, 0.030, s), 1.682 - 4 * 0.230, 1e-9);
  EXPECT_THROW(cycle::sensing_scheme_total(0, 0.03), std::invalid_argument);
  EXPECT_THROW(cycle::sensing_scheme_total(2, -1), std::invalid_argument);
  s.estimation = -1;
  EXPECT_THROW(cycle::sensing_scheme_total(2, 0.03, s), std::invalid_argument);
}

TEST(Timeline, TotalsAndOverlap) {
  cycle::Timeline tl;
  tl.add("drop N->C", cycle::Lane::robot, 1.0, 2.0);
  tl.add("fusion+ICP", cycle::Lane::processing, 1.5, 1.7, true);
  tl.add("estimation", cycle::Lane::processing, 1.7, 2.5, true);
  EXPECT_NEAR(tl.total(cycle::Lane::processing), 1.0, 1e-12);
  EXPECT_NEAR(tl.overlap("drop N->C", cycle::Lane::processing), 0.5, 1e-12);
  EXPECT_NEAR(tl.begin(), 1.0, 0);
  EXPECT_NEAR(tl.end(), 2.5, 0);
  tl.add("backwards", cycle::Lane::robot, 3.0, 2.0);
  EXPECT_EQ(tl.find("backwards")->duration(), 0.0);
  EXPECT_THROW(tl.add("nan", cycle::Lane::robot, std::nan(""), 1.0), std::invalid_argument);
}

// ---------------------------------------------------------------------------------------------------
// The pipeline in the simulated cell, with drivers that can fail on demand.

namespace {

// Forwards to the fake sensor; can lose the last frame of a read or throw on a trigger. Remembers the
// true camera pose of the first frame after a read (for the oracle estimator of the mechanics tests).
struct TestSensor {
  using Scalar = S;
  using Camera = ::Camera;
  sim::FakeSensor<S>* inner;
  const sim::FakeRobot<S>* robot;
  Isometry3<S> T_flange_camera;
  bool lose_frame = false, throw_on_trigger = false;
  bool first_pending = true;
  Isometry3<S> T_base_view1 = Isometry3<S>::Identity();
  const Camera& camera() const { return inner->camera(); }
  S accuracy() const { return inner->accuracy(); }
  double trigger() {
    if (throw_on_trigger) throw std::runtime_error("no trigger acknowledge");
    const double t = inner->trigger();
    if (first_pending) T_base_view1 = robot->true_flange_pose(t) * T_flange_camera, first_pending = false;
    return t;
  }
  std::size_t frames_in_memory() const { return inner->frames_in_memory(); }
  std::vector<cycle::DepthFrame<S>> read_frames() {
    auto f = inner->read_frames();
    first_pending = true;
    if (lose_frame && !f.empty()) f.pop_back();
    return f;
  }
};
static_assert(cycle::is_sensor_driver<TestSensor>::value, "TestSensor models SensorDriver");

// Forwards to the fake robot; the n-th pose read (counting from 1) can throw or return garbage.
struct TestRobot {
  using Scalar = S;
  sim::FakeRobot<S>* inner;
  int fail_read = 0, reads = 0;
  bool garbage = false;
  double move_along(const std::vector<Isometry3<S>>& p, S v) { return inner->move_along(p, v); }
  bool is_moving() const { return inner->is_moving(); }
  cycle::StampedPose<S> read_flange_pose() {
    ++reads;
    if (fail_read > 0 && reads == fail_read) {
      if (!garbage) throw std::runtime_error("controller timeout");
      cycle::StampedPose<S> p;
      p.T_base_flange.matrix().setConstant(std::numeric_limits<S>::quiet_NaN());
      return p;
    }
    return inner->read_flange_pose();
  }
};
static_assert(cycle::is_robot_driver<TestRobot>::value, "TestRobot models RobotDriver");

// TEST-ONLY STAND-IN (oracle): returns the true parts in view 1's frame, so the mechanics of the
// cycle (emptying, timing, failures) are tested independently of recognition quality. The picking
// test (binpick_sim) and the strategy comparison below use the reference estimator.
struct OracleEstimator {
  using Scalar = S;
  using Camera = ::Camera;
  const sim::Scene<S>* scene;
  const TestSensor* sensor;
  std::vector<std::thread::id> threads;  // the thread of each call
  bool blind = false;                     // recognizes nothing
  S grasp_shift = 0;                       // every grasp moved this far along base x [m]: grips fail
  std::vector<int> shift_ids;  // when not empty: grasp_shift moves only these parts' grasps, ranked first
  bool weak_clear_top = false;  // the top part: 20 % and a clear grasp; the others: confident, not clear
  bool all_blocked = false;     // every grasp reported blocked (grasp_clear false)
  std::vector<int> only_ids;    // when not empty: the parts with these ids only (the others unrecognized)
  long with_obstacles = 0, only_in_obstacles = 0;  // calls given obstacles; pixels measured only there
  cycle::EstimationResult<S> estimate(const cycle::EstimatorInput<S, Camera>& in) {
    threads.push_back(std::this_thread::get_id());
    if (!in.obstacles.empty()) {
      ++with_obstacles;
      bool consistent = in.obstacles.width() == in.depth.width() && in.obstacles.height() == in.depth.height();
      for (int v = 0; consistent && v < in.depth.height(); ++v)
        for (int u = 0; u < in.depth.width(); ++u) {
          const S kept = in.depth.depth(u, v), all = in.obstacles.depth(u, v);
          consistent = consistent && !(kept > 0 && kept != all);  // the crop only removes
          only_in_obstacles += kept == 0 && all > 0;
        }
      if (!consistent) {
        cycle::EstimationResult<S> bad;
        bad.status = cycle::EstimationStatus::invalid_input;
        return bad;
      }
    }
    cycle::EstimationResult<S> r;
    if (blind) {
      r.status = cycle::EstimationStatus::no_objects;
      return r;
    }
    if (!in.camera) {
      r.status = cycle::EstimationStatus::invalid_input;
      return r;
    }
    const Isometry3<S> T_cam_base = sensor->T_base_view1.inverse(Eigen::Isometry);
    for (const auto& p : scene->parts()) {
      if (!only_ids.empty() && std::find(only_ids.begin(), only_ids.end(), p.id) == only_ids.end()) continue;
      const auto& m = scene->model(p.type);
      for (const auto& g : m.grasps) {
        Isometry3<S> G = p.T_base_part * g.T_part_grasp;
        const bool shifted = std::find(shift_ids.begin(), shift_ids.end(), p.id) != shift_ids.end();
        if (shift_ids.empty() || shifted) G.translation().x() += grasp_shift;
        if (G.linear().col(2).z() > S(-0.7)) continue;  // approach from above only
        cycle::RecognizedObject<S> o;
        o.part_type = int(p.type);
        o.T_camera_object = T_cam_base * p.T_base_part;
        o.T_camera_grasp = T_cam_base * G;
        o.confidence_percent = S(50) + S(1000) * p.T_base_part.translation().z() + (shifted ? S(10) : S(0));  // top parts first
        o.gripper = m.gripper;
        if (weak_clear_top) {
          const bool top = std::all_of(scene->parts().begin(), scene->parts().end(), [&](const auto& q) {
            return q.T_base_part.translation().z() <= p.T_base_part.translation().z();
          });
          o.confidence_percent = top ? S(20) : o.confidence_percent;
          o.grasp_clear = top;
        }
        if (all_blocked) o.grasp_clear = false;
        r.objects.push_back(o);
        break;
      }
    }
    std::sort(r.objects.begin(), r.objects.end(), [](const auto& a, const auto& b) { return a.confidence_percent > b.confidence_percent; });
    r.status = r.objects.empty() ? cycle::EstimationStatus::no_objects : cycle::EstimationStatus::ok;
    return r;
  }
};

// Expects f to throw std::invalid_argument naming `name`.
template <typename F>
void expect_invalid_argument(F&& f, const std::string& name) {
  try {
    f();
    ADD_FAILURE() << "accepted a bad " << name;
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'" + name + "'"), std::string::npos) << e.what();
  }
}

struct TestCell {
  using Pipeline = cycle::PickingPipeline<TestRobot, TestSensor, OracleEstimator, sim::SimClock, simcell::SimGripper<S>>;
  sim::Scene<S> scene;
  sim::SimClock clock;
  std::unique_ptr<sim::FakeRobot<S>> fake_robot;
  std::unique_ptr<sim::FakeSensor<S>> fake_sensor;
  TestRobot robot;
  TestSensor sensor;
  OracleEstimator estimator;
  std::unique_ptr<simcell::SimGripper<S>> gripper;
  std::unique_ptr<Pipeline> pipeline;

  TestCell(int parts, cycle::Strategy strategy, std::uint64_t seed = 5, bool vary_search = true, bool relook = true,
           S confident_percent = 0, bool grasp_blocked = false) {
    sim::SceneSettings<S> ss;
    ss.part_type = sim::PartType::circle_nut;
    ss.num_parts = parts;
    scene = sim::Scene<S>::generate(ss, seed);
    cycle::PipelineSettings<S> ps;
    ps.strategy = strategy;
    ps.vary_search = vary_search;
    ps.relook = relook;
    ps.confident_percent = confident_percent;
    ps.grasp_blocked = grasp_blocked;
    fake_robot = std::make_unique<sim::FakeRobot<S>>(clock, ps.T_base_drop);
    sim::StereoSensorSettings<S> st;
    st.width = 640;
    st.height = 512;
    st.errors.enabled = false;  // mechanics only: the exact depth renders 3x faster
    fake_sensor = std::make_unique<sim::FakeSensor<S>>(scene, *fake_robot, clock, ps.T_flange_camera, st);
    robot.inner = fake_robot.get();
    sensor.inner = fake_sensor.get();
    sensor.robot = fake_robot.get();
    sensor.T_flange_camera = ps.T_flange_camera;
    estimator.scene = &scene;
    estimator.sensor = &sensor;
    gripper = std::make_unique<simcell::SimGripper<S>>(scene, sim::PartType::circle_nut);
    pipeline = std::make_unique<Pipeline>(robot, sensor, estimator, clock, *gripper, ps);
  }
  /// A new pipeline over the same drivers with the settings `change` makes to the current ones.
  template <typename Change>
  void reconfigure(Change&& change) {
    auto ps = pipeline->settings();
    change(ps);
    pipeline = std::make_unique<Pipeline>(robot, sensor, estimator, clock, *gripper, ps);
  }
};

}  // namespace

TEST(Pipeline, EmptiesASmallPileWithProcessingDuringTheDrop) {
  TestCell cell(3, cycle::Strategy::ours);
  int cycles = 0, placed = 0;
  while (!cell.scene.parts().empty() && cycles < 8) {
    const auto r = cell.pipeline->run_cycle();
    ++cycles;
    ASSERT_TRUE(r.error.empty()) << r.error;
    EXPECT_EQ(r.views, 4);
    if (!r.placed) continue;
    ++placed;
    // Fig. 2: processing runs while the robot drops the part, and starts after the last view.
    const auto* drop = r.timeline.find("drop N->C");
    const auto* icp = r.timeline.find("ICP");
    const auto* fusion = r.timeline.find("fusion");
    const auto* last_exposure = r.timeline.find("exposure 4");
    ASSERT_TRUE(drop && icp && fusion && last_exposure);
    // The registration (measured inside the fusion) is its own stage, right before the rest of it.
    EXPECT_GT(icp->duration(), 0.0);
    EXPECT_NEAR(icp->end, fusion->start, 1e-12);
    EXPECT_NEAR(r.icp_ms + fusion->duration() * 1e3, r.fusion_ms, 1e-6);
    EXPECT_GT(r.timeline.overlap("drop N->C", cycle::Lane::processing), 0.5 * drop->duration());
    EXPECT_GE(r.timeline.find("transfer")->start, last_exposure->end - 1e-9);
    // The robot never moves while it waits, and a wait only follows an unfinished processing.
    if (const auto* wait = r.timeline.find("wait for processing")) {
      EXPECT_NEAR(wait->end, r.timeline.find("planning")->end, 1e-9);
    }
    EXPECT_NEAR(r.takt.sensing_in_takt(), r.takt.detour + r.takt.robot_wait, 1e-12);
    EXPECT_GE(r.takt.detour, 0.0);
  }
  EXPECT_TRUE(cell.scene.parts().empty()) << "pile not emptied in " << cycles << " cycles";
  EXPECT_GE(placed, 2);
  // The estimator saw the cropped depth and, for its gripper check, the walls and floor the crop removed.
  EXPECT_EQ(cell.estimator.with_obstacles, long(cycles));
  EXPECT_GT(cell.estimator.only_in_obstacles, 1000);
}

// Searches in a row aim at the bin centre, then at each of its quarters, then around again
// (vary_search); without it every search aims at the same spot. (No drags here: drag_unrecognized_after
// would drag the pile the blind estimator does not see instead of searching again.)
TEST(Pipeline, SearchesInARowAimAtDifferentPartsOfTheBin) {
  for (const bool vary : {true, false}) {
    TestCell cell(3, cycle::Strategy::ours, 5, vary);
    cell.estimator.blind = true;
    cell.reconfigure([](cycle::PipelineSettings<S>& ps) {
      ps.drag_unrecognized_after = 0;
      ps.look_at_unexplained = false;  // it would aim the first search at the pile (LooksAtSurfaceNoObjectExplains)
    });
    const cycle::PipelineSettings<S>& ps = cell.pipeline->settings();
    std::vector<Eigen::Vector3f> targets;
    for (int c = 0; c < 7; ++c) {
      const auto r = cell.pipeline->run_cycle();
      ASSERT_TRUE(r.error.empty()) << r.error;
      EXPECT_EQ(r.status, cycle::CycleStatus::nothing_recognized);
      EXPECT_EQ(r.search, c > 0);  // the first cycle runs the predefined path
      if (r.search) targets.push_back(r.target);
    }
    ASSERT_EQ(targets.size(), 6u);
    EXPECT_EQ(cell.pipeline->searches(), 7);
    for (const auto& t : targets) {
      EXPECT_LE(std::abs(t.x() - ps.bin_center.x()), ps.bin_length / 2);
      EXPECT_LE(std::abs(t.y() - ps.bin_center.y()), ps.bin_width / 2);
    }
    // The period: the first search aiming where the first one did.
    std::size_t period = 1;
    while (period < targets.size() && (targets[period] - targets[0]).norm() > 1e-6f) ++period;
    if (!vary) {
      EXPECT_EQ(period, 1u);
    } else {
      EXPECT_EQ(period, 5u);  // the centre and all four quarters
    }
    for (std::size_t i = 0; i < targets.size(); ++i) {
      if (i >= period) {
        EXPECT_LT((targets[i] - targets[i - period]).norm(), 1e-6f) << i;
      }
      for (std::size_t j = 0; j < i && i < period; ++j) {
        EXPECT_GT((targets[i] - targets[j]).norm(), ps.bin_width / 4) << i << " " << j;
      }
    }
  }
}

// After a failed grip the next sensing path is the planned one with its arc turned about the vertical
// through B: half a turn from the drop side, then a quarter turn; after a successful grip (or with
// `relook` off) it sweeps toward the drop point C (Alg. 2).
TEST(Pipeline, AFailedGripTurnsTheNextSensingArc) {
  // The arc's horizontal sweep direction against the direction from B toward C: 1 toward C, -1 away.
  const auto sweep_cos = [](const cycle::CycleResult<S>& r, const cycle::PipelineSettings<S>& ps) {
    const auto& cams = r.T_base_captures_planned;
    Eigen::Vector3f sweep = cams.back().translation() - cams.front().translation();
    Eigen::Vector3f to_c = ps.T_base_drop.translation() - r.pull_up;
    sweep.z() = 0;
    to_c.z() = 0;
    return sweep.normalized().dot(to_c.normalized());
  };
  for (const int mode : {0, 1, 2}) {  // 0: grips hold; 1: grips fail; 2: grips fail, relook off
    const bool fail = mode > 0;
    TestCell cell(3, cycle::Strategy::ours, 5, true, mode != 2);
    cell.estimator.grasp_shift = fail ? S(0.02) : S(0);
    const auto& ps = cell.pipeline->settings();
    const auto r0 = cell.pipeline->run_cycle();  // the predefined path
    ASSERT_EQ(r0.status, fail ? cycle::CycleStatus::grasp_failed : cycle::CycleStatus::picked);
    const auto r1 = cell.pipeline->run_cycle();
    ASSERT_EQ(r1.path_source, cycle::PathSource::planned);
    ASSERT_GE(r1.T_base_captures_planned.size(), 2u);
    if (mode != 1) {
      EXPECT_GT(sweep_cos(r1, ps), 0.9f) << mode;
      continue;
    }
    EXPECT_LT(sweep_cos(r1, ps), -0.9f);  // half a turn
    ASSERT_EQ(r1.status, cycle::CycleStatus::grasp_failed);
    const auto r2 = cell.pipeline->run_cycle();
    ASSERT_GE(r2.T_base_captures_planned.size(), 2u);
    EXPECT_LT(std::abs(sweep_cos(r2, ps)), 0.2f);  // a quarter turn
  }
}

// Objects below confident_percent are grasped only when no confident object offers a grasp, not even
// one the estimator found blocked (when blocked grasps are tried at all, grasp_blocked): the top part
// (weak, clear) is taken first when the threshold is 0, or when blocked grasps are not tried.
TEST(Pipeline, WeakObjectsAreALastResort) {
  for (const bool grasp_blocked : {true, false})
    for (const S confident : {S(0), S(35)}) {
      TestCell cell(3, cycle::Strategy::ours, 5, true, true, confident, grasp_blocked);
      cell.estimator.weak_clear_top = true;
      int top = -1;
      S top_z = -1;
      for (const auto& p : cell.scene.parts())
        if (p.T_base_part.translation().z() > top_z) {
          top_z = p.T_base_part.translation().z();
          top = p.id;
        }
      const auto r = cell.pipeline->run_cycle();
      ASSERT_EQ(r.status, cycle::CycleStatus::picked) << r.error;
      const bool top_left = std::any_of(cell.scene.parts().begin(), cell.scene.parts().end(),
                                        [&](const auto& p) { return p.id == top; });
      const bool weak_first = confident == 0 || !grasp_blocked;
      EXPECT_EQ(top_left, !weak_first) << confident << " " << grasp_blocked;
      EXPECT_EQ(r.grasp_clear, weak_first) << confident << " " << grasp_blocked;
    }
  // Only weak objects: still grasped, not a search.
  TestCell cell(1, cycle::Strategy::ours, 5, true, true, S(35));
  cell.estimator.weak_clear_top = true;
  const auto r = cell.pipeline->run_cycle();
  EXPECT_EQ(r.status, cycle::CycleStatus::picked) << r.error;
  EXPECT_TRUE(cell.scene.parts().empty());
}

// A grasp the estimator found blocked is not tried by default: the cycle grips nothing and the next one
// runs the search move. With grasp_blocked it is tried (the oracle's grasps are exact, so it holds).
TEST(Pipeline, BlockedGraspsAreNotTriedByDefault) {
  for (const bool grasp_blocked : {false, true}) {
    TestCell cell(3, cycle::Strategy::ours, 5, true, true, S(0), grasp_blocked);
    cell.estimator.all_blocked = true;
    const auto r1 = cell.pipeline->run_cycle();
    ASSERT_TRUE(r1.error.empty()) << r1.error;
    EXPECT_GT(r1.recognized, 0) << grasp_blocked;
    if (grasp_blocked) {
      EXPECT_EQ(r1.status, cycle::CycleStatus::picked) << r1.error;
      EXPECT_FALSE(r1.grasp_clear);
      EXPECT_EQ(int(cell.scene.parts().size()), 2);
      continue;
    }
    EXPECT_EQ(r1.status, cycle::CycleStatus::nothing_recognized);
    EXPECT_EQ(int(cell.scene.parts().size()), 3);  // no grip was tried
    const auto r2 = cell.pipeline->run_cycle();
    EXPECT_TRUE(r2.search);
    EXPECT_EQ(int(cell.scene.parts().size()), 3);
  }
}

TEST(Pipeline, ProcessesEveryCycleOnOneThreadItOwns) {
  TestCell cell(3, cycle::Strategy::ours);
  for (int k = 0; k < 3; ++k) {
    const auto r = cell.pipeline->run_cycle();
    ASSERT_TRUE(r.error.empty()) << r.error;
  }
  const auto& ids = cell.estimator.threads;
  ASSERT_EQ(ids.size(), 3u);
  EXPECT_NE(ids[0], std::this_thread::get_id());  // processing overlaps the drop
  EXPECT_EQ(ids[1], ids[0]);                      // not a new thread per cycle
  EXPECT_EQ(ids[2], ids[0]);
}

TEST(Pipeline, StopAndGoSpendsMoreTimeInTakt) {
  double ours = 0, c = 0;
  for (auto strategy : {cycle::Strategy::ours, cycle::Strategy::stop_and_go}) {
    TestCell cell(2, strategy);
    double sum = 0;
    int placed = 0;
    for (int k = 0; k < 3 && !cell.scene.parts().empty(); ++k) {
      const auto r = cell.pipeline->run_cycle();
      ASSERT_TRUE(r.error.empty()) << r.error;
      if (r.placed) sum += r.takt.sensing_in_takt(), ++placed;
    }
    ASSERT_GT(placed, 0);
    (strategy == cycle::Strategy::ours ? ours : c) = sum / placed;
  }
  EXPECT_GT(c, ours + 0.5) << "stop-and-go " << c << " s vs ours " << ours << " s";
}

TEST(Pipeline, LostFrameEndsTheCycleCleanly) {
  TestCell cell(3, cycle::Strategy::ours);
  ASSERT_EQ(cell.pipeline->run_cycle().status, cycle::CycleStatus::picked);
  cell.sensor.lose_frame = true;
  const auto r = cell.pipeline->run_cycle();
  EXPECT_EQ(r.status, cycle::CycleStatus::sensor_failure);
  EXPECT_NE(r.error.find("never arrived"), std::string::npos) << r.error;
  EXPECT_EQ(cell.sensor.frames_in_memory(), 0u);
  EXPECT_FALSE(cell.fake_robot->is_moving());
  // The cell goes on: the next cycle runs the predefined path and succeeds.
  cell.sensor.lose_frame = false;
  const auto next = cell.pipeline->run_cycle();
  EXPECT_TRUE(next.error.empty()) << next.error;
  EXPECT_EQ(next.path_source, cycle::PathSource::predefined);
}

TEST(Pipeline, FailedPoseReadAndTriggerEndTheCycleCleanly) {
  for (int mode = 0; mode < 3; ++mode) {
    TestCell cell(2, cycle::Strategy::ours);
    if (mode == 0) cell.robot.fail_read = 2;                          // a late read throws
    if (mode == 1) cell.robot.fail_read = 3, cell.robot.garbage = true;  // a read returns NaN
    if (mode == 2) cell.sensor.throw_on_trigger = true;
    const auto r = cell.pipeline->run_cycle();
    EXPECT_EQ(r.status, mode == 2 ? cycle::CycleStatus::sensor_failure : cycle::CycleStatus::robot_failure) << mode;
    EXPECT_FALSE(r.error.empty());
    EXPECT_EQ(cell.sensor.frames_in_memory(), 0u);
    EXPECT_FALSE(cell.fake_robot->is_moving());
    EXPECT_TRUE(cell.fake_robot->read_flange_pose().T_base_flange.isApprox(cell.pipeline->T_base_home(), 1e-5f));
    cell.robot.fail_read = 0;
    cell.sensor.throw_on_trigger = false;
    EXPECT_TRUE(cell.pipeline->run_cycle().error.empty());
  }
}

TEST(Pipeline, RejectsBadSettings) {
  TestCell cell(1, cycle::Strategy::ours);
  cycle::PipelineSettings<S> ps;
  ps.interval = 0;
  EXPECT_THROW(TestCell::Pipeline(cell.robot, cell.sensor, cell.estimator, cell.clock, *cell.gripper, ps), std::invalid_argument);
  ps = {};
  ps.sensing_speed_percent = 120;
  EXPECT_THROW(TestCell::Pipeline(cell.robot, cell.sensor, cell.estimator, cell.clock, *cell.gripper, ps), std::invalid_argument);
  ps = {};
  ps.tool_margin = -0.001f;
  expect_invalid_argument([&] { TestCell::Pipeline(cell.robot, cell.sensor, cell.estimator, cell.clock, *cell.gripper, ps); },
                          "tool_margin");
  ps = {};
  ps.jaw_tool.hi.x() = std::numeric_limits<S>::infinity();
  expect_invalid_argument([&] { TestCell::Pipeline(cell.robot, cell.sensor, cell.estimator, cell.clock, *cell.gripper, ps); },
                          "jaw_tool");
  ps = {};
  ps.fixed_compute_time = std::numeric_limits<double>::quiet_NaN();
  try {
    TestCell::Pipeline p(cell.robot, cell.sensor, cell.estimator, cell.clock, *cell.gripper, ps);
    ADD_FAILURE() << "a NaN fixed_compute_time was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'fixed_compute_time'"), std::string::npos) << e.what();
  }
  ps = {};
  ps.confident_percent = 101;
  EXPECT_THROW(TestCell::Pipeline(cell.robot, cell.sensor, cell.estimator, cell.clock, *cell.gripper, ps), std::invalid_argument);
  ps = {};
  ps.drag_after_failures = -1;
  expect_invalid_argument([&] { TestCell::Pipeline(cell.robot, cell.sensor, cell.estimator, cell.clock, *cell.gripper, ps); },
                          "drag_after_failures");
  ps = {};
  ps.drag_unrecognized_after = -1;
  expect_invalid_argument([&] { TestCell::Pipeline(cell.robot, cell.sensor, cell.estimator, cell.clock, *cell.gripper, ps); },
                          "drag_unrecognized_after");
  ps = {};
  ps.drag_surface_height = std::numeric_limits<S>::quiet_NaN();
  expect_invalid_argument([&] { TestCell::Pipeline(cell.robot, cell.sensor, cell.estimator, cell.clock, *cell.gripper, ps); },
                          "drag_surface_height");
  ps = {};
  ps.drag_tall_height = std::numeric_limits<S>::quiet_NaN();
  expect_invalid_argument([&] { TestCell::Pipeline(cell.robot, cell.sensor, cell.estimator, cell.clock, *cell.gripper, ps); },
                          "drag_tall_height");
  ps = {};
  ps.look_radius = 0;
  const auto rejected = [&](const char* name) {
    expect_invalid_argument([&] { TestCell::Pipeline(cell.robot, cell.sensor, cell.estimator, cell.clock, *cell.gripper, ps); },
                            name);
  };
  rejected("look_radius");
  ps = {};
  ps.look_min_area = -1e-4f;
  rejected("look_min_area");
  ps = {};
  ps.look_wall_band = std::numeric_limits<S>::infinity();
  rejected("look_wall_band");
  ps = {};
  ps.drag_clearance = -0.001f;
  rejected("drag_clearance");
  ps.drag_clearance = std::numeric_limits<S>::quiet_NaN();
  rejected("drag_clearance");
}

// ---------------------------------------------------------------------------------------------------
// The strategies with the reference estimator on a fixed seed.

// Five piles of one part type, as binpick_sim runs 0-4 of it make them (the seed of run r: seed ×
// 1000003 + the type's index × 7919 + r), each strategy on the same piles, until the bin is empty,
// `max_failures` failed cycles in a row or `max_cycles`. With a fixed compute time on the simulated
// clock the runs are the same on any machine.
struct Piles {
  sim::PartType part = sim::PartType::pencil_coupler;
  int parts = 6;
  std::uint64_t seed = 11;
  int width = 640, height = 512;
  int views = 4;                 // Table III's sensing parameters, or the pipeline's defaults
  double interval = 0.030;       // [s]
  S speed_percent = 80;
  double compute_time = 0.060;   // [s] on the simulated clock
  int max_cycles = 10;
  int max_failures = 3;
};

static int strategy_picks(cycle::Strategy s, const Piles& piles) {
  int picked_total = 0;
  for (std::uint64_t pile = 0; pile < 5; ++pile) {
    simcell::CellOptions o;
    o.part = piles.part;
    o.parts = piles.parts;
    o.seed = piles.seed * 1000003ULL + std::uint64_t(int(piles.part)) * 7919ULL + pile;
    o.width = piles.width;
    o.height = piles.height;
    cycle::PipelineSettings<S> ps;
    ps.strategy = s;
    ps.seed = o.seed;
    ps.num_views = piles.views;
    ps.interval = piles.interval;
    ps.sensing_speed_percent = piles.speed_percent;
    ps.fixed_compute_time = piles.compute_time;  // the same cycles on any machine
    simcell::Cell cell(o, ps);
    int fails = 0;
    for (int k = 0; k < piles.max_cycles && cell.remaining() > 0 && fails < piles.max_failures; ++k) {
      const auto r = cell.pipeline->run_cycle();
      EXPECT_TRUE(r.error.empty()) << r.error;
      const bool ok = r.status == cycle::CycleStatus::picked;
      picked_total += ok;
      fails = ok ? 0 : fails + 1;
    }
  }
  return picked_total;
}

// Pencil couplers, five piles of 6 parts (binpick_sim --types pencil_coupler --parts 6 --seed 11
// --compute-time 60, runs 0-4), at most 10 cycles a pile and 3 failed ones in a row. Two piles were
// too few: when the scene's settling changed (parts no longer balance on an edge) their outcome
// turned from ours 12, A 9 to ours 8, A 11 of 12, one pile losing 4 parts to a coupler the fit kept
// sliding along its axis.
static const Piles kCouplerPiles{};

// Multi-view sensing picks more than one view (paper Fig. 11); measured: ours 25, A 22 of 30 (ours
// 26 before a success forgot only the failures near it, forget_distance). A single view leaves more parts unrecognized, and looking at their
// surface (look_at_unexplained) finds some of them again (earlier code, piles 0 and 1: without it A
// picked 4 of 12).
TEST(Strategies, OursBeatsSingleView) {
  const int ours = strategy_picks(cycle::Strategy::ours, kCouplerPiles),
            a = strategy_picks(cycle::Strategy::single_view, kCouplerPiles);
  std::printf("picked of 30: ours %d, A %d\n", ours, a);
  EXPECT_GT(ours, a) << "ours " << ours << ", A " << a << " of 30";
}

// Active vision picks more than a random sensing path (B) where the sensor sees parts poorly: the
// paper's Fig. 12 shows mirror nuts. Five piles of 10 mirror nuts at the sensor's 1280 x 1024 with
// Table III's parameters (3 views, 60 ms, 60 %), until empty or 3 failed cycles in a row
// (binpick_sim --types mirror_nut --parts 10 --resolution 1280x1024 --seed 1 --compute-time 40
// --max-failures 3, runs 0-4). Measured: ours 50, B 46 of 50 (ours emptied every pile, B lost 1 and
// 3 parts in two of them); on seed 2, the only other seed run, ours 47 and B 43. These are the first
// two seeds tried, not chosen. Over whole picking tests of 20 mirror nuts (5 runs per seed, seeds 3-6,
// --max-failures 5) ours picked 391 and B 376 of 400. On the five coupler piles above at 640 x 512
// B picks more, 30 against 25, though both miss about as often there (binpick_sim on those piles
// with --max-failures 3: B 11 cycles without a pick, ours 13, mostly fits 3-4 mm off along a
// coupler's axis): ours' misses fell in a row in two piles, which ended them. The gap is the hard
// type's.
TEST(Strategies, OursBeatsRandomPathOnMirrorNuts) {
  Piles nuts;
  nuts.part = sim::PartType::mirror_nut;
  nuts.parts = 10;
  nuts.seed = 1;
  nuts.width = 1280;
  nuts.height = 1024;
  const simcell::Params table = simcell::table3(nuts.part);
  nuts.views = table.n;
  nuts.interval = table.t_ms * 1e-3;
  nuts.speed_percent = S(table.v_percent);
  nuts.compute_time = 0.040;
  nuts.max_cycles = 3 * nuts.parts + 10;
  // B on a second thread (each cell is independent and single-threaded: the same picks, half the wait).
  auto b_picks = std::async(std::launch::async, [&] { return strategy_picks(cycle::Strategy::random_path, nuts); });
  const int ours = strategy_picks(cycle::Strategy::ours, nuts), b = b_picks.get();
  std::printf("picked of 50: ours %d, B %d\n", ours, b);
  EXPECT_GT(ours, b) << "ours " << ours << ", B " << b << " of 50";
}

// A cell of `part` with an empty bin on `seed`, its compute time fixed on the simulated clock (the
// same cycles on any machine); the rest of `ps` as the test sets it.
static std::unique_ptr<simcell::Cell> empty_bin_cell(sim::PartType part, std::uint64_t seed, cycle::PipelineSettings<S> ps = {}) {
  simcell::CellOptions o;
  o.part = part;
  o.parts = 0;
  o.seed = seed;
  ps.seed = seed;
  ps.fixed_compute_time = 0.040;
  return std::make_unique<simcell::Cell>(o, ps);
}

// A part lying beside a long wall is inside the region of interest and gets picked: the crop removes
// the walls, not the parts next to them (a 15 mm margin left every part within ~1 cm of a wall unseen
// to the end of its run; this test fails with it). One flange nut 3 mm from each long wall in turn,
// alone in the bin. (Beside a short wall, 25 cm from the centre, the quarter searches see it but the
// reference estimator does not recognize it: not covered.)
TEST(Pipeline, PicksAPartLyingBesideALongWall) {
  for (int wall = 0; wall < 2; ++wall) {
    const cycle::PipelineSettings<S> ps;
    const auto cell = empty_bin_cell(sim::PartType::circle_nut, 17 + std::uint64_t(wall), ps);
    const S radius = S(0.010), gap = S(0.003);
    const S hy = ps.bin_width / 2 - radius - gap;
    const Eigen::Vector2f xy = wall == 0 ? Eigen::Vector2f(0.02f, -hy) : Eigen::Vector2f(-0.03f, hy);
    cell->scene.add_part(sim::PartType::circle_nut, Eigen::Matrix3f::Identity(), xy);
    bool picked = false;
    for (int k = 0; k < 5 && !picked; ++k) {
      const auto r = cell->pipeline->run_cycle();
      EXPECT_TRUE(r.error.empty()) << r.error;
      picked = r.status == cycle::CycleStatus::picked;
    }
    EXPECT_TRUE(picked) << "wall " << wall << ": the part at (" << xy.x() << ", " << xy.y() << ") was never picked";
  }
}

// look_at_unexplained: a circle nut and a pencil coupler standing on end, which the cell's estimator
// (circle-nut models only) never explains. The predefined look over the bin centre recognizes
// nothing; the search then starts above surface the fused depth showed (with the setting off, and for
// baseline B: the bin centre's search). Once the nut is picked, the next path aims at the coupler. Each check fails
// without the setting's effect.
TEST(Pipeline, LooksAtSurfaceNoObjectExplains) {
  for (const int mode : {0, 1, 2}) {
    // 0: ours; 1: ours with the setting off; 2: baseline B, which never looks (its paths aim at random).
    const bool look = mode == 0;
    cycle::PipelineSettings<S> ps;
    ps.look_at_unexplained = mode != 1;
    if (mode == 2) ps.strategy = cycle::Strategy::random_path;
    const auto cell = empty_bin_cell(sim::PartType::circle_nut, 23, ps);
    cell->scene.add_part(sim::PartType::circle_nut, Eigen::Matrix3f::Identity(), Eigen::Vector2f(-0.06f, -0.02f));
    cell->scene.add_part(sim::PartType::pencil_coupler, Eigen::Matrix3f::Identity(), Eigen::Vector2f(0.12f, 0.05f));
    const Eigen::Vector2f nut = cell->scene.parts().front().T_base_part.translation().head<2>();
    const Eigen::Vector2f coupler = cell->scene.parts().back().T_base_part.translation().head<2>();
    const Eigen::Vector2f centre = ps.bin_center.head<2>();
    const auto first = cell->pipeline->run_cycle();
    ASSERT_EQ(first.status, cycle::CycleStatus::nothing_recognized) << "look " << look << ": " << cycle::to_string(first.status);
    const auto search = cell->pipeline->run_cycle();
    ASSERT_TRUE(search.search);
    ASSERT_FALSE(search.T_base_captures_planned.empty());
    const Eigen::Vector2f target = search.target.head<2>();
    if (!look) {
      EXPECT_LT((target - centre).norm(), 0.001f) << "mode " << mode << ": not the bin centre's search";
      continue;
    }
    EXPECT_LT(std::min((target - nut).norm(), (target - coupler).norm()), 0.02f)
        << "the search aims at (" << target.x() << ", " << target.y() << "), at neither part";
    EXPECT_LT((search.T_base_captures_planned.front().translation().head<2>() - target).norm(), 0.02f)
        << "the search does not start above its target";
    for (int k = 0; k < 4 && cell->remaining() == 2; ++k) {
      const auto r = cell->pipeline->run_cycle();
      ASSERT_TRUE(r.error.empty()) << r.error;
    }
    ASSERT_EQ(cell->remaining(), 1) << "the circle nut was not picked";
    ASSERT_EQ(cell->scene.parts().front().type, sim::PartType::pencil_coupler);
    const auto next = cell->pipeline->run_cycle();  // aimed by the picking cycle's plan
    EXPECT_LT((next.target.head<2>() - coupler).norm(), 0.02f) << "the path after the last recognized part misses the coupler";
  }
}

// ---------------------------------------------------------------------------------------------------
// The known bin against the tool (bin_volume.hpp)

namespace {
// Whether any of a grid of points of `box` at T stands in the bin, with the walls and the floor moved
// `tol` inward (the reference for the exact check).
bool sampled_hit(const cycle::ToolBox<double>& box, const Isometry3<double>& T, const cycle::BinVolume<double>& bin,
                 double tol, int n) {
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j)
      for (int k = 0; k <= n; ++k) {
        const Vector3<double> f(double(i) / n, double(j) / n, double(k) / n);
        const Vector3<double> d = T * (box.lo + (box.hi - box.lo).cwiseProduct(f)) - bin.floor_center;
        if (d.z() < tol) return true;
        if (d.z() <= bin.height + tol && (std::abs(d.x()) > bin.length / 2 - tol || std::abs(d.y()) > bin.width / 2 - tol))
          return true;
      }
  return false;
}

}  // namespace

// The exact box check agrees with a dense sampling of the box: a sampled point in the bin's walls or
// floor means blocked, and blocked means a sampled point within a grid cell of them.
RC_GTEST_PROP(BinVolume, ToolBoxCheckAgreesWithSampling, ()) {
  cycle::BinVolume<double> bin;
  bin.floor_center = Vector3<double>(*rc::gen::inRange(-100, 100) * 1e-3, *rc::gen::inRange(-100, 100) * 1e-3,
                                     *rc::gen::inRange(-50, 50) * 1e-3);
  bin.length = *rc::gen::inRange(100, 600) * 1e-3;
  bin.width = *rc::gen::inRange(100, 400) * 1e-3;
  bin.height = *rc::gen::inRange(30, 150) * 1e-3;
  cycle::ToolBox<double> box;
  box.hi = Vector3<double>(*rc::gen::inRange(1, 40), *rc::gen::inRange(1, 40), *rc::gen::inRange(0, 5)) * 1e-3;
  box.lo = -Vector3<double>(*rc::gen::inRange(1, 40), *rc::gen::inRange(1, 40), *rc::gen::inRange(1, 60)) * 1e-3;
  Isometry3<double> T = Isometry3<double>::Identity();
  const Vector3<double> axis(*rc::gen::inRange(-100, 101), *rc::gen::inRange(-100, 101), *rc::gen::inRange(1, 101));
  T.linear() = Eigen::AngleAxisd(*rc::gen::inRange(0, 180) * M_PI / 180, axis.normalized()).toRotationMatrix();
  // Anywhere from the middle of the bin to beyond its walls, from below the floor to above the top.
  const double fx = *rc::gen::inRange(-60, 61) / 100.0, fy = *rc::gen::inRange(-60, 61) / 100.0;
  T.translation() = bin.floor_center + Vector3<double>(fx * bin.length, fy * bin.width, *rc::gen::inRange(-10, 200) * 1e-3);
  const bool clear = cycle::tool_clear_of_bin(box, T, bin);
  const int n = 24;
  const double cell = (box.hi - box.lo).norm() / n;
  if (sampled_hit(box, T, bin, 0, n)) RC_ASSERT(!clear);
  if (!clear) RC_ASSERT(sampled_hit(box, T, bin, cell, n));
  RC_TAG(clear ? "clear" : "blocked");
}

TEST(BinVolume, MarginsUnknownBinsAndBadSizes) {
  cycle::BinVolume<double> bin;
  bin.length = 0.5;
  bin.width = 0.25;
  bin.height = 0.1;
  const auto jaws = cycle::jaw_tool_box(0.020, 0.004, 0.008, 0.030);  // reaches 14 mm along x
  Isometry3<double> T = Isometry3<double>::Identity();
  T.linear() = Eigen::AngleAxisd(M_PI, Vector3<double>::UnitX()).toRotationMatrix();  // approach down
  T.translation() = Vector3<double>(0.25 - 0.015, 0, 0.035);  // 1 mm between the finger and the wall
  EXPECT_TRUE(cycle::tool_clear_of_bin(jaws, T, bin));
  EXPECT_FALSE(cycle::tool_clear_of_bin(jaws, T, bin, 0.002));
  T.translation().z() = 0.02;  // the tips 20 mm above the floor, the box reaches down: fine
  EXPECT_TRUE(cycle::tool_clear_of_bin(jaws, T, bin));
  T.translation().z() = -0.001;  // tips below the floor
  EXPECT_FALSE(cycle::tool_clear_of_bin(jaws, T, bin));
  T.translation() = Vector3<double>(0.25 - 0.010, 0, 0.035);  // a finger in the wall
  EXPECT_FALSE(cycle::tool_clear_of_bin(jaws, T, bin));
  EXPECT_TRUE(bin.blocks(T * Vector3<double>(0.013, 0, 0)));
  EXPECT_FALSE(bin.blocks(T * Vector3<double>(0.003, 0, 0)));
  T.translation().z() = 0.1 + 0.031;  // the whole tool above the wall top
  EXPECT_TRUE(cycle::tool_clear_of_bin(jaws, T, bin));
  EXPECT_TRUE(cycle::tool_clear_of_bin(cycle::ToolBox<double>{}, Isometry3<double>::Identity(), bin));  // empty box
  EXPECT_TRUE(cycle::tool_clear_of_bin(jaws, T, cycle::BinVolume<double>{}));                          // no bin
  EXPECT_FALSE(cycle::BinVolume<double>{}.blocks(Vector3<double>(0, 0, -1)));
  expect_invalid_argument([] { cycle::jaw_tool_box(-0.01, 0.004, 0.008, 0.03); }, "stroke");
  expect_invalid_argument([] { cycle::jaw_tool_box(0.02, 0.004, std::nan(""), 0.03); }, "finger_width");
  expect_invalid_argument([] { cycle::cup_tool_box(0.005, -1.0); }, "length");
}

// A grasp whose cup would stand in a wall is not tried, even when the estimator (here the oracle,
// which checks nothing) offers it: the cycle grips nothing. Without the check the grip is tried and
// the simulated world judges it a bin collision.
TEST(Pipeline, AGraspWhoseToolStandsInAWallIsNotTried) {
  for (const bool check : {true, false}) {
    TestCell cell(0, cycle::Strategy::ours);
    // A circle nut 1 mm from the short wall at +x; its first grasp (on the annulus, 7 mm towards +x)
    // puts the 5 mm cup 1 mm into the wall.
    const S hx = S(0.25) - S(0.010) - S(0.001);
    cell.scene.add_part(sim::PartType::circle_nut, Eigen::Matrix3f::Identity(), Eigen::Vector2f(hx, 0.02f));
    if (!check) cell.reconfigure([](cycle::PipelineSettings<S>& ps) { ps.cup_tool = ps.jaw_tool = {}; });
    const auto r = cell.pipeline->run_cycle();
    ASSERT_TRUE(r.error.empty()) << r.error;
    EXPECT_EQ(r.recognized, 1);
    if (check) {
      EXPECT_EQ(r.status, cycle::CycleStatus::nothing_recognized);
    } else {
      EXPECT_EQ(r.status, cycle::CycleStatus::grasp_failed);
      EXPECT_EQ(cell.gripper->last_status(), sim::PickStatus::bin_collision);
    }
    EXPECT_EQ(cell.scene.parts().size(), 1u);
  }
}

// A LAN connector lying flat against a long wall, end to end towards it: every grasp puts a finger in
// the wall. Without the drag the cell never picks it; with it, a cycle drags it off the wall and a
// later one picks it.
TEST(Pipeline, DragsAPartOffAWallThenPicksIt) {
  for (const bool drag : {true, false}) {
    cycle::PipelineSettings<S> ps;
    ps.drag_from_wall = drag;
    ps.drag_unrecognized_after = 0;  // the drag of unrecognized surface presses wherever the searches saw some
    const auto cell = empty_bin_cell(sim::PartType::lan_connector, 23, ps);
    const Eigen::Matrix3f R = Eigen::AngleAxisf(float(M_PI / 2), Eigen::Vector3f::UnitZ()).toRotationMatrix();
    cell->scene.add_part(sim::PartType::lan_connector, R, Eigen::Vector2f(0.03f, 0.2f));  // clamped against the wall
    const S y0 = cell->scene.parts()[0].T_base_part.translation().y();
    ASSERT_GT(y0, ps.bin_width / 2 - S(0.012));  // its end within 1.5 mm of the wall
    int dragged = 0, bin_hits = 0;
    bool picked = false;
    for (int k = 0; k < 6 && !picked; ++k) {
      const auto r = cell->pipeline->run_cycle();
      ASSERT_TRUE(r.error.empty()) << r.error;
      dragged += r.dragged;
      picked = r.status == cycle::CycleStatus::picked;
      bin_hits += r.status == cycle::CycleStatus::grasp_failed && cell->gripper->last_status() == sim::PickStatus::bin_collision;
      if (r.dragged) {
        ASSERT_EQ(cell->scene.parts().size(), 1u);
        EXPECT_LT(cell->scene.parts()[0].T_base_part.translation().y(), y0 - S(0.02)) << "the drag did not move it off the wall";
      }
    }
    EXPECT_EQ(bin_hits, 0) << "drag " << drag;
    EXPECT_EQ(picked, drag) << "drag " << drag;
    EXPECT_EQ(dragged > 0, drag);
    EXPECT_EQ(cell->gripper->dragged(), dragged);
  }
}

// Two parts side by side in the middle of the bin, both reported blocked: the cycle drags one straight
// away from the other (drag_apart) instead of searching; without drag_apart it searches.
TEST(Pipeline, DragsBlockedNeighboursApart) {
  for (const bool apart : {true, false}) {
    TestCell cell(0, cycle::Strategy::ours);
    cell.scene.add_part(sim::PartType::circle_nut, Eigen::Matrix3f::Identity(), Eigen::Vector2f(0.0f, 0.0f));
    cell.scene.add_part(sim::PartType::circle_nut, Eigen::Matrix3f::Identity(), Eigen::Vector2f(0.022f, 0.0f));
    cell.estimator.all_blocked = true;
    cell.reconfigure([&](cycle::PipelineSettings<S>& ps) { ps.drag_apart = apart; });
    const auto r = cell.pipeline->run_cycle();
    ASSERT_TRUE(r.error.empty()) << r.error;
    EXPECT_EQ(r.recognized, 2);
    EXPECT_EQ(r.status, cycle::CycleStatus::nothing_recognized);
    EXPECT_EQ(r.dragged, apart);
    ASSERT_EQ(cell.scene.parts().size(), 2u);
    const auto& p = cell.scene.parts();
    const float gap = (p[0].T_base_part.translation() - p[1].T_base_part.translation()).head<2>().norm();
    if (apart)
      EXPECT_GT(gap, 0.05f) << "not dragged apart";
    else
      EXPECT_NEAR(gap, 0.022f, 1e-4f);
    const auto r2 = cell.pipeline->run_cycle();
    EXPECT_EQ(r2.search, !apart);
  }
}

// drag_clearance: the same two blocked nuts, with a stack of two nuts the estimator does not recognize
// where either drag would end, 40 mm beyond each. The drag turns and the nut lands on the floor clear
// of the stack; with the setting 0 it goes straight and lands on the stack.
TEST(Pipeline, DragsAPartClearOfOthers) {
  for (const bool clearance : {true, false}) {
    TestCell cell(0, cycle::Strategy::ours);
    cell.scene.add_part(sim::PartType::circle_nut, Eigen::Matrix3f::Identity(), Eigen::Vector2f(0.0f, 0.0f));
    cell.scene.add_part(sim::PartType::circle_nut, Eigen::Matrix3f::Identity(), Eigen::Vector2f(0.022f, 0.0f));
    const std::array<Eigen::Vector2f, 2> stacks{Eigen::Vector2f(-0.040f, 0.0f), Eigen::Vector2f(0.062f, 0.0f)};
    for (const auto& xy : stacks)
      for (int k = 0; k < 2; ++k) cell.scene.add_part(sim::PartType::circle_nut, Eigen::Matrix3f::Identity(), xy);
    cell.estimator.all_blocked = true;
    cell.estimator.only_ids = {cell.scene.parts()[0].id, cell.scene.parts()[1].id};
    cell.reconfigure([&](cycle::PipelineSettings<S>& ps) { ps.drag_clearance = clearance ? S(0.015) : S(0); });
    const std::array<Eigen::Vector3f, 2> before{cell.scene.parts()[0].T_base_part.translation(),
                                                cell.scene.parts()[1].T_base_part.translation()};
    const auto r = cell.pipeline->run_cycle();
    ASSERT_TRUE(r.error.empty()) << r.error;
    ASSERT_TRUE(r.dragged);
    // The dragged nut (moved more than 3 cm) and its distance to the stacks' centres.
    int moved = 0;
    float to_stack = 1, height = 0;
    for (const auto& p : cell.scene.parts()) {
      if (p.id > 1) continue;  // ids follow the order added (an empty scene first)
      const Eigen::Vector3f at = p.T_base_part.translation(), start = before[std::size_t(p.id)];
      if (!((at - start).head<2>().norm() > 0.03f)) continue;
      ++moved;
      height = at.z() - cell.pipeline->settings().bin_center.z();
      for (const auto& xy : stacks) to_stack = std::min(to_stack, (at.head<2>() - xy).norm());
    }
    ASSERT_EQ(moved, 1) << "clearance " << clearance;
    if (clearance) {
      EXPECT_GT(to_stack, 0.02f) << "landed against the stack";
      EXPECT_LT(height, 0.004f) << "not on the floor";
    } else {
      EXPECT_GT(height, 0.004f) << "did not land on the stack";
    }
  }
}

// A blocked part beside a pile the estimator does not recognize (two nuts stacked 25 mm away): the cycle
// drags it away from the pile, read from the fused depth. The same part lying alone balances its own
// surface: nothing to drag it from, the cycle searches. Without drag_apart it searches either way.
TEST(Pipeline, DragsABlockedPartAwayFromAnUnrecognizedPile) {
  for (const bool pile : {true, false})
    for (const bool apart : {true, false}) {
      TestCell cell(0, cycle::Strategy::ours);
      cell.scene.add_part(sim::PartType::circle_nut, Eigen::Matrix3f::Identity(), Eigen::Vector2f(0.0f, 0.01f));
      if (pile)
        for (int k = 0; k < 2; ++k)
          cell.scene.add_part(sim::PartType::circle_nut, Eigen::Matrix3f::Identity(), Eigen::Vector2f(0.025f, 0.01f));
      cell.estimator.all_blocked = true;
      cell.estimator.only_ids = {cell.scene.parts()[0].id};
      cell.reconfigure([&](cycle::PipelineSettings<S>& ps) { ps.drag_apart = apart; });
      const Eigen::Vector3f before = cell.scene.parts()[0].T_base_part.translation();
      const auto r = cell.pipeline->run_cycle();
      ASSERT_TRUE(r.error.empty()) << r.error;
      ASSERT_EQ(r.recognized, 1);
      EXPECT_EQ(r.status, cycle::CycleStatus::nothing_recognized);
      EXPECT_EQ(r.dragged, pile && apart) << "pile " << pile << " apart " << apart;
      ASSERT_EQ(cell.scene.parts().size(), pile ? 3u : 1u);
      const auto& parts = cell.scene.parts();
      const auto it = std::find_if(parts.begin(), parts.end(), [&](const auto& p) { return p.id == cell.estimator.only_ids[0]; });
      ASSERT_NE(it, parts.end());
      const Eigen::Vector3f moved = it->T_base_part.translation() - before;
      if (pile && apart) {
        EXPECT_LT(moved.x(), -0.035f) << "not dragged away from the pile";
        EXPECT_LT(std::abs(moved.y()), 0.01f);
      } else {
        EXPECT_LT(moved.head<2>().norm(), 1e-4f);
      }
      EXPECT_EQ(cell.pipeline->run_cycle().search, !(pile && apart));
    }
}

// The simulated drag tips a part standing on end over (SimGripper::prepare_drag): a pencil coupler
// on end lies after a drag in any of 8 directions, its axis along the drag. No part type lying in one
// of its rest orientations turns.
TEST(SimGripper, ADragTipsOverOnlyAPartStandingOnEnd) {
  sim::SceneSettings<S> ss;
  ss.num_parts = 0;
  for (int type = 0; type < sim::kNumPartTypes; ++type) {
    const auto t = sim::PartType(type);
    const auto models = sim::Scene<S>::generate(ss, 1);
    std::vector<Eigen::Matrix3f> poses = models.model(t).rest_orientations;
    if (t == sim::PartType::pencil_coupler) poses.push_back(Eigen::Matrix3f::Identity());  // on end
    for (std::size_t k = 0; k < poses.size(); ++k)
      for (int d = 0; d < 8; ++d) {
        auto scene = sim::Scene<S>::generate(ss, 1);
        const int id = scene.add_part(t, poses[k], Eigen::Vector2f(0, 0));
        const Eigen::Matrix3f R0 = scene.parts()[0].T_base_part.linear();
        simcell::SimGripper<S> gripper(scene, t);
        const Eigen::Vector3f dir(std::cos(d * S(M_PI / 4)), std::sin(d * S(M_PI / 4)), 0);
        Eigen::Isometry3f from = Eigen::Isometry3f::Identity(), to = Eigen::Isometry3f::Identity();
        from.translation() = Eigen::Vector3f(0, 0, 0.001f);
        to.translation() = from.translation() + S(0.04) * dir;
        ASSERT_TRUE(gripper.prepare_drag(from, to));
        ASSERT_EQ(gripper.dragged(), 1);
        const auto& moved = scene.parts()[0];
        ASSERT_EQ(moved.id, id);
        const Eigen::Vector3f axis0 = R0.col(2), axis = moved.T_base_part.linear().col(2);
        if (k == models.model(t).rest_orientations.size()) {  // the coupler on end
          EXPECT_LT(std::abs(axis.z()), 0.2f) << "direction " << d << ": still standing";
          EXPECT_GT(std::abs(axis.dot(dir)), 0.9f) << "direction " << d << ": not lying along the drag";
        } else {
          EXPECT_GT(axis.dot(axis0), 0.99f) << sim::part_type_name(t) << " rest " << k << " direction " << d << ": turned";
        }
      }
  }
}

// Grips that keep failing at one part (every grasp estimated 5 mm off): after drag_after_failures of
// them the cycle drags the part instead of gripping it a third time: off the near wall, or, lying
// alone away from the walls with nothing around it to drag it away from, toward the bin centre
// (binpick_sim ours, 1280 x 1024, --vignetting 2, seed 4: a mirror-nut run ended on a nut whose jaws
// hit a neighbour the depth did not show, gripped 3 times in a row). With the setting 0 it grips
// again.
TEST(Pipeline, DragsAPartAtWhichGripsKeepFailing) {
  for (const bool wall : {true, false})
    for (const int after : {2, 0}) {
      TestCell cell(0, cycle::Strategy::ours);
      // 20 mm from the long wall's inner face (grasps clear of it), or 70 mm from the bin centre.
      const Eigen::Vector2f at = wall ? Eigen::Vector2f(0.05f, S(0.125) - S(0.02)) : Eigen::Vector2f(0.07f, 0.0f);
      cell.scene.add_part(sim::PartType::circle_nut, Eigen::Matrix3f::Identity(), at);
      cell.estimator.grasp_shift = S(0.005);
      cell.reconfigure([&](cycle::PipelineSettings<S>& ps) { ps.drag_after_failures = after; });
      for (int k = 0; k < 2; ++k) {
        const auto r = cell.pipeline->run_cycle();
        ASSERT_TRUE(r.error.empty()) << r.error;
        ASSERT_EQ(r.status, cycle::CycleStatus::grasp_failed);
        EXPECT_FALSE(r.dragged);
      }
      const Eigen::Vector2f p0 = cell.scene.parts()[0].T_base_part.translation().head<2>();
      const auto r = cell.pipeline->run_cycle();
      ASSERT_TRUE(r.error.empty()) << r.error;
      EXPECT_EQ(r.dragged, after > 0) << "wall " << wall;
      EXPECT_EQ(r.status, after > 0 ? cycle::CycleStatus::nothing_recognized : cycle::CycleStatus::grasp_failed);
      const Eigen::Vector2f d = cell.scene.parts()[0].T_base_part.translation().head<2>() - p0;
      if (after == 0)
        EXPECT_LT(d.norm(), S(1e-4));
      else if (wall)
        EXPECT_LT(d.y(), S(-0.03)) << "not dragged off the wall";
      else
        EXPECT_LT(d.x(), S(-0.03)) << "not dragged toward the bin centre";
    }
}

// A grip that holds forgets only the failures near it (forget_distance): a nut at which grips fail
// (every grasp estimated 5 mm off) and two good nuts 8 cm away. The failed nut is ranked first. With
// the default its first failure is remembered through the picks of the others, so it is gripped
// twice, then dragged. When a success forgets every failure (infinity, the earlier rule), it is
// gripped again after each pick elsewhere, and twice more once alone: four failed grips before the
// drag, as many as a LAN connector got in binpick_sim (seed 4), whose run ended before any drag.
TEST(Pipeline, ASuccessForgetsOnlyTheFailuresNearIt) {
  for (const S forget : {cycle::PipelineSettings<S>{}.forget_distance, std::numeric_limits<S>::infinity()}) {
    TestCell cell(0, cycle::Strategy::ours);
    const int bad = cell.scene.add_part(sim::PartType::circle_nut, Eigen::Matrix3f::Identity(), Eigen::Vector2f(0.0f, 0.0f));
    cell.scene.add_part(sim::PartType::circle_nut, Eigen::Matrix3f::Identity(), Eigen::Vector2f(0.08f, 0.0f));
    cell.scene.add_part(sim::PartType::circle_nut, Eigen::Matrix3f::Identity(), Eigen::Vector2f(-0.08f, 0.0f));
    cell.estimator.grasp_shift = S(0.005);
    cell.estimator.shift_ids = {bad};
    cell.reconfigure([&](cycle::PipelineSettings<S>& ps) { ps.forget_distance = forget; });
    int failed_grips = 0, picked = 0;
    bool dragged = false;
    for (int k = 0; k < 10 && !dragged; ++k) {
      const auto r = cell.pipeline->run_cycle();
      ASSERT_TRUE(r.error.empty()) << r.error;
      failed_grips += r.status == cycle::CycleStatus::grasp_failed;
      picked += r.status == cycle::CycleStatus::picked;
      dragged = r.dragged;
    }
    EXPECT_TRUE(dragged) << "forget_distance " << forget;
    EXPECT_EQ(picked, 2) << "forget_distance " << forget;
    EXPECT_EQ(failed_grips, std::isfinite(forget) ? 2 : 4) << "forget_distance " << forget;
  }
  cycle::PipelineSettings<S> ps;
  ps.forget_distance = std::nanf("");
  TestCell cell(0, cycle::Strategy::ours);
  expect_invalid_argument([&] { TestCell::Pipeline(cell.robot, cell.sensor, cell.estimator, cell.clock, *cell.gripper, ps); },
                          "forget_distance");
}

// A pencil coupler standing on end, alone: the reference estimator does not recognize it, and the top
// of the sleeve (a 1.5 mm ring around its bore, 30 mm high) is all the depth shows of it. The search
// cycles end in a drag of it, which tips it over (binpick_sim ours, 1280 x 1024, seed 5: two coupler
// runs ended on a coupler on end, never dragged: the drag asked for half of the tool's footprint
// measured, and the ring fills 10-20 of 49 cells; drag_tall_height lets it count with a quarter).
TEST(Pipeline, DragsAPartStandingOnEndThatIsNeverRecognized) {
  simcell::CellOptions o;
  o.part = sim::PartType::pencil_coupler;
  o.parts = 0;
  o.seed = 29;
  o.width = 1280;  // at 640 x 512 the ring's cells are fewer and coarser: it was dragged either way
  o.height = 1024;
  cycle::PipelineSettings<S> ps;
  ps.seed = o.seed;
  ps.fixed_compute_time = 0.040;
  const auto cell = std::make_unique<simcell::Cell>(o, ps);
  cell->scene.add_part(sim::PartType::pencil_coupler, Eigen::Matrix3f::Identity(), Eigen::Vector2f(0.02f, 0.01f));
  bool dragged = false;
  for (int k = 0; k < 4 && !dragged; ++k) {
    const auto r = cell->pipeline->run_cycle();
    ASSERT_TRUE(r.error.empty()) << r.error;
    ASSERT_NE(r.status, cycle::CycleStatus::picked) << "the coupler on end was recognized and picked";
    dragged = r.dragged;
  }
  ASSERT_TRUE(dragged) << "the coupler on end was never dragged";
  ASSERT_EQ(cell->remaining(), 1);
  EXPECT_LT(std::abs(cell->scene.parts()[0].T_base_part.linear()(2, 2)), 0.2f) << "the dragged coupler still stands";
}

// Baseline B differs from ours only in where its sensing paths aim. After a drag, ours looks where
// the drag ended; B aims at a random point of the bin (on this seed, more than 3 cm from it).
TEST(Strategies, RandomPathAimsAtRandomAfterADrag) {
  for (const auto strategy : {cycle::Strategy::ours, cycle::Strategy::random_path}) {
    TestCell cell(0, strategy);
    cell.scene.add_part(sim::PartType::circle_nut, Eigen::Matrix3f::Identity(), Eigen::Vector2f(0.05f, S(0.105)));
    cell.estimator.grasp_shift = S(0.005);  // every grip fails: the third cycle drags the nut off the wall
    for (int k = 0; k < 3; ++k) {
      const auto r = cell.pipeline->run_cycle();
      ASSERT_TRUE(r.error.empty()) << r.error;
      ASSERT_EQ(r.dragged, k == 2) << cycle::to_string(strategy) << ", cycle " << k;
    }
    const Eigen::Vector2f at = cell.scene.parts()[0].T_base_part.translation().head<2>();
    const auto next = cell.pipeline->run_cycle();
    ASSERT_TRUE(next.error.empty()) << next.error;
    const float off = (next.target.head<2>() - at).norm();
    if (strategy == cycle::Strategy::ours)
      EXPECT_LT(off, 0.01f) << "ours does not look where the drag ended";
    else
      EXPECT_GT(off, 0.03f) << "B aims where the drag ended";
  }
}

// The estimator recognizes nothing: the first cycle searches; the second drags the highest surface in
// the bin (a nut lying on another) instead of searching again. An empty bin shows no surface to drag,
// and with the setting 0 the cell keeps searching.
TEST(Pipeline, DragsWhatIsNeverRecognized) {
  for (const int after : {2, 0})
    for (const bool empty : {false, true}) {
      TestCell cell(0, cycle::Strategy::ours);
      if (!empty)
        for (int k = 0; k < 2; ++k)
          cell.scene.add_part(sim::PartType::circle_nut, Eigen::Matrix3f::Identity(), Eigen::Vector2f(-0.06f, 0.03f));
      cell.estimator.blind = true;
      cell.reconfigure([&](cycle::PipelineSettings<S>& ps) { ps.drag_unrecognized_after = after; });
      const auto r1 = cell.pipeline->run_cycle();
      ASSERT_TRUE(r1.error.empty()) << r1.error;
      EXPECT_FALSE(r1.dragged);
      std::vector<Eigen::Vector3f> before;
      for (const auto& p : cell.scene.parts()) before.push_back(p.T_base_part.translation());
      const auto r2 = cell.pipeline->run_cycle();
      ASSERT_TRUE(r2.error.empty()) << r2.error;
      const bool drags = after > 0 && !empty;
      EXPECT_EQ(r2.dragged, drags) << "after " << after << " empty " << empty;
      EXPECT_EQ(cell.gripper->dragged(), drags ? 1 : 0);
      ASSERT_EQ(cell.scene.parts().size(), before.size());
      if (empty) continue;
      // The upper nut (the last part after the drag) moved 40 mm; the lower one stayed.
      const Eigen::Vector3f top = cell.scene.parts().back().T_base_part.translation();
      const float moved = std::min((top - before[0]).head<2>().norm(), (top - before[1]).head<2>().norm());
      if (drags)
        EXPECT_GT(moved, 0.035f);
      else
        EXPECT_LT(moved, 1e-4f);
      EXPECT_EQ(cell.pipeline->run_cycle().search, !drags);
    }
}

// ---------------------------------------------------------------------------------------------------
// Determinism of the simulated picking test (with a fixed compute time on the simulated clock, the
// cycles do not depend on how long the computer took), with driver faults injected on a seeded
// schedule. Two cells built alike run the same cycles bit for bit.

TEST(Determinism, SimulatedPickingWithFaultsIsBitIdenticalTwiceInOneProcess) {
  struct Trace {
    std::vector<int> statuses, recognized, remaining, faults;
    std::vector<double> times;  // cycle time, wait, detour, processing, timeline ends
    std::vector<S> grasps;      // T_base_grasp of each grasping cycle
  };
  auto run = [] {
    simcell::CellOptions o;
    o.part = sim::PartType::circle_nut;
    o.parts = 3;
    o.seed = 2;
    cycle::PipelineSettings<S> ps;
    ps.seed = o.seed;
    ps.fixed_compute_time = 0.060;
    simcell::Cell cell(o, ps);
    simcell::FaultSchedule schedule(0.5, o.seed);
    Trace t;
    for (int k = 0; k < 8 && cell.remaining() > 0; ++k) {
      const simcell::Arm arm = schedule.next();
      cell.arm(arm);
      const auto r = cell.pipeline->run_cycle();
      EXPECT_FALSE(cell.fused_wrong_pose(r)) << "cycle " << k;
      t.statuses.push_back(int(r.status));
      t.recognized.push_back(r.recognized);
      t.remaining.push_back(cell.remaining());
      t.faults.push_back(cell.fired(arm) ? int(arm.fault) : 0);
      for (double x : {r.takt.cycle_time, r.takt.robot_wait, r.takt.detour, r.takt.processing}) t.times.push_back(x);
      for (const auto& e : r.timeline.entries()) t.times.push_back(e.end);
      if (r.status == cycle::CycleStatus::picked || r.status == cycle::CycleStatus::grasp_failed)
        t.grasps.insert(t.grasps.end(), r.T_base_grasp.matrix().data(), r.T_base_grasp.matrix().data() + 16);
    }
    return t;
  };
  const Trace a = run(), b = run();
  EXPECT_EQ(a.statuses, b.statuses);
  EXPECT_EQ(a.recognized, b.recognized);
  EXPECT_EQ(a.remaining, b.remaining);
  EXPECT_EQ(a.faults, b.faults);
  ASSERT_EQ(a.times.size(), b.times.size());
  EXPECT_EQ(0, std::memcmp(a.times.data(), b.times.data(), a.times.size() * sizeof(double)));
  ASSERT_EQ(a.grasps.size(), b.grasps.size());
  EXPECT_EQ(0, std::memcmp(a.grasps.data(), b.grasps.data(), a.grasps.size() * sizeof(S)));
  // The run exercised what it claims to: faults fired, and parts were picked.
  EXPECT_GT(std::count_if(a.faults.begin(), a.faults.end(), [](int f) { return f != 0; }), 0);
  EXPECT_GT(std::count(a.statuses.begin(), a.statuses.end(), int(cycle::CycleStatus::picked)), 0);
}
