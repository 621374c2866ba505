// Fusion with registration (§III.B.2): views 2..n with motion-corrupted poses are registered to view 1
// before voting.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "binpick/fusion.hpp"
#include "binpick/sim/box_scene.hpp"
#include "sim_instances.hpp"  // Fuser<float / double, pinhole>, compiled once
#include "test_support.hpp"

using namespace binpick;

namespace {

constexpr double kDeg = M_PI / 180.0;

// A sensing arc as the robot drives it: views at angles a_i on a circle of radius r about the target,
// moving at speed v. The kinematics of a view are read `latency` late, i.e. they report the pose the
// camera had latency * v earlier along the arc — a few millimetres and about a degree off.
Isometry3<double> arc_pose(double angle, double r = 0.3) {
  const Eigen::Vector3d eye(r * std::sin(angle), 0.02 * angle / 0.12, r * std::cos(angle));
  return sim::look_at(eye, Eigen::Vector3d(0, 0, 0));
}

double mean_abs_error(const DepthImage<double>& fused, const DepthImage<double>& truth, std::size_t* count = nullptr) {
  double sum = 0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < fused.storage().size(); ++i) {
    const double f = fused.storage()[i], t = truth.storage()[i];
    if (f > 0 && t > 0) sum += std::abs(f - t), ++n;
  }
  if (count) *count = n;
  return n ? sum / double(n) : 0.0;
}

}  // namespace

TEST(FusionRegistration, MotionCorruptedPosesAreCorrectedBeforeVoting) {
  const PinholeCamera<double> cam(250, 250, 159.5, 127.5, 320, 256);
  const sim::BoxScene scene = sim::boxes_scene();
  const double speed = 0.5, latency = 0.02, radius = 0.3;  // 0.5 m/s, 20 ms late: 10 mm along the arc
  std::vector<DepthImage<double>> views;
  std::vector<Isometry3<double>> T_true, T_kinematic;
  for (int i = 0; i < 4; ++i) {
    const double a = -0.06 + 0.04 * i;
    T_true.push_back(arc_pose(a, radius));
    // View 1 is captured at the pull-up stop: its kinematics are exact.
    T_kinematic.push_back(i == 0 ? T_true.back() : arc_pose(a - speed * latency / radius, radius));
    views.push_back(scene.render<double>(cam, T_true.back()));
  }
  const double err_t = (T_true[1].translation() - T_kinematic[1].translation()).norm();
  ASSERT_GT(err_t, 0.005);  // the corruption is real: ~1 cm and ~2 degrees
  std::vector<DepthImageView<double>> vv;
  for (const auto& v : views) vv.push_back(v.view());
  const DepthImage<double>& truth = views[0];

  FusionSettings<double> off;
  off.register_views = false;
  FusionSettings<double> on;  // defaults: registration on
  const auto r_off = fuse(vv, T_kinematic, cam, off);
  const auto r_on = fuse(vv, T_kinematic, cam, on);
  std::size_t n_off = 0, n_on = 0;
  const double mae_off = mean_abs_error(r_off.depth, truth, &n_off);
  const double mae_on = mean_abs_error(r_on.depth, truth, &n_on);
  EXPECT_LT(mae_on, mae_off * 0.5) << "registered " << mae_on << " vs kinematic " << mae_off;
  EXPECT_LT(mae_on, 5e-4);
  for (std::size_t i = 1; i < 4; ++i) {
    const auto& rep = r_on.views[i];
    EXPECT_EQ(rep.pose, ViewPose::registered) << i << " " << to_string(rep.icp_status);
    const Isometry3<double> e = T_true[i].inverse() * rep.T_base_view;
    // Sliding over the floor is observable only through the few box walls the camera sees, so the
    // pose is good to about a millimetre here; on a pile of parts it is far better constrained.
    EXPECT_LT(e.translation().norm(), 2e-3) << i << " " << to_string(rep.icp_status) << " it " << rep.icp_iterations;
    EXPECT_LT(rotation_angle(e), 0.3 * kDeg) << i;
    EXPECT_GT(rep.correction_translation, 0.005);
    EXPECT_EQ(r_off.views[i].pose, ViewPose::kinematic);
  }
  EXPECT_EQ(r_on.views[0].pose, ViewPose::reference);
  // The stages are timed: registering three views takes far longer than skipping it.
  EXPECT_GT(r_on.registration_ms, 0.0);
  EXPECT_LT(r_off.registration_ms, r_on.registration_ms);
  for (const auto* r : {&r_on, &r_off}) {
    EXPECT_GT(r->reprojection_ms, 0.0);
    EXPECT_GT(r->voting_ms, 0.0);
  }
}

