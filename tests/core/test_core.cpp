#include <cstdint>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <rapidcheck/gtest.h>

#include "binpick/core.hpp"
#include "binpick/core/detail/huge_pages.hpp"
#include "binpick/core/detail/simd.hpp"
#include "test_support.hpp"

using namespace binpick;
using binpick::test::uniform;

namespace {

template <typename Scalar>
PinholeCamera<Scalar> random_pinhole() {
  // Realistic fields of view (normalized image coordinates within about ±0.6), so that moderate lens
  // distortion stays monotonic over the image.
  const int w = *rc::gen::inRange(16, 2048);
  const int h = std::max(8, int(w * uniform(0.5, 1.0)));
  const double f = w * uniform(0.8, 1.5);
  return PinholeCamera<Scalar>(Scalar(f), Scalar(f * uniform(0.9, 1.1)), Scalar(w * uniform(0.4, 0.6)),
                               Scalar(h * uniform(0.4, 0.6)), w, h);
}

template <typename Scalar>
BrownConradyCamera<Scalar> random_brown_conrady() {
  const PinholeCamera<Scalar> p = random_pinhole<Scalar>();
  // Moderate distortion, as real industrial lenses: monotonic over the image.
  BrownConradyDistortion<Scalar> d{Scalar(uniform(-0.2, 0.2)), Scalar(uniform(-0.05, 0.05)),
                                   Scalar(uniform(-1e-3, 1e-3)), Scalar(uniform(-1e-3, 1e-3)),
                                   Scalar(uniform(-0.01, 0.01))};
  return BrownConradyCamera<Scalar>(p.fx(), p.fy(), p.cx(), p.cy(), p.width(), p.height(), d);
}

// Tolerance on the round-trip pixel, per scalar type [px].
template <typename Scalar>
double pixel_tolerance() {
  return std::is_same<Scalar, float>::value ? 5e-2 : 1e-6;
}

template <typename Camera>
void check_roundtrip(const Camera& cam) {
  using Scalar = typename Camera::Scalar;
  const Scalar u = Scalar(uniform(0, cam.width() - 1));
  const Scalar v = Scalar(uniform(0, cam.height() - 1));
  const Scalar z = Scalar(uniform(0.05, 5.0));
  const auto p = cam.backproject(u, v, z);
  RC_ASSERT(std::abs(double(p.z() - z)) <= 1e-6 * z);
  const auto px = cam.project(p);
  RC_ASSERT(px.has_value());
  RC_ASSERT(std::abs(double(px->x() - u)) <= pixel_tolerance<Scalar>() * (1 + std::abs(double(u)) * 1e-3));
  RC_ASSERT(std::abs(double(px->y() - v)) <= pixel_tolerance<Scalar>() * (1 + std::abs(double(v)) * 1e-3));
}

}  // namespace

static_assert(is_camera_model<PinholeCameraf>::value, "pinhole is a camera model");
static_assert(is_camera_model<BrownConradyCamerad>::value, "Brown-Conrady is a camera model");
static_assert(!is_camera_model<int>::value, "int is not a camera model");

RC_GTEST_PROP(Camera, PinholeRoundTripDouble, ()) { check_roundtrip(random_pinhole<double>()); }
RC_GTEST_PROP(Camera, PinholeRoundTripFloat, ()) { check_roundtrip(random_pinhole<float>()); }
RC_GTEST_PROP(Camera, BrownConradyRoundTripDouble, ()) { check_roundtrip(random_brown_conrady<double>()); }
RC_GTEST_PROP(Camera, BrownConradyRoundTripFloat, ()) { check_roundtrip(random_brown_conrady<float>()); }

RC_GTEST_PROP(Camera, BrownConradyAgreesWithOpenCV, ()) {
  const auto cam = random_brown_conrady<double>();
  const auto& d = cam.distortion();
  cv::Mat K = (cv::Mat_<double>(3, 3) << cam.fx(), 0, cam.cx(), 0, cam.fy(), cam.cy(), 0, 0, 1);
  cv::Mat dist = (cv::Mat_<double>(1, 5) << d.k1, d.k2, d.p1, d.p2, d.k3);
  // A point seen near the image centre region (normalized coordinates up to ±0.4).
  const double x = uniform(-0.4, 0.4), y = uniform(-0.3, 0.3), z = uniform(0.1, 3.0);
  std::vector<cv::Point3d> obj{cv::Point3d(x * z, y * z, z)};
  std::vector<cv::Point2d> img;
  cv::projectPoints(obj, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, dist, img);
  const auto ours = cam.project(Eigen::Vector3d(x * z, y * z, z));
  if (img[0].x < -0.5 || img[0].y < -0.5 || img[0].x >= cam.width() - 0.5 || img[0].y >= cam.height() - 0.5) {
    RC_ASSERT(!ours.has_value());
  } else {
    RC_ASSERT(ours.has_value());
    RC_ASSERT(std::abs(ours->x() - img[0].x) < 1e-6);
    RC_ASSERT(std::abs(ours->y() - img[0].y) < 1e-6);
  }
}

