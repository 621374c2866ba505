// Driver concepts and the simulated drivers: clock, robot (exact at rest, late while moving) and the
// sensor driver (frames rendered at the true pose of the trigger, kept until read).
#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include "binpick/cycle/drivers.hpp"
#include "binpick/sim.hpp"
#include "sim_instances.hpp"  // the simulated cell's templates, compiled once
#include "test_support.hpp"

using namespace binpick;
using namespace binpick::sim;

namespace {

// A foreign estimator adapted to the concept (compile-time check only).
struct NullEstimator {
  using Scalar = float;
  using Camera = PinholeCamera<float>;
  cycle::EstimationResult<float> estimate(const cycle::EstimatorInput<float, Camera>& input) {
    cycle::EstimationResult<float> r;
    r.status = input.camera ? cycle::EstimationStatus::no_objects : cycle::EstimationStatus::invalid_input;
    return r;
  }
};

Isometry3d pose(double x, double y, double z, double yaw = 0) {
  Isometry3d T = Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()) * Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ())).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, z);
  return T;
}

template <typename F>
void expect_invalid_argument_naming(F&& f, const std::string& name) {
  try {
    f();
    ADD_FAILURE() << "expected std::invalid_argument naming " << name;
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'" + name + "'"), std::string::npos) << e.what();
  }
}

}  // namespace

static_assert(cycle::is_clock<SimClock>::value && cycle::is_clock<cycle::SteadyClock>::value, "clocks");
static_assert(cycle::is_robot_driver<FakeRobot<double>>::value && cycle::is_robot_driver<FakeRobot<float>>::value, "robot");
static_assert(cycle::is_sensor_driver<FakeSensor<float>>::value && cycle::is_sensor_driver<FakeSensor<double>>::value, "sensor");
static_assert(cycle::is_pose_estimator<NullEstimator>::value, "estimator");
static_assert(!cycle::is_clock<int>::value && !cycle::is_robot_driver<SimClock>::value &&
                  !cycle::is_sensor_driver<FakeRobot<double>>::value && !cycle::is_pose_estimator<FakeSensor<float>>::value,
              "the traits reject other types");

TEST(SimClock, JumpsForwardOnly) {
  SimClock clock(1.0);
  clock.sleep_until(0.5);
  EXPECT_EQ(clock.now(), 1.0);
  clock.sleep_until(2.5);
  EXPECT_EQ(clock.now(), 2.5);
  clock.advance(0.25);
  EXPECT_EQ(clock.now(), 2.75);
  expect_invalid_argument_naming([&] { clock.advance(-1); }, "dt");
}

TEST(FakeRobot, ReadAtRestIsTheCommandedPose) {
  SimClock clock;
  FakeRobot<double> robot(clock, pose(0, 0, 0.4));
  EXPECT_FALSE(robot.is_moving());
  EXPECT_TRUE(robot.read_flange_pose().T_base_flange.isApprox(pose(0, 0, 0.4), 0));
  const std::vector<Isometry3d> path{pose(0.1, 0, 0.4), pose(0.1, 0.2, 0.45, 0.3)};
  const double arrival = robot.move_along(path, 50);
  // Length 0.1 + |(0, 0.2, 0.05)| at 0.5 m/s (translation dominates the 0.3 rad turn at 0.5π rad/s).
  EXPECT_NEAR(arrival, (0.1 + std::sqrt(0.04 + 0.0025)) / 0.5, 1e-12);
  EXPECT_TRUE(robot.is_moving());
  clock.sleep_until(arrival);
  EXPECT_FALSE(robot.is_moving());
  const auto read = robot.read_flange_pose();
  EXPECT_EQ(read.time, arrival);
  EXPECT_EQ(read.T_base_flange.matrix(), path.back().matrix()) << "stops exactly at the pull-up point";
}

RC_GTEST_PROP(FakeRobot, ReadWhileMovingLagsByLatencyTimesSpeed, ()) {
  SimClock clock;
  FakeRobotSettings<double> s;
  s.latency = test::uniform(0.005, 0.05);
  s.jitter = 0;
  const double percent = test::uniform(10, 100);
  FakeRobot<double> robot(clock, pose(-0.2, 0, 0.4), s);
  const double arrival = robot.move_along({pose(0.3, 0, 0.4)}, percent);  // 0.5 m straight line
  const double v = percent / 100.0;
  clock.sleep_until(test::uniform(s.latency, arrival * 0.999));
  RC_ASSERT(robot.is_moving());
  const auto read = robot.read_flange_pose();
  const Eigen::Vector3d truth = robot.true_flange_pose(clock.now()).translation();
  const double lag_distance = (truth - read.T_base_flange.translation()).norm();
  RC_ASSERT(std::abs(lag_distance - s.latency * v) < 1e-9);
  RC_ASSERT(read.T_base_flange.translation().x() < truth.x());  // behind, not ahead
  RC_ASSERT(read.time == clock.now());
}

