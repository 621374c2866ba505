// Compile-time guard: the reference estimator never sees the simulated scene. This translation unit
// includes only the estimator's header and then declares an unrelated, non-template
// binpick::sim::Scene — which fails to compile if the estimator's header pulled in scene.hpp (where
// Scene is a class template). The type-level half of the guard is in test_estimator.cpp.
#include <type_traits>

#include "binpick/core/camera_model.hpp"
#include "binpick/sim/reference_estimator.hpp"

namespace binpick::sim {
struct Scene {};  // would clash with scene.hpp's template<typename> class Scene
}  // namespace binpick::sim

namespace {
using Estimator = binpick::sim::ReferenceEstimator<float, binpick::PinholeCamera<float>>;
static_assert(!std::is_constructible<Estimator, binpick::sim::Scene>::value, "the estimator takes no scene");
}  // namespace

int binpick_estimator_guard_translation_unit() { return 0; }
