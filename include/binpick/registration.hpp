#pragma once
/// \file registration.hpp
/// Registration (paper §III.B.2): normals, data association (FLANN kNN, projective), point-to-plane
/// and point-to-point ICP, and the depth-view entry point.
#include "binpick/registration/align_depth_views.hpp"
#include "binpick/registration/correspondence.hpp"
#include "binpick/registration/icp.hpp"
#include "binpick/registration/kdtree.hpp"
#include "binpick/registration/knn_association.hpp"
#include "binpick/registration/normals.hpp"
#include "binpick/registration/point_cloud.hpp"
#include "binpick/registration/projective_association.hpp"
