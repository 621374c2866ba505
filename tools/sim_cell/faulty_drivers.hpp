#pragma once
// Fault injection around the simulated drivers: wrappers that model the same driver concepts as
// sim::FakeSensor and sim::FakeRobot and, when armed, inject one fault at a chosen call. The fake
// drivers themselves are unchanged. Faults (issue: driver faults):
//   frame_lost     the k-th frame of the cycle never reaches the on-board memory
//   frame_late     the k-th frame reaches memory only after the cycle read its frames
//   pose_fails     the k-th pose read throws (the controller did not answer)
//   pose_stale     the k-th pose read returns an old sample: the pose and time of a read 0.5 s earlier
//   robot_stops    the k-th motion command stops half way along its first segment (arrival unchanged)
// The sensor wrapper also records where the camera truly was at each trigger, so a run can check
// that no cycle fused a view whose pose read was far from the truth. FaultSchedule draws the faults of
// a run from a seed; FaultLedger counts what each one cost. Used by binpick_sim (--fault-rate) and
// binpick_soak through the simulated cell (sim_cell.hpp).
#include <cstdint>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "binpick/cycle/drivers.hpp"
#include "binpick/cycle/pipeline.hpp"
#include "binpick/sim/fake_robot.hpp"
#include "binpick/sim/fake_sensor.hpp"

namespace binpick::simcell {

enum class Fault { none, frame_lost, frame_late, pose_fails, pose_stale, robot_stops };
constexpr int kNumFaults = 6;
inline const char* to_string(Fault f) {
  switch (f) {
    case Fault::none: return "none";
    case Fault::frame_lost: return "frame_lost";
    case Fault::frame_late: return "frame_late";
    case Fault::pose_fails: return "pose_fails";
    case Fault::pose_stale: return "pose_stale";
    case Fault::robot_stops: return "robot_stops";
  }
  return "unknown";
}

/// One armed fault: which kind and at which call (1-based) of the cycle; `fired` once injected.
struct Arm {
  Fault fault = Fault::none;
  int at_call = 1;
  bool fired = false;
};

template <typename Scalar_>
class FaultyRobot {
 public:
  using Scalar = Scalar_;
  using Pose = Isometry3<Scalar>;
  FaultyRobot(sim::FakeRobot<Scalar>& robot, const sim::SimClock& clock) : robot_(&robot), clock_(&clock) {}

  void arm(const Arm& a) {
    arm_ = a;
    reads_ = moves_ = 0;
  }
  const Arm& armed() const { return arm_; }

  double move_along(const std::vector<Pose>& path, Scalar speed_percent) {
    ++moves_;
    if (arm_.fault == Fault::robot_stops && !arm_.fired && moves_ == arm_.at_call) {
      arm_.fired = true;
      // Plan the whole motion to learn its arrival time, then replace it by a stop half way along the
      // first segment: the robot reports arrival as planned but stands elsewhere.
      const double arrival = robot_->move_along(path, speed_percent);
      const double t0 = clock_->now();
      const Pose start = robot_->true_flange_pose(t0);
      Pose mid = start;
      mid.translation() = (start.translation() + path.front().translation()) / Scalar(2);
      robot_->move_along({mid}, speed_percent);
      return arrival;
    }
    return robot_->move_along(path, speed_percent);
  }
  bool is_moving() const { return robot_->is_moving(); }
  cycle::StampedPose<Scalar> read_flange_pose() {
    ++reads_;
    cycle::StampedPose<Scalar> r = robot_->read_flange_pose();
    history_.push_back(r);
    if (history_.size() > 256) history_.erase(history_.begin(), history_.begin() + 128);
    if (!arm_.fired && reads_ == arm_.at_call) {
      if (arm_.fault == Fault::pose_fails) {
        arm_.fired = true;
        throw std::runtime_error("injected fault: the controller did not answer the pose read");
      }
      if (arm_.fault == Fault::pose_stale) {
        arm_.fired = true;
        // The newest sample at least 0.5 s older than this read (or the oldest one kept).
        for (auto it = history_.rbegin(); it != history_.rend(); ++it)
          if (it->time <= r.time - 0.5 || it + 1 == history_.rend()) return *it;
      }
    }
    return r;
  }