// A Fuser and a FusionResult kept across cycles (their buffers reused: the registration's reference
// cloud, the output images) give the same bits as fresh ones, also after a fusion of other views with
// other settings in between.
TEST(FusionRegistration, KeptFuserAndResultGiveTheBitsOfFreshOnes) {
  const PinholeCamera<double> cam(250, 250, 159.5, 127.5, 320, 256);
  const sim::BoxScene scene = sim::boxes_scene();
  auto cycle_views = [&](double a0, int n, std::vector<DepthImage<double>>& images, std::vector<Isometry3<double>>& poses) {
    for (int i = 0; i < n; ++i) {
      const double a = a0 + 0.04 * i;
      images.push_back(scene.render<double>(cam, arc_pose(a)));
      poses.push_back(i == 0 ? arc_pose(a) : arc_pose(a - 0.03));  // late kinematics
    }
  };
  std::vector<DepthImage<double>> ia, ib;
  std::vector<Isometry3<double>> pa, pb;
  cycle_views(-0.06, 4, ia, pa);
  cycle_views(0.1, 3, ib, pb);
  std::vector<DepthImageView<double>> va, vb;
  for (const auto& v : ia) va.push_back(v.view());
  for (const auto& v : ib) vb.push_back(v.view());
  FusionSettings<double> sa;
  sa.compute_votes = true;
  FusionSettings<double> sb;
  sb.reference_stride = 1;

  const auto same = [](const FusionResult<double>& x, const FusionResult<double>& y) {
    EXPECT_TRUE(x.depth.storage() == y.depth.storage());
    EXPECT_TRUE(x.votes.votes == y.votes.votes);
    EXPECT_EQ(x.votes.width, y.votes.width);
    EXPECT_EQ(x.valid_pixels, y.valid_pixels);
    ASSERT_EQ(x.views.size(), y.views.size());
    for (std::size_t i = 0; i < x.views.size(); ++i) {
      EXPECT_EQ(x.views[i].pose, y.views[i].pose) << i;
      EXPECT_TRUE(x.views[i].T_base_view.matrix() == y.views[i].T_base_view.matrix()) << i;
      EXPECT_EQ(x.views[i].icp_iterations, y.views[i].icp_iterations) << i;
    }
  };
  Fuser<double, PinholeCamera<double>> kept(cam);
  FusionResult<double> out;
  kept.fuse(va, pa, sa, out);
  same(out, fuse(va, pa, cam, sa));
  EXPECT_FALSE(out.votes.votes.empty());
  EXPECT_EQ(out.views[1].pose, ViewPose::registered);
  kept.fuse(vb, pb, sb, out);
  same(out, fuse(vb, pb, cam, sb));
  EXPECT_TRUE(out.votes.votes.empty());  // votes off this time: none left from the last fusion
  EXPECT_EQ(out.views.size(), 3u);
  kept.fuse(va, pa, sa, out);
  same(out, fuse(va, pa, cam, sa));
}

TEST(FusionRegistration, CorrectionBeyondTheBoundKeepsTheKinematicPose) {
  const PinholeCamera<double> cam(250, 250, 159.5, 127.5, 320, 256);
  const sim::BoxScene scene = sim::boxes_scene();
  const auto T0 = arc_pose(0.0), T1 = arc_pose(0.04);
  Isometry3<double> T1_bad = T1;
  T1_bad.translation().z() += 0.008;  // an 8 mm kinematic error along the view...
  const auto d0 = scene.render<double>(cam, T0), d1 = scene.render<double>(cam, T1);
  FusionSettings<double> s;
  s.max_correction_translation = 0.002;  // ...but corrections over 2 mm are not trusted
  const auto r = fuse<double>({d0.view(), d1.view()}, {T0, T1_bad}, cam, s);
  EXPECT_EQ(r.views[1].pose, ViewPose::kept_too_far);
  EXPECT_TRUE(r.views[1].T_base_view.isApprox(T1_bad));
  EXPECT_GT(r.views[1].correction_translation, 0.002);
}

