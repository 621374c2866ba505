#pragma once
/// \file cycle.hpp
/// Umbrella header of the picking cycle: driver concepts, gripper concept, takt model and timeline, and
/// the cycle pipeline of Fig. 2.
#include "binpick/cycle/bin_volume.hpp"
#include "binpick/cycle/drivers.hpp"
#include "binpick/cycle/gripper.hpp"
#include "binpick/cycle/pipeline.hpp"
#include "binpick/cycle/takt.hpp"