 private:
  sim::FakeRobot<Scalar>* robot_;
  const sim::SimClock* clock_;
  Arm arm_;
  int reads_ = 0, moves_ = 0;
  std::vector<cycle::StampedPose<Scalar>> history_;
};

template <typename Scalar_>
class FaultySensor {
 public:
  using Scalar = Scalar_;
  using Camera = typename sim::FakeSensor<Scalar>::Camera;
  FaultySensor(sim::FakeSensor<Scalar>& sensor, const sim::FakeRobot<Scalar>& robot) : sensor_(&sensor), robot_(&robot) {}

  void arm(const Arm& a) {
    arm_ = a;
    triggers_ = 0;
    truth_.clear();
  }
  const Arm& armed() const { return arm_; }
  /// True camera pose at each trigger of the current cycle, in trigger order (lost frames included).
  const std::vector<Isometry3<Scalar>>& truth() const { return truth_; }

  const Camera& camera() const { return sensor_->camera(); }
  Scalar accuracy() const { return sensor_->accuracy(); }
  double trigger() {
    ++triggers_;
    const double t = sensor_->trigger();
    truth_.push_back(camera_pose_in_base(robot_->true_flange_pose(t), sensor_->T_flange_camera()));
    if (!arm_.fired && triggers_ == arm_.at_call && (arm_.fault == Fault::frame_lost || arm_.fault == Fault::frame_late)) {
      arm_.fired = true;
      auto frames = sensor_->read_frames();  // take the new frame back out of the on-board memory
      held_.insert(held_.end(), std::make_move_iterator(frames.begin()), std::make_move_iterator(frames.end() - 1));
      if (arm_.fault == Fault::frame_late) late_.push_back(std::move(frames.back()));
      // frame_lost: dropped. Restore the others in order (they stay in `held_` until the next read).
    }
    return t;
  }
  std::size_t frames_in_memory() const { return sensor_->frames_in_memory() + held_.size(); }
  std::vector<cycle::DepthFrame<Scalar>> read_frames() {
    std::vector<cycle::DepthFrame<Scalar>> out = std::move(held_);
    held_.clear();
    auto rest = sensor_->read_frames();
    out.insert(out.end(), std::make_move_iterator(rest.begin()), std::make_move_iterator(rest.end()));
    // A late frame lands in memory after this read: the next read (or drain) sees it.
    held_ = std::move(late_);
    late_.clear();
    return out;
  }

 private:
  sim::FakeSensor<Scalar>* sensor_;
  const sim::FakeRobot<Scalar>* robot_;
  Arm arm_;
  int triggers_ = 0;
  std::vector<Isometry3<Scalar>> truth_;
  std::vector<cycle::DepthFrame<Scalar>> held_, late_;
};

static_assert(cycle::is_robot_driver<FaultyRobot<float>>::value, "FaultyRobot models RobotDriver");
static_assert(cycle::is_sensor_driver<FaultySensor<float>>::value, "FaultySensor models SensorDriver");

/// The seeded fault schedule of a run: before each cycle, with probability `rate`, one fault of a
/// uniformly drawn kind at a uniformly drawn call 1..4 (a view for sensor and pose faults, a motion for
/// robot_stops); otherwise none.
class FaultSchedule {
 public:
  /// Throws std::invalid_argument naming `rate` outside [0, 1].
  FaultSchedule(double rate, std::uint64_t seed) : rate_(rate), rng_(seed * 0x9E3779B97F4A7C15ULL + 0xfa17ULL) {
    if (!(rate >= 0 && rate <= 1)) throw std::invalid_argument("rate: must be in [0, 1]");
  }
  Arm next() {
    Arm a;
    if (rate_ > 0 && cycle::detail::uniform01(rng_) < rate_) {
      a.fault = Fault(1 + int(cycle::detail::splitmix64(rng_) % (kNumFaults - 1)));
      a.at_call = 1 + int(cycle::detail::splitmix64(rng_) % 4);
    }
    return a;
  }

