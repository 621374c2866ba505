#pragma once
/// \file fake_sensor.hpp
/// The simulated hand-held stereo camera as a driver (models cycle::SensorDriver). A trigger renders
/// the scene from where the camera truly is at the trigger time — the robot's true flange pose times
/// the hand-eye transform — and keeps the frame in on-board memory until read_frames(), as the
/// paper's sensor does (§III.A, §IV.A). Exposure (3 ms) starts at the trigger; motion during it is
/// not rendered (≤ 3 mm at 1 m/s).

#include <cstdint>
#include <vector>

#include "binpick/core/camera_model.hpp"
#include "binpick/core/pose.hpp"
#include "binpick/cycle/drivers_sensor.hpp"
#include "binpick/sim/fake_robot.hpp"
#include "binpick/sim/scene.hpp"
#include "binpick/sim/sim_clock.hpp"
#include "binpick/sim/stereo_sensor.hpp"

namespace binpick::sim {

template <typename Scalar_>
class FakeSensor {
 public:
  using Scalar = Scalar_;
  using Camera = PinholeCamera<Scalar>;

  /// The scene, robot and clock are referenced, not copied (the scene may change between triggers:
  /// the geometry is rebuilt on a new scene revision). Throws std::invalid_argument naming the
  /// argument for a non-rigid T_flange_camera or invalid sensor settings.
  FakeSensor(const Scene<Scalar>& scene, const FakeRobot<Scalar>& robot, const SimClock& clock,
             const Isometry3<Scalar>& T_flange_camera, const StereoSensorSettings<Scalar>& settings = {})
      : scene_(&scene), robot_(&robot), clock_(&clock), T_flange_camera_(T_flange_camera), sensor_(settings) {
    require_valid_pose(T_flange_camera, "T_flange_camera");
  }

  const Camera& camera() const { return sensor_.camera(); }
  Scalar accuracy() const { return sensor_.settings().accuracy; }
  double exposure() const { return 0.003; }  ///< [s] (§IV.A)
  const Isometry3<Scalar>& T_flange_camera() const { return T_flange_camera_; }

  /// Captures now; returns the trigger time [s].
  double trigger() {
    const double t = clock_->now();
    if (!geometry_valid_ || revision_ != scene_->revision()) {
      geometry_ = SceneGeometry<Scalar>::build(*scene_, sensor_.settings().errors.bin_material,
                                               sensor_.settings().errors.table_material);
      revision_ = scene_->revision();
      geometry_valid_ = true;
    }
    const Isometry3<Scalar> T_base_camera = camera_pose_in_base(robot_->true_flange_pose(t), T_flange_camera_);
    memory_.push_back({sensor_.render(geometry_, T_base_camera, next_index_, workspace_), t});
    ++next_index_;
    return t;
  }

  std::size_t frames_in_memory() const { return memory_.size(); }

  /// The stored frames in capture order as depth images with their trigger times; clears the memory.
  std::vector<cycle::DepthFrame<Scalar>> read_frames() {
    std::vector<cycle::DepthFrame<Scalar>> out;
    for (auto& m : memory_) out.push_back({std::move(m.frame.depth), m.time, m.frame.frame_index});
    memory_.clear();
    return out;
  }

  /// Like read_frames() but with the simulation's ground truth (true camera pose, statistics and,
  /// with settings.diagnostics, the true depth and pixel status) — for evaluation, not for the cycle.
  std::vector<StereoFrame<Scalar>> read_frames_with_truth() {
    std::vector<StereoFrame<Scalar>> out;
    for (auto& m : memory_) out.push_back(std::move(m.frame));
    memory_.clear();
    return out;
  }

 private:
  struct Stored {
    StereoFrame<Scalar> frame;
    double time;
  };
  const Scene<Scalar>* scene_;
  const FakeRobot<Scalar>* robot_;
  const SimClock* clock_;
  Isometry3<Scalar> T_flange_camera_;
  StereoSensor<Scalar> sensor_;
  RenderWorkspace<Scalar> workspace_;  // render's scratch memory, kept across frames
  SceneGeometry<Scalar> geometry_;
  bool geometry_valid_ = false;
  std::uint64_t revision_ = 0;
  std::uint64_t next_index_ = 0;
  std::vector<Stored> memory_;
};

static_assert(cycle::is_sensor_driver<FakeSensor<float>>::value, "FakeSensor models SensorDriver");

}  // namespace binpick::sim
