#pragma once
/// \file active_vision.hpp
/// Active vision (paper §III.C–D): the target center of the next sensing path (Eq. 1), the sensing
/// path itself (Alg. 2), and the path parameters (v, t, n) <-> (α, β) with their offline determination.
#include "binpick/active_vision/arc_angle.hpp"
#include "binpick/active_vision/parameters.hpp"
#include "binpick/active_vision/sensing_path.hpp"
#include "binpick/active_vision/target_center.hpp"