TEST(Camera, ProjectRejectsBehindAndOutside) {
  PinholeCamerad cam(500, 500, 319.5, 239.5, 640, 480);
  EXPECT_FALSE(cam.project(Eigen::Vector3d(0, 0, -1)).has_value());
  EXPECT_FALSE(cam.project(Eigen::Vector3d(0, 0, 0)).has_value());
  EXPECT_FALSE(cam.project(Eigen::Vector3d(10, 0, 1)).has_value());
  EXPECT_FALSE(cam.project(Eigen::Vector3d(NAN, 0, 1)).has_value());
  ASSERT_TRUE(cam.project(Eigen::Vector3d(0, 0, 1)).has_value());
  EXPECT_DOUBLE_EQ(cam.project(Eigen::Vector3d(0, 0, 1))->x(), 319.5);
}

TEST(Camera, BadIntrinsicsThrowNamingTheArgument) {
  auto expect_names = [](auto&& make, const char* arg) {
    try {
      make();
      ADD_FAILURE() << "no exception for " << arg;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(std::string("'") + arg + "'"), std::string::npos) << e.what();
    }
  };
  expect_names([] { PinholeCamerad(0, 500, 1, 1, 10, 10); }, "fx");
  expect_names([] { PinholeCamerad(500, -1, 1, 1, 10, 10); }, "fy");
  expect_names([] { PinholeCamerad(500, 500, NAN, 1, 10, 10); }, "cx");
  expect_names([] { PinholeCamerad(500, 500, 1, INFINITY, 10, 10); }, "cy");
  expect_names([] { PinholeCameraf(500, 500, 1, 1, 0, 10); }, "width");
  expect_names([] { PinholeCameraf(500, 500, 1, 1, 10, -3); }, "height");
  expect_names([] { BrownConradyCamerad(500, 500, 1, 1, 10, 10, {NAN, 0, 0, 0, 0}); }, "k1");
  expect_names([] { BrownConradyCamerad(500, 500, 1, 1, 10, 10, {0, 0, 0, 0, INFINITY}); }, "k3");
}

TEST(DepthImageView, Uint16MillimetresWithStrideAndInvalids) {
  // 3 x 2 image inside rows of 5 elements (as a cv::Mat ROI would be).
  std::vector<std::uint16_t> buf = {1000, 0, 65535, 7, 7,  //
                                    250, 1, 2, 7, 7};
  DepthImageView<float> view(buf.data(), 3, 2, 5 * sizeof(std::uint16_t), 0.001f);
  EXPECT_FLOAT_EQ(view.depth(0, 0), 1.0f);
  EXPECT_EQ(view.depth(1, 0), 0.0f);
  EXPECT_FLOAT_EQ(view.depth(2, 0), 65.535f);
  EXPECT_FLOAT_EQ(view.depth(0, 1), 0.25f);
  EXPECT_FLOAT_EQ(view.depth(2, 1), 0.002f);
}

TEST(DepthImageView, FloatInvalidValuesReadAsZero) {
  std::vector<float> buf = {1.5f, NAN, -2.0f, INFINITY, -INFINITY, 0.0f};
  DepthImageView<double> view(buf.data(), 6, 1);
  EXPECT_DOUBLE_EQ(view.depth(0, 0), 1.5);
  for (int u = 1; u < 6; ++u) EXPECT_EQ(view.depth(u, 0), 0.0) << u;
}

