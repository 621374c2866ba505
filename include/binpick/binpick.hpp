#pragma once
/// \file binpick.hpp
/// Umbrella header: every module the library ships (the simulation, binpick/sim, stays out).
#include "binpick/core.hpp"
#include "binpick/fusion.hpp"
#include "binpick/registration.hpp"
#include "binpick/geometry.hpp"
#include "binpick/active_vision.hpp"
