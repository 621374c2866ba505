#pragma once
/// \file sim.hpp
/// Umbrella header of the simulated cell: parts, piled scene, stereo sensor with the metal error model,
/// fake sensor and robot drivers, simulated clock. Kept out of binpick.hpp: the library never includes
/// the simulation.
#include "binpick/sim/fake_robot.hpp"
#include "binpick/sim/fake_sensor.hpp"
#include "binpick/sim/grasp_model.hpp"
#include "binpick/sim/mesh.hpp"
#include "binpick/sim/parts.hpp"
#include "binpick/sim/ray_caster.hpp"
#include "binpick/sim/reference_estimator.hpp"
#include "binpick/sim/scene.hpp"
#include "binpick/sim/sim_clock.hpp"
#include "binpick/sim/stereo_sensor.hpp"
