#pragma once
// The simulated cell's heavy class templates for float and the pinhole camera (and Fuser for double,
// which the reliability tests use), compiled once in
// sim_cell.cpp (library binpick_sim_cell) instead of in every tool and test that uses them: each such
// translation unit took minutes under the sanitizers (binpick_sim.cpp 150 s -> 65 s at -O1 with these
// declarations). A declaration only keeps out the members that are not inline, so the heavy entry
// points (PickingPipeline's constructor and run_cycle, Fuser::fuse_into) are defined below their
// classes: binpick_sim.cpp then compiles in 14 s instead of 65 s (Release, GCC). Project-internal:
// integrators instantiate the library's templates as they like.
#include "binpick/core/camera_model.hpp"
#include "binpick/fusion/fuse.hpp"
#include "binpick/sim.hpp"
#include "binpick/sim/reference_estimator.hpp"

extern template class binpick::Fuser<float, binpick::PinholeCamera<float>>;
extern template class binpick::Fuser<double, binpick::PinholeCamera<double>>;
extern template class binpick::sim::Scene<float>;
extern template class binpick::sim::StereoSensor<float>;
extern template class binpick::sim::FakeSensor<float>;
extern template class binpick::sim::FakeRobot<float>;
extern template class binpick::sim::ReferenceEstimator<float, binpick::PinholeCamera<float>>;
