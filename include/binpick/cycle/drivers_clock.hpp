#pragma once
/// \file drivers_clock.hpp
/// The `Clock` concept: the one source of time of a picking cycle. Robot and sensor drivers stamp
/// poses and frames with it, so a simulated clock makes a simulated cycle run faster than real time
/// while every reported duration is in real (cell) seconds.
///
/// \code
/// struct MyClock {
///   double now() const;          // current time [s]; monotonic, arbitrary origin
///   void sleep_until(double t);  // returns once now() >= t [s]: a real clock blocks, a simulated
///                                // one jumps; no effect when t <= now()
/// };
/// \endcode
/// `binpick::cycle::is_clock<T>` checks the members at compile time. `SteadyClock` (here) adapts
/// std::chrono::steady_clock; the simulation has `sim::SimClock`.

#include <chrono>
#include <thread>
#include <type_traits>
#include <utility>

namespace binpick::cycle {

/// Compile-time check of the Clock concept above.
template <typename T, typename = void>
struct is_clock : std::false_type {};
template <typename T>
struct is_clock<T, std::void_t<decltype(double(std::declval<const T&>().now())),
                               decltype(std::declval<T&>().sleep_until(double()))>> : std::true_type {};

/// Wall-clock time of the cell (std::chrono::steady_clock), seconds since construction.
class SteadyClock {
 public:
  SteadyClock() : origin_(std::chrono::steady_clock::now()) {}
  double now() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - origin_).count();
  }
  void sleep_until(double t) {
    const double dt = t - now();
    if (dt > 0) std::this_thread::sleep_for(std::chrono::duration<double>(dt));
  }

 private:
  std::chrono::steady_clock::time_point origin_;
};

static_assert(is_clock<SteadyClock>::value, "SteadyClock models Clock");

}  // namespace binpick::cycle
