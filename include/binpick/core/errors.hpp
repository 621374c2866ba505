#pragma once
/// \file errors.hpp
/// Precondition checks. User preconditions are always checked and throw `std::invalid_argument`
/// naming the argument (through one cold, non-inlined function so the check costs one branch);
/// internal invariants use `assert` (debug only). Numerical failure is never an exception: it is a
/// status in a result struct.

#include <cmath>
#include <stdexcept>
#include <string>

namespace binpick {
namespace detail {

[[noreturn]] inline __attribute__((noinline, cold)) void throw_invalid_argument(const char* argument,
                                                                                 const std::string& why) {
  throw std::invalid_argument(std::string("binpick: argument '") + argument + "': " + why);
}

}  // namespace detail

/// Throws `std::invalid_argument("binpick: argument '<argument>': <why>")` unless `condition` holds.
inline void require(bool condition, const char* argument, const char* why) {
  if (__builtin_expect(!condition, 0)) detail::throw_invalid_argument(argument, why);
}

/// Throws unless `value` is finite.
template <typename Scalar>
inline void require_finite(Scalar value, const char* argument) {
  if (__builtin_expect(!std::isfinite(value), 0)) detail::throw_invalid_argument(argument, "must be finite");
}

/// Throws unless every coefficient of an Eigen expression is finite.
template <typename Derived>
inline void require_all_finite(const Derived& m, const char* argument) {
  if (__builtin_expect(!m.allFinite(), 0)) detail::throw_invalid_argument(argument, "must be finite (NaN or inf found)");
}

}  // namespace binpick
