#pragma once
/// \file fake_robot.hpp
/// A simulated arm (models cycle::RobotDriver). The flange moves through the commanded poses along
/// straight lines with slerped orientation, each segment at constant speed (the paper's sensing path
/// assumes a constant speed v, §III.D.1; 100 % ≈ 1 m/s, §III.D.2). Acceleration is not modelled: it
/// starts and stops instantly and stops exactly at the last pose (the pull-up point, §III.B.2).
///
/// Pose reads: at rest a read is exact. While moving it returns where the flange was `lag` seconds
/// before the read, lag = latency + jitter·N(0, 1) (≥ 0, seeded per read) — the imperfect hand-eye
/// synchronization the fusion's ICP absorbs (§III.B.2): the error is about latency × speed.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "binpick/core/errors.hpp"
#include "binpick/core/pose.hpp"
#include "binpick/cycle/drivers_robot.hpp"
#include "binpick/sim/detail/random.hpp"
#include "binpick/sim/sim_clock.hpp"

namespace binpick::sim {

template <typename Scalar>
struct FakeRobotSettings {
  Scalar full_speed = Scalar(1.0);                   ///< flange speed at 100 % [m/s]
  Scalar full_angular_speed = Scalar(M_PI);          ///< flange rotation speed at 100 % [rad/s]
  double latency = 0.020;                            ///< mean lateness of a pose read while moving [s]
  double jitter = 0.004;                             ///< std. deviation of that lateness [s]
  std::uint64_t seed = 1;                            ///< keys the jitter draws
};

template <typename Scalar_>
class FakeRobot {
 public:
  using Scalar = Scalar_;
  using Pose = Isometry3<Scalar>;

  /// The flange stands at T_base_flange_start. Throws std::invalid_argument naming the argument for a
  /// non-rigid start pose, non-positive speeds, or a negative or non-finite latency/jitter.
  FakeRobot(const SimClock& clock, const Pose& T_base_flange_start, const FakeRobotSettings<Scalar>& settings = {})
      : clock_(&clock), s_(settings) {
    require_valid_pose(T_base_flange_start, "T_base_flange_start");
    require(std::isfinite(s_.full_speed) && s_.full_speed > 0, "full_speed", "must be finite and > 0");
    require(std::isfinite(s_.full_angular_speed) && s_.full_angular_speed > 0, "full_angular_speed",
            "must be finite and > 0");
    require(std::isfinite(s_.latency) && s_.latency >= 0, "latency", "must be finite and >= 0");
    require(std::isfinite(s_.jitter) && s_.jitter >= 0, "jitter", "must be finite and >= 0");
    poses_.push_back(T_base_flange_start);
    times_.push_back(clock.now());
  }

  /// Starts moving from the current pose through T_base_flange_path at speed_percent of full speed
  /// (a new command replaces the rest of a running one). Returns the arrival time [s]. Throws
  /// std::invalid_argument naming `T_base_flange_path` (empty, non-rigid pose) or `speed_percent`
  /// (not in (0, 100]).
  double move_along(const std::vector<Pose>& T_base_flange_path, Scalar speed_percent) {
    require(!T_base_flange_path.empty(), "T_base_flange_path", "is empty");
    require(std::isfinite(speed_percent) && speed_percent > 0 && speed_percent <= 100, "speed_percent",
            "must be in (0, 100]");
    for (const Pose& p : T_base_flange_path) require_valid_pose(p, "T_base_flange_path");
    const double t0 = clock_->now();
    const Pose start = true_flange_pose(t0);
    const Scalar v = s_.full_speed * speed_percent / Scalar(100);
    const Scalar w = s_.full_angular_speed * speed_percent / Scalar(100);
    poses_.assign(1, start);
    times_.assign(1, t0);
    for (const Pose& p : T_base_flange_path) {
      const Pose& a = poses_.back();
      const double dt = std::max(double((p.translation() - a.translation()).norm() / v),
                                 double(rotation_angle<Scalar>(relative_pose(a, p)) / w));
      poses_.push_back(p);
      times_.push_back(times_.back() + dt);
    }
    speed_ = v;
    return times_.back();
  }

  /// True while the flange moves at the clock's current time.
  bool is_moving() const { return clock_->now() < times_.back(); }
  /// Time the current motion ends [s] (the start time when idle).
  double arrival_time() const { return times_.back(); }
  /// Translation speed of the current motion [m/s].
  Scalar speed() const { return speed_; }

  /// What the controller reports now: exact at rest, `lag` seconds late while moving (file comment).
  cycle::StampedPose<Scalar> read_flange_pose() {
    const double now = clock_->now();
    cycle::StampedPose<Scalar> r;
    r.time = now;
    if (!is_moving()) {
      r.T_base_flange = true_flange_pose(now);
      return r;
    }
    sim::detail::Rng rng(sim::detail::hash_keys(s_.seed, 0x40b07ULL, reads_++));
    const double lag = std::max(0.0, s_.latency + s_.jitter * rng.normal());
    r.T_base_flange = true_flange_pose(now - lag);
    return r;
  }

  /// Ground truth: where the flange is at time t [s] of the current motion.
  Pose true_flange_pose(double t) const {
    if (!(t > times_.front())) return poses_.front();
    if (t >= times_.back()) return poses_.back();  // exactly the commanded end pose
    const std::size_t k = std::size_t(std::upper_bound(times_.begin(), times_.end(), t) - times_.begin());  // times_[k-1] <= t < times_[k]
    const Pose& a = poses_[k - 1];
    const Pose& b = poses_[k];
    const double span = times_[k] - times_[k - 1];
    const Scalar s = span > 0 ? Scalar((t - times_[k - 1]) / span) : Scalar(1);
    Pose p = Pose::Identity();
    p.translation() = a.translation() + s * (b.translation() - a.translation());
    p.linear() = Eigen::Quaternion<Scalar>(a.linear()).slerp(s, Eigen::Quaternion<Scalar>(b.linear())).toRotationMatrix();
    return p;
  }

 private:
  const SimClock* clock_;
  FakeRobotSettings<Scalar> s_;
  std::vector<Pose> poses_;    // waypoints of the current motion, starting at its start pose
  std::vector<double> times_;  // time each waypoint is reached
  Scalar speed_ = 0;
  std::uint64_t reads_ = 0;
};

static_assert(cycle::is_robot_driver<FakeRobot<double>>::value, "FakeRobot models RobotDriver");

}  // namespace binpick::sim