TEST(FusionRegistration, AnEmptyViewKeepsItsPoseAndStillFuses) {
  const PinholeCamera<double> cam(250, 250, 159.5, 127.5, 320, 256);
  const auto T0 = arc_pose(0.0), T1 = arc_pose(0.04);
  const auto d0 = sim::boxes_scene().render<double>(cam, T0);
  DepthImage<double> empty(cam.width(), cam.height());  // every pixel dropped out
  const auto r = fuse<double>({d0.view(), empty.view()}, {T0, T1}, cam);
  EXPECT_EQ(r.views[1].pose, ViewPose::kept_icp_failed);
  EXPECT_EQ(r.views[1].icp_status, IcpStatus::too_few_correspondences);
  EXPECT_EQ(r.valid_pixels, d0.valid_count());
}

// Real data: the Redwood frames with poses perturbed by 2 cm and 2 degrees; registration inside the
// fusion brings the fused depth back close to the fusion with the given poses.
TEST(FusionRegistration, RedwoodPerturbedFusionImproves) {
  const std::string dir = test::data_dir() + "/redwood_rgbd";
  std::ifstream log(dir + "/trajectory.log");
  if (!log) GTEST_SKIP() << "no Redwood data";
  std::vector<cv::Mat> depth;
  std::vector<Isometry3<float>> T_world;
  for (int i = 0; i < 3; ++i) {
    int a, b, c;
    log >> a >> b >> c;
    Eigen::Matrix4d m;
    for (int r = 0; r < 4; ++r)
      for (int col = 0; col < 4; ++col) log >> m(r, col);
    Isometry3<double> T;
    T.matrix() = m;
    T_world.push_back(T.cast<float>());
    char name[32];
    std::snprintf(name, sizeof name, "/depth/%05d.png", i);
    depth.push_back(cv::imread(dir + name, cv::IMREAD_ANYDEPTH));
    ASSERT_EQ(depth.back().type(), CV_16UC1);
  }
  const PinholeCamera<float> cam(525.f, 525.f, 319.5f, 239.5f, 640, 480);
  std::vector<DepthImageView<float>> views;
  for (const auto& m : depth) views.emplace_back(m.ptr<std::uint16_t>(), m.cols, m.rows, std::ptrdiff_t(m.step), 0.001f);

  // Fuse frames 1 and 2 into a virtual camera at frame 0's pose and compare with frame 0's own depth.
  std::vector<DepthImageView<float>> others{views[1], views[2]};
  auto perturbed = std::vector<Isometry3<float>>{T_world[1], T_world[2]};
  Isometry3<float> P = Isometry3<float>::Identity();
  P.linear() = Eigen::AngleAxisf(float(2 * kDeg), Eigen::Vector3f(0.3f, -0.8f, 0.5f).normalized()).toRotationMatrix();
  P.translation() = Eigen::Vector3f(0.012f, -0.01f, 0.012f);  // 2 cm
  perturbed[1] = perturbed[1] * P;                             // frame 2 is off, frame 1 is the reference
  auto median_diff = [&](const DepthImage<float>& fused) {
    std::vector<float> d;
    for (int v = 0; v < 480; ++v)
      for (int u = 0; u < 640; ++u) {
        const float f = fused.at(u, v), t = views[0].depth(u, v);
        if (f > 0 && t > 0) d.push_back(std::abs(f - t));
      }
    std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
    return d.empty() ? 1e9f : d[d.size() / 2];
  };
  Fuser<float, PinholeCamera<float>> fuser(cam);
  FusionSettings<float> s;
  s.sensor_accuracy = 0.01f;  // PrimeSense at 2-3 m
  s.register_views = false;
  const float given = median_diff(fuser.fuse_virtual(T_world[0], others, {T_world[1], T_world[2]}, s).depth);
  const float off = median_diff(fuser.fuse_virtual(T_world[0], others, perturbed, s).depth);
  s.register_views = true;
  s.icp.max_correspondence_distance = 0.2f;  // 2 degrees at 2-3 m moves points by up to ~10 cm
  s.icp.kernel_scale = 0.02f;
  s.icp.max_iterations = 60;
  s.normals.pixel_offset = 3;
  const auto reg = fuser.fuse_virtual(T_world[0], others, perturbed, s);
  const float on = median_diff(reg.depth);
  std::printf("Redwood median |fused - frame 0|: given poses %.4f m, perturbed %.4f m, perturbed + ICP %.4f m\n", given,
              off, on);
  EXPECT_EQ(reg.views[1].pose, ViewPose::registered) << to_string(reg.views[1].icp_status);
  EXPECT_LT(on, off * 0.7f) << "registered " << on << " perturbed " << off << " given poses " << given;
  EXPECT_LT(on, given * 1.5f + 0.001f);
}