 private:
  double rate_;
  std::uint64_t rng_;
};

/// What the injected faults cost, per kind: how many were armed and how many fired (a fault at a call
/// the cycle never made does not fire), how each faulted cycle ended, the cycles lost (the faulted
/// cycle when it picked nothing, plus the failed cycles after it until a normal one) and the faulted
/// cycles that fused a view with a wrong pose (must stay 0).
class FaultLedger {
 public:
  struct Stats {
    int armed = 0, fired = 0, cycles_lost = 0, wrong_pose_used = 0;
    std::map<std::string, int> outcomes;
  };

  /// One cycle: the fault armed before it (Fault::none for a normal cycle), whether it fired, the
  /// cycle's status and whether it fused a view with a wrong pose.
  void record(const Arm& armed, bool fired, cycle::CycleStatus status, bool wrong_pose) {
    const bool failed = status == cycle::CycleStatus::sensor_failure || status == cycle::CycleStatus::robot_failure ||
                        status == cycle::CycleStatus::processing_failure;
    if (open_ >= 0) {  // the cycles after a fault that still fail (e.g. the recovery)
      if (failed) ++stats_[open_].cycles_lost;
      else open_ = -1;
    }
    if (armed.fault == Fault::none) return;
    Stats& f = stats_[int(armed.fault)];
    ++f.armed;
    if (!fired) return;
    ++f.fired;
    ++f.outcomes[cycle::to_string(status)];
    f.wrong_pose_used += wrong_pose;
    if (status != cycle::CycleStatus::picked) ++f.cycles_lost;  // the faulted cycle picked nothing
    if (failed) open_ = int(armed.fault);
  }
  /// Adds another run's counts (a run's trailing failures stay with that run).
  void merge(const FaultLedger& o) {
    for (int k = 0; k < kNumFaults; ++k) {
      Stats& a = stats_[k];
      const Stats& b = o.stats_[k];
      a.armed += b.armed, a.fired += b.fired, a.cycles_lost += b.cycles_lost, a.wrong_pose_used += b.wrong_pose_used;
      for (const auto& [name, n] : b.outcomes) a.outcomes[name] += n;
    }
  }
  const Stats& operator[](Fault f) const { return stats_[int(f)]; }
  int fired() const {
    int n = 0;
    for (const auto& s : stats_) n += s.fired;
    return n;
  }
  /// {"frame_lost": {"armed": .., "fired": .., "cycles_lost": .., "wrong_pose_used": .., "outcomes": {..}}, ...}
  std::string json() const {
    std::string js = "{";
    for (int f = 1; f < kNumFaults; ++f) {
      const Stats& s = stats_[f];
      js += std::string(f > 1 ? ", " : "") + "\"" + to_string(Fault(f)) + "\": {\"armed\": " + std::to_string(s.armed) +
            ", \"fired\": " + std::to_string(s.fired) + ", \"cycles_lost\": " + std::to_string(s.cycles_lost) +
            ", \"wrong_pose_used\": " + std::to_string(s.wrong_pose_used) + ", \"outcomes\": {";
      bool first = true;
      for (const auto& [name, n] : s.outcomes) js += std::string(first ? "" : ", ") + "\"" + name + "\": " + std::to_string(n), first = false;
      js += "}}";
    }
    return js + "}";
  }

 private:
  Stats stats_[kNumFaults];
  int open_ = -1;
};

}  // namespace binpick::simcell

// Compiled once in sim_cell.cpp (see sim_instances.hpp).
extern template class binpick::simcell::FaultyRobot<float>;
extern template class binpick::simcell::FaultySensor<float>;
