#pragma once
/// \file core.hpp
/// Core types: errors, scalar traits, poses, camera models, depth images.
#include "binpick/core/brown_conrady_camera.hpp"
#include "binpick/core/camera_model.hpp"
#include "binpick/core/depth_image.hpp"
#include "binpick/core/errors.hpp"
#include "binpick/core/parallel.hpp"
#include "binpick/core/pose.hpp"
#include "binpick/core/scalar_traits.hpp"
#include "binpick/core/simd_level.hpp"
