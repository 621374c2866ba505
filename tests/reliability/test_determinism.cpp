// Determinism: the same inputs, seed and thread count give bit-identical results when run twice in one
// process (the two-process check is test_determinism.sh around reliability_fingerprint). Where the
// thread count changes the last bits it is measured here and documented in the module's header.
#include <cstring>
#include <string>
#include <type_traits>
#include <vector>

#include <gtest/gtest.h>

#include "binpick/fusion.hpp"
#include "synthetic_views.hpp"

#if __has_include("binpick/registration/icp.hpp")
#include "binpick/registration.hpp"
#include "sim_instances.hpp"  // the simulated cell's templates, compiled once
#define BINPICK_RELIABILITY_REGISTRATION 1
#endif

namespace binpick::reliability {
namespace {

template <typename Scalar>
bool same_bits(const std::vector<Scalar>& a, const std::vector<Scalar>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(Scalar)) == 0;
}

template <typename Scalar>
bool same_bits(const Isometry3<Scalar>& a, const Isometry3<Scalar>& b) {
  return std::memcmp(a.matrix().data(), b.matrix().data(), 16 * sizeof(Scalar)) == 0;
}

template <typename Scalar>
FusionResult<Scalar> run_fusion(const SyntheticViews<Scalar>& s, int threads, bool registration) {
  FusionSettings<Scalar> settings;
  settings.num_threads = threads;
  settings.compute_votes = true;
  settings.sensor_accuracy = Scalar(0.001);
#ifdef BINPICK_RELIABILITY_REGISTRATION
  settings.register_views = registration;
#else
  (void)registration;
#endif
  Fuser<Scalar, PinholeCamera<Scalar>> fuser(s.camera);
  return fuser.fuse(s.views(), s.T_base_views, settings);
}

template <typename Scalar>
void expect_identical(const FusionResult<Scalar>& a, const FusionResult<Scalar>& b) {
  EXPECT_TRUE(same_bits(a.depth.storage(), b.depth.storage()));
  EXPECT_EQ(a.votes.votes, b.votes.votes);
  ASSERT_EQ(a.views.size(), b.views.size());
  for (std::size_t i = 0; i < a.views.size(); ++i) {
    EXPECT_TRUE(same_bits(a.views[i].T_base_view, b.views[i].T_base_view)) << "view " << i;
    EXPECT_EQ(a.views[i].pose, b.views[i].pose) << "view " << i;
  }
}

template <typename Scalar>
class Determinism : public ::testing::Test {};
using Scalars = ::testing::Types<float, double>;
// Named by the scalar (also gives the macro's optional argument, which Clang warns about when missing).
struct ScalarName {
  template <typename T>
  static std::string GetName(int) {
    return std::is_same<T, float>::value ? "float" : "double";
  }
};
TYPED_TEST_SUITE(Determinism, Scalars, ScalarName);

TYPED_TEST(Determinism, FusionWithoutRegistrationIsBitIdenticalTwiceAndForAnyThreadCount) {
  using Scalar = TypeParam;
  const auto s = make_synthetic_views<Scalar>(5, 7);
  const auto a1 = run_fusion(s, 1, false), b1 = run_fusion(s, 1, false);
  const auto a2 = run_fusion(s, 2, false), b2 = run_fusion(s, 2, false);
  ASSERT_GT(a1.valid_pixels, 0u);
  expect_identical(a1, b1);
  expect_identical(a2, b2);
  // Voting is per pixel and reprojection per view with a z-test min: no reduction crosses threads, so
  // the thread count does not change a bit (fuse.hpp).
  expect_identical(a1, a2);
}

#ifdef BINPICK_RELIABILITY_REGISTRATION
TYPED_TEST(Determinism, FusionWithRegistrationIsBitIdenticalTwiceAndForAnyThreadCount) {
  using Scalar = TypeParam;
  const auto s = make_synthetic_views<Scalar>(5, 11);
  for (int threads : {1, 2}) {
    const auto a = run_fusion(s, threads, true), b = run_fusion(s, threads, true);
    ASSERT_GT(a.valid_pixels, 0u);
    expect_identical(a, b);
  }
  // Views are registered in parallel, each view's ICP on one thread (fuse.hpp): no sum is split
  // across threads, so the registered poses and the fused depth do not change a bit.
  const auto a1 = run_fusion(s, 1, true), a2 = run_fusion(s, 2, true);
  std::size_t registered = 0;
  for (const auto& v : a1.views) registered += v.pose == ViewPose::registered;
  EXPECT_GT(registered, 0u);
  expect_identical(a1, a2);
}

TYPED_TEST(Determinism, IcpIsBitIdenticalTwiceForAFixedThreadCount) {
  using Scalar = TypeParam;
  const auto s = make_synthetic_views<Scalar>(2, 5);
  const auto views = s.views();
  const auto target = make_projective_target(views[0], s.camera, ProjectiveAssociationSettings{}, OrganizedNormalSettings<Scalar>{});
  const Isometry3<Scalar> prior = s.T_base_views[0].inverse(Eigen::Isometry) * s.T_base_views[1];
  for (int threads : {1, 2}) {
    IcpSettings<Scalar> settings;
    settings.num_threads = threads;
    OrganizedNormalSettings<Scalar> normals;
    normals.num_threads = threads;
    const auto a = align_depth_view(views[1], s.camera, target, prior, settings, normals);
    const auto b = align_depth_view(views[1], s.camera, target, prior, settings, normals);
    EXPECT_TRUE(same_bits(a.T_target_source, b.T_target_source)) << threads << " threads";
    EXPECT_EQ(a.iterations, b.iterations);
    EXPECT_EQ(a.inliers, b.inliers);
    EXPECT_EQ(std::memcmp(&a.rmse, &b.rmse, sizeof a.rmse), 0);
  }
}
#endif

}  // namespace
}  // namespace binpick::reliability
