#pragma once
/// \file sim_clock.hpp
/// Simulated time for the simulated cell (models cycle::Clock): sleeping jumps instead of blocking,
/// so a simulated picking cycle runs as fast as the computer allows while every timestamp and
/// duration it reports is in cell seconds.

#include <cmath>

#include "binpick/core/errors.hpp"
#include "binpick/cycle/drivers_clock.hpp"

namespace binpick::sim {

class SimClock {
 public:
  /// Starts at `start` [s]. Throws std::invalid_argument naming `start` when it is not finite.
  explicit SimClock(double start = 0) : now_(start) { require(std::isfinite(start), "start", "must be finite"); }

  double now() const { return now_; }
  /// Jumps to t [s] when it is later than now.
  void sleep_until(double t) {
    require(!std::isnan(t), "t", "must not be NaN");
    if (t > now_ && std::isfinite(t)) now_ = t;
  }
  /// Advances by dt [s] >= 0 (e.g. the measured processing time of a pipeline stage). Throws
  /// std::invalid_argument naming `dt` for a negative or non-finite step.
  void advance(double dt) {
    require(std::isfinite(dt) && dt >= 0, "dt", "must be finite and >= 0");
    now_ += dt;
  }

 private:
  double now_;
};

static_assert(cycle::is_clock<SimClock>::value, "SimClock models Clock");

}  // namespace binpick::sim