TEST(DepthImageView, BadArguments) {
  std::vector<float> buf(4);
  EXPECT_THROW(DepthImageView<float>(buf.data(), 4, 1, 8), std::invalid_argument);  // stride < row
  EXPECT_THROW(DepthImageView<float>(static_cast<const float*>(nullptr), 4, 1), std::invalid_argument);
  EXPECT_THROW(DepthImageView<float>(buf.data(), 4, 1, 0, 0.0f), std::invalid_argument);
  EXPECT_THROW(DepthImageView<float>(buf.data(), 4, 1, 0, NAN), std::invalid_argument);
  EXPECT_THROW(DepthImageView<float>(buf.data(), -1, 1), std::invalid_argument);
  EXPECT_NO_THROW(DepthImageView<float>(static_cast<const float*>(nullptr), 0, 0));
}

TEST(DepthImage, OwningImageViewAndValidCount) {
  DepthImage<float> img(4, 3);
  img.at(1, 2) = 0.5f;
  img.at(3, 0) = NAN;
  EXPECT_EQ(img.valid_count(), 1u);
  const auto v = img.view();
  EXPECT_EQ(v.width(), 4);
  EXPECT_FLOAT_EQ(v.depth(1, 2), 0.5f);
  EXPECT_EQ(v.depth(3, 0), 0.0f);
}

TEST(Pose, CameraPoseIsFlangeTimesHandEye) {
  Isometry3d T_base_flange = Isometry3d::Identity();
  T_base_flange.translate(Eigen::Vector3d(0.1, 0.2, 0.5)).rotate(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()));
  Isometry3d T_flange_camera = Isometry3d::Identity();
  T_flange_camera.translation() = Eigen::Vector3d(0, 0.05, 0.02);
  const Isometry3d T = camera_pose_in_base(T_base_flange, T_flange_camera);
  const Eigen::Vector3d p_camera(0.01, 0.02, 0.3);
  EXPECT_TRUE((T * p_camera).isApprox(T_base_flange * (T_flange_camera * p_camera), 1e-12));
  EXPECT_TRUE(relative_pose(T, T).isApprox(Isometry3d::Identity(), 1e-12));
}

TEST(Pose, ValidationRejectsBadPoses) {
  Isometry3d T = Isometry3d::Identity();
  EXPECT_NO_THROW(require_valid_pose(T, "T"));
  T.matrix()(0, 3) = NAN;
  EXPECT_THROW(require_valid_pose(T, "T"), std::invalid_argument);
  T = Isometry3d::Identity();
  T.matrix()(0, 0) = 2.0;
  EXPECT_THROW(require_valid_pose(T, "T"), std::invalid_argument);
  T = Isometry3d::Identity();
  T.matrix()(0, 0) = -1.0;  // a reflection
  EXPECT_THROW(require_valid_pose(T, "T"), std::invalid_argument);
}

TEST(Pose, RotationAngleAccurateForSmallAngles) {
  Isometry3f T = Isometry3f::Identity();
  T.linear() = Eigen::AngleAxisf(1e-4f, Eigen::Vector3f::UnitX()).toRotationMatrix();
  EXPECT_NEAR(rotation_angle(T), 1e-4f, 1e-7f);
}

// Pack::load3 / store3 (core/detail/simd.hpp) at every SIMD level: the transpose of `size`
// consecutive 3-vectors and back, lane for lane (distinct values, so any wrong shuffle index shows).
template <typename Scalar>
void check_pack_load3_store3() {
  for (const SimdLevel level : available_simd_levels()) {
    const test::SimdCap cap(level);
    std::vector<Scalar> in(25), coords(25), out(25, Scalar(-1));  // up to 8 lanes, one sentinel
    int lanes = 0;
    for (int e = 0; e < 25; ++e) in[std::size_t(e)] = Scalar(e) * Scalar(1.25) + Scalar(0.5);
    detail::simd_call([&](auto bytes) BINPICK_SIMD_INLINE_LAMBDA {
      using P = detail::Pack<Scalar, decltype(bytes)::value>;
      lanes = P::size;
      typename P::type x, y, z;
      P::load3(in.data(), x, y, z);
      P::store(coords.data(), x);
      P::store(coords.data() + P::size, y);
      P::store(coords.data() + 2 * P::size, z);
      P::store3(out.data(), x, y, z);
    });
    ASSERT_GE(lanes, 1);
    for (int l = 0; l < lanes; ++l)
      for (int d = 0; d < 3; ++d)
        EXPECT_EQ(coords[std::size_t(d * lanes + l)], in[std::size_t(3 * l + d)]) << "lane " << l << " coordinate " << d;
    for (int e = 0; e < 3 * lanes; ++e) EXPECT_EQ(out[std::size_t(e)], in[std::size_t(e)]) << "scalar " << e;
    EXPECT_EQ(out[std::size_t(3 * lanes)], Scalar(-1)) << "store3 wrote past 3 x size scalars";
  }
}

