#pragma once
/// \file fusion.hpp
/// Multi-view depth fusion into one view (paper §III.B.3, Alg. 1).
#include "binpick/fusion/fuse.hpp"
#include "binpick/fusion/reproject.hpp"
#include "binpick/fusion/voting.hpp"
