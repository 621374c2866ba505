// Prints a fingerprint (FNV-1a of every output bit) of fusion with and without registration on the
// synthetic views, for float and double and 1 and 2 threads, one JSON line each. test_determinism.sh
// runs it in two processes and compares the outputs byte for byte.
#include <cinttypes>
#include <cstdio>

#include "binpick/fusion.hpp"
#include "sim_instances.hpp"  // Fuser<float / double, pinhole>, compiled once
#include "synthetic_views.hpp"

#if __has_include("binpick/registration/icp.hpp")
#define BINPICK_RELIABILITY_REGISTRATION 1
#endif

namespace br = binpick::reliability;

template <typename Scalar>
void print(int threads, bool registration) {
  const auto s = br::make_synthetic_views<Scalar>(5, 2024);
  binpick::FusionSettings<Scalar> settings;
  settings.num_threads = threads;
  settings.compute_votes = true;
#ifdef BINPICK_RELIABILITY_REGISTRATION
  settings.register_views = registration;
#else
  if (registration) return;
#endif
  binpick::Fuser<Scalar, binpick::PinholeCamera<Scalar>> fuser(s.camera);
  const auto r = fuser.fuse(s.views(), s.T_base_views, settings);
  std::uint64_t h = br::fnv1a(r.depth.data(), r.depth.storage().size() * sizeof(Scalar));
  h = br::fnv1a(r.votes.votes.data(), r.votes.votes.size(), h);
  for (const auto& v : r.views) h = br::fnv1a(v.T_base_view.matrix().data(), 16 * sizeof(Scalar), h);
  std::printf("{\"scalar\": \"%s\", \"threads\": %d, \"registration\": %s, \"valid_pixels\": %zu, \"fingerprint\": \"%016" PRIx64 "\"}\n",
              sizeof(Scalar) == 4 ? "float" : "double", threads, registration ? "true" : "false", r.valid_pixels, h);
}

int main() {
  for (bool reg : {false, true})
    for (int threads : {1, 2}) {
      print<float>(threads, reg);
      print<double>(threads, reg);
    }
  return 0;
}
