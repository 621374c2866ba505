#pragma once
/// \file fusion.hpp
/// Multi-view depth fusion into one view (paper §III.B.3, Alg. 1).