TEST(Simd, PackLoad3Store3Float) { check_pack_load3_store3<float>(); }
TEST(Simd, PackLoad3Store3Double) { check_pack_load3_store3<double>(); }

// Pack::all / none at every SIMD level, for every single-lane mask, none and all lanes (a mask
// test that looked at one lane or one byte too few would pass some of these and fail others).
template <typename Scalar>
void check_pack_all_none() {
  for (const SimdLevel level : available_simd_levels()) {
    const test::SimdCap cap(level);
    int lanes = 0;
    std::vector<int> all_of, none_of;  // per case: -1 no lane set, L all lanes, else the one lane set
    detail::simd_call([&](auto bytes) BINPICK_SIMD_INLINE_LAMBDA {
      using P = detail::Pack<Scalar, decltype(bytes)::value>;
      using V = typename P::type;
      lanes = P::size;
      V index;
      for (int l = 0; l < P::size; ++l) index[l] = Scalar(l);
      for (int c = -1; c <= P::size; ++c) {
        V ref;  // equal to index in no lane (c = -1), in lane c, or in all lanes (c = size)
        for (int l = 0; l < P::size; ++l) ref[l] = c == P::size ? Scalar(l) : Scalar(c);
        const auto m = index == ref;
        all_of.push_back(P::all(m));
        none_of.push_back(P::none(m));
      }
    });
    ASSERT_EQ(all_of.size(), std::size_t(lanes + 2));
    for (int c = -1; c <= lanes; ++c) {
      const std::size_t k = std::size_t(c + 1);
      EXPECT_EQ(all_of[k], c == lanes || (lanes == 1 && c == 0)) << "lanes " << lanes << " case " << c;
      EXPECT_EQ(none_of[k], c == -1) << "lanes " << lanes << " case " << c;
    }
  }
}

TEST(Simd, PackAllNoneFloat) { check_pack_all_none<float>(); }
TEST(Simd, PackAllNoneDouble) { check_pack_all_none<double>(); }

// reserve_huge is reserve() plus a hint: contents kept, capacity enough; a large buffer's capacity is
// rounded so that the allocation (with the allocator's 24-byte chunk overhead) fills whole 2 MB pages.
TEST(HugePages, ReserveHugeKeepsContentsAndRoundsLargeBuffers) {
  using binpick::detail::kHugePageBytes;
  std::vector<float> small{1.f, 2.f, 3.f};
  binpick::detail::reserve_huge(small, 1000);
  EXPECT_EQ(small.capacity(), 1000u);  // small: plain reserve
  EXPECT_EQ(small, (std::vector<float>{1.f, 2.f, 3.f}));

  std::vector<Eigen::Vector3f> big(5, Eigen::Vector3f(1, 2, 3));
  const std::size_t n = 640 * 480;  // 3.7 MB of float points
  binpick::detail::reserve_huge(big, n);
  ASSERT_GE(big.capacity(), n);
  EXPECT_LT(big.capacity() * sizeof(Eigen::Vector3f), n * sizeof(Eigen::Vector3f) + kHugePageBytes);
  const std::size_t pages = (n * sizeof(Eigen::Vector3f) + 24 + kHugePageBytes - 1) / kHugePageBytes;
  EXPECT_LE(big.capacity() * sizeof(Eigen::Vector3f) + 24, pages * kHugePageBytes);        // fits the pages
  EXPECT_GT((big.capacity() + 1) * sizeof(Eigen::Vector3f) + 24, pages * kHugePageBytes);  // and fills them
  ASSERT_EQ(big.size(), 5u);
  for (const auto& p : big) EXPECT_EQ(p, Eigen::Vector3f(1, 2, 3));
  big.resize(n, Eigen::Vector3f(4, 5, 6));  // the advised memory is ordinary memory
  EXPECT_EQ(big[n - 1], Eigen::Vector3f(4, 5, 6));

  const std::size_t cap = big.capacity();
  binpick::detail::reserve_huge(big, 10);  // never shrinks
  EXPECT_EQ(big.capacity(), cap);
  binpick::detail::advise_huge_pages(nullptr, n);  // no-ops
  binpick::detail::advise_huge_pages(big.data(), 1);
}