// A camera wider than FusionSettings::stride_width registers with both strides multiplied: the same
// bits as asking for the multiplied strides unscaled, and other bits than the strides as given.
TEST(FusionRegistration, StridesScaleWithTheImageWidth) {
  FusionSettings<double> d;
  EXPECT_EQ(d.stride_scale(640), 1);
  EXPECT_EQ(d.stride_scale(641), 2);
  EXPECT_EQ(d.stride_scale(1280), 2);
  EXPECT_EQ(d.stride_scale(1920), 3);
  d.stride_width = 0;
  EXPECT_EQ(d.stride_scale(4096), 1);

  const PinholeCamera<double> cam(300, 300, 349.5, 139.5, 700, 280);  // 700 px wide: scale 2
  const sim::BoxScene scene = sim::boxes_scene();
  std::vector<DepthImage<double>> images;
  std::vector<Isometry3<double>> poses;
  for (int i = 0; i < 3; ++i) {
    const double a = -0.04 + 0.04 * i;
    images.push_back(scene.render<double>(cam, arc_pose(a)));
    poses.push_back(i == 0 ? arc_pose(a) : arc_pose(a - 0.03));  // late kinematics
  }
  std::vector<DepthImageView<double>> views;
  for (const auto& v : images) views.push_back(v.view());
  FusionSettings<double> scaled;  // defaults: strides 4 and 2, doubled
  FusionSettings<double> doubled;
  doubled.stride_width = 0;
  doubled.icp.stride = 8;
  doubled.reference_stride = 4;
  FusionSettings<double> as_given;
  as_given.stride_width = 0;
  const auto a = fuse(views, poses, cam, scaled), b = fuse(views, poses, cam, doubled), c = fuse(views, poses, cam, as_given);
  for (std::size_t i = 1; i < 3; ++i) {
    EXPECT_EQ(a.views[i].pose, ViewPose::registered) << i;
    EXPECT_TRUE(a.views[i].T_base_view.matrix() == b.views[i].T_base_view.matrix()) << i;
    EXPECT_EQ(a.views[i].icp_inliers, b.views[i].icp_inliers) << i;
    // The unscaled strides pair about four times the points.
    EXPECT_GT(c.views[i].icp_inliers, 3 * a.views[i].icp_inliers) << i;
  }
  FusionSettings<double> bad;
  bad.stride_width = -1;
  EXPECT_THROW(fuse(views, poses, cam, bad), std::invalid_argument);
}

TEST(FusionRegistration, BadCorrectionBoundsThrow) {
  const PinholeCamera<float> cam(100, 100, 15.5f, 11.5f, 32, 24);
  DepthImage<float> d(32, 24, 0.3f);
  FusionSettings<float> s;
  s.max_correction_rotation = -1;
  EXPECT_THROW(fuse<float>({d.view(), d.view()}, {Isometry3f::Identity(), Isometry3f::Identity()}, cam, s),
               std::invalid_argument);
}
