#pragma once
/// \file drivers.hpp
/// The adapters through which a cell plugs in: Clock, SensorDriver, RobotDriver, PoseEstimator.
#include "binpick/cycle/drivers_clock.hpp"
#include "binpick/cycle/drivers_estimator.hpp"
#include "binpick/cycle/drivers_robot.hpp"
#include "binpick/cycle/drivers_sensor.hpp"