TEST(FakeRobot, JitteredLagAveragesToTheLatency) {
  SimClock clock;
  FakeRobotSettings<double> s;
  s.latency = 0.02;
  s.jitter = 0.005;
  FakeRobot<double> robot(clock, pose(0, 0, 0.4), s);
  robot.move_along({pose(1.0, 0, 0.4)}, 80);  // 0.8 m/s for 1.25 s
  double sum = 0, sq = 0;
  const int n = 200;
  for (int i = 0; i < n; ++i) {
    clock.advance(0.005);
    const auto read = robot.read_flange_pose();
    const double lag = (robot.true_flange_pose(clock.now()).translation() - read.T_base_flange.translation()).norm() / 0.8;
    sum += lag;
    sq += lag * lag;
  }
  const double mean = sum / n, sd = std::sqrt(std::max(0.0, sq / n - mean * mean));
  EXPECT_NEAR(mean, 0.02, 0.002);
  EXPECT_NEAR(sd, 0.005, 0.0015);
}

TEST(FakeRobot, BadInputNamesTheArgument) {
  SimClock clock;
  FakeRobot<double> robot(clock, pose(0, 0, 0.4));
  expect_invalid_argument_naming([&] { robot.move_along({}, 50); }, "T_base_flange_path");
  expect_invalid_argument_naming([&] { robot.move_along({pose(0.1, 0, 0.4)}, -5); }, "speed_percent");
  expect_invalid_argument_naming([&] { robot.move_along({pose(0.1, 0, 0.4)}, 0); }, "speed_percent");
  expect_invalid_argument_naming([&] { robot.move_along({pose(0.1, 0, 0.4)}, 150); }, "speed_percent");
  Isometry3d nan_pose = pose(0, 0, 0.4);
  nan_pose.translation().x() = std::nan("");
  expect_invalid_argument_naming([&] { robot.move_along({nan_pose}, 50); }, "T_base_flange_path");
  FakeRobotSettings<double> s;
  s.latency = -0.01;
  expect_invalid_argument_naming([&] { FakeRobot<double>(clock, pose(0, 0, 0.4), s); }, "latency");
}

TEST(FakeSensor, TriggersRenderTheTruePoseAndWaitInMemory) {
  SceneSettings<float> ss;
  ss.part_type = PartType::pencil_coupler;
  const auto scene = Scene<float>::generate(ss, 4);
  SimClock clock;
  Isometry3f start = pose(0, 0, 0.3).cast<float>();
  FakeRobot<float> robot(clock, start);
  StereoSensorSettings<float> s;
  s.width = 160;
  s.height = 128;
  const Isometry3f T_flange_camera = Isometry3f::Identity();
  FakeSensor<float> sensor(scene, robot, clock, T_flange_camera, s);
  EXPECT_EQ(sensor.accuracy(), s.accuracy);
  EXPECT_EQ(sensor.camera().width(), 160);

  // View 1 at the pull-up stop, views 2..3 while moving, 30 ms apart (the paper's sensing path).
  const double t1 = sensor.trigger();
  robot.move_along({pose(0.05, 0, 0.3).cast<float>()}, 70);
  clock.advance(0.030);
  const double t2 = sensor.trigger();
  clock.advance(0.030);
  const double t3 = sensor.trigger();
  EXPECT_EQ(sensor.frames_in_memory(), 3u);
  EXPECT_DOUBLE_EQ(t2 - t1, 0.030);
  EXPECT_DOUBLE_EQ(t3 - t2, 0.030);
  auto frames = sensor.read_frames_with_truth();
  EXPECT_EQ(sensor.frames_in_memory(), 0u);
  ASSERT_EQ(frames.size(), 3u);
  const double times[3] = {t1, t2, t3};
  const StereoSensor<float> reference(s);
  for (std::size_t k = 0; k < 3; ++k) {
    const Isometry3f truth = robot.true_flange_pose(times[k]) * T_flange_camera;
    EXPECT_TRUE(frames[k].T_base_camera.isApprox(truth, 1e-6f)) << "frame " << k;
    EXPECT_EQ(frames[k].frame_index, k);
    // The same frame as rendering directly at the true pose with the same index.
    EXPECT_EQ(frames[k].depth.storage(), reference.render(scene, truth, k).depth.storage());
  }
  // The camera moved 21 mm between the first two views (0.7 m/s × 30 ms).
  EXPECT_NEAR((frames[1].T_base_camera.translation() - frames[0].T_base_camera.translation()).norm(), 0.021, 1e-5);

  sensor.trigger();
  const auto plain = sensor.read_frames();
  ASSERT_EQ(plain.size(), 1u);
  EXPECT_EQ(plain[0].trigger_time, clock.now());
  EXPECT_EQ(plain[0].index, 3u);
  EXPECT_EQ(plain[0].depth.width(), 160);
}
