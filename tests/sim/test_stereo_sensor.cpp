// The simulated stereo sensor: exact geometry with the error model off, z² noise, reproducibility and
// thread-count independence, geometry-driven dropouts (specular direction, close views differ),
// ghosts behind the surface, and rejected settings.
#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include "binpick/sim.hpp"
#include "sim_instances.hpp"  // the simulated cell's templates, compiled once
#include "test_support.hpp"

using namespace binpick;
using namespace binpick::sim;

namespace {

// Camera at `eye` looking at `target`; image x along base +x where possible.
Isometry3f look_at(const Eigen::Vector3f& eye, const Eigen::Vector3f& target) {
  return camera_looking_at<float>(eye, target, Eigen::Vector3f::UnitY());
}

StereoSensorSettings<float> small_settings(int width = 320, int height = 256) {
  StereoSensorSettings<float> s;
  s.width = width;
  s.height = height;
  s.diagnostics = true;
  return s;
}

// Share of view 0's part pixels measured within 3 mm of the truth by any of the frames, each frame's
// valid points reprojected into view 0 (all frames from the same sensor).
double part_coverage(const StereoSensor<float>& sensor, const std::vector<const StereoFrame<float>*>& frames) {
  const auto& cam = sensor.camera();
  const auto& f0 = *frames[0];
  std::vector<std::uint8_t> covered(f0.status.size(), 0);
  for (const auto* f : frames) {
    const Isometry3f T_0_k = f0.T_base_camera.inverse() * f->T_base_camera;
    for (int v = 0; v < cam.height(); ++v)
      for (int u = 0; u < cam.width(); ++u) {
        const float z = f->depth.at(u, v);
        if (!(z > 0)) continue;
        const auto px = cam.project(T_0_k * cam.backproject(float(u), float(v), z));
        if (!px) continue;
        const int u0 = int(std::lround(px->x())), v0 = int(std::lround(px->y()));
        const Eigen::Vector3f p0 = T_0_k * cam.backproject(float(u), float(v), z);
        if (std::abs(f0.true_depth.at(u0, v0) - p0.z()) < 0.003f) covered[std::size_t(v0) * std::size_t(cam.width()) + std::size_t(u0)] = 1;
      }
  }
  std::size_t parts = 0, cov = 0;
  for (std::size_t i = 0; i < covered.size(); ++i)
    if (f0.part_index[i] >= 0) {
      ++parts;
      cov += covered[i];
    }
  return parts ? double(cov) / double(parts) : 0.0;
}

}  // namespace

RC_GTEST_PROP(StereoSensor, PlaneRendersToTheAnalyticDepthWithTheErrorModelOff, ()) {
  const Scene<float> scene;  // empty bin: its floor is the plane z = 0
  auto s = small_settings(160, 128);
  s.errors.enabled = false;
  const StereoSensor<float> sensor(s);
  const float h = float(test::uniform(0.25, 0.35));
  const Eigen::Vector3f target(float(test::uniform(-0.05, 0.05)), float(test::uniform(-0.03, 0.03)), 0);
  const Eigen::Vector3f eye = target + h * Eigen::Vector3f(float(test::uniform(-0.15, 0.15)), float(test::uniform(-0.15, 0.15)), 1).normalized();
  const Isometry3f T = look_at(eye, target);
  const auto f = sensor.render(scene, T, 0);
  const auto& cam = sensor.camera();
  int checked = 0;
  for (int v = 0; v < cam.height(); ++v)
    for (int u = 0; u < cam.width(); ++u) {
      const Eigen::Vector3d d = T.linear().cast<double>() * cam.backproject(float(u), float(v), 1.0f).cast<double>();
      const double t = -double(eye.z()) / d.z();  // plane z = 0, depth = t (d has camera z = 1)
      const Eigen::Vector3d p = eye.cast<double>() + t * d;
      if (std::abs(p.x()) > 0.23 || std::abs(p.y()) > 0.105) continue;  // 2 cm off the walls
      ++checked;
      RC_ASSERT(std::abs(double(f.depth.at(u, v)) - t) < 2e-6);
    }
  RC_ASSERT(checked > 1000);
}

TEST(StereoSensor, ZeroNoiseMatchesThePlaneUpToDisparityQuantization) {
  const Scene<float> scene;
  auto s = small_settings();
  s.errors.noise_scale = 0;
  const StereoSensor<float> sensor(s);
  const auto f = sensor.render(scene, look_at(Eigen::Vector3f(0.01f, 0.02f, 0.3f), Eigen::Vector3f(0, 0, 0)), 3);
  std::size_t floor = 0, valid = 0;
  for (std::size_t i = 0; i < f.status.size(); ++i) {
    const float zt = f.true_depth.data()[i], z = f.depth.data()[i];
    if (!(zt > 0.28f && zt < 0.32f)) continue;  // the bin floor
    ++floor;
    if (!(z > 0) || f.status[i] != PixelStatus::valid) continue;
    ++valid;
    // Half a 1/32 px disparity step: z² / (f B) / 64.
    const double step = double(zt) * zt / (sensor.camera().fx() * s.baseline) / 64.0;
    ASSERT_LE(std::abs(double(z - zt)), step * 1.01 + 1e-6);
  }
  ASSERT_GT(floor, 10000u);
  EXPECT_GT(double(valid) / double(floor), 0.8) << "a matte floor must be mostly measured";
}

TEST(StereoSensor, NoiseGrowsWithDistanceSquared) {
  const Scene<float> scene;
  const StereoSensor<float> sensor(small_settings());
  auto rms_at = [&](float h) {
    const auto f = sensor.render(scene, look_at(Eigen::Vector3f(0, 0, h), Eigen::Vector3f(0, 0.001f, 0)), 1);
    double sum = 0;
    std::size_t n = 0;
    for (std::size_t i = 0; i < f.status.size(); ++i)
      if (f.status[i] == PixelStatus::valid && f.part_index[i] < 0 && std::abs(f.true_depth.data()[i] - h) < 0.002f) {
        const double e = f.depth.data()[i] - f.true_depth.data()[i];
        sum += e * e;
        ++n;
      }
    EXPECT_GT(n, 500u);
    return std::sqrt(sum / double(std::max<std::size_t>(n, 1)));
  };
  const double near = rms_at(0.25f), far = rms_at(0.5f);
  EXPECT_GT(near, 0.0);
  EXPECT_GT(far / near, 0.8 * 4.0) << "near " << near << " far " << far;  // (0.5 / 0.25)² = 4, darker → more
}

TEST(StereoSensor, FramesAreReproducibleAndIndependentOfThreads) {
  SceneSettings<float> ss;
  ss.part_type = PartType::small_screw;
  const auto scene = Scene<float>::generate(ss, 5);
  auto s = small_settings();
  const StereoSensor<float> one(s);
  s.num_threads = 2;
  const StereoSensor<float> two(s);
  const auto T = look_at(Eigen::Vector3f(0.02f, 0, 0.3f), Eigen::Vector3f(0, 0, 0));
  const auto a = one.render(scene, T, 7), b = two.render(scene, T, 7), c = one.render(scene, T, 8);
  EXPECT_EQ(a.depth.storage(), b.depth.storage());
  EXPECT_EQ(a.status, b.status);
  EXPECT_NE(a.depth.storage(), c.depth.storage()) << "another frame index draws other noise";
  EXPECT_GT(a.valid_pixels, 0u);
}

TEST(StereoSensor, AKeptWorkspaceGivesTheSameFramesAsAFreshOne) {
  SceneSettings<float> ss;
  ss.part_type = PartType::small_screw;
  const auto scene = Scene<float>::generate(ss, 5);
  auto s = small_settings();
  s.diagnostics = true;
  const StereoSensor<float> sensor(s);
  const auto geo = SceneGeometry<float>::build(scene, s.errors.bin_material, s.errors.table_material);
  RenderWorkspace<float> ws;
  for (const std::uint64_t index : {7u, 8u, 7u}) {  // the workspace holds the previous frame's buffers
    const auto T = look_at(Eigen::Vector3f(0.02f * float(index - 6), 0, 0.3f), Eigen::Vector3f(0, 0, 0));
    const auto kept = sensor.render(geo, T, index, ws), fresh = sensor.render(scene, T, index);
    EXPECT_EQ(kept.depth.storage(), fresh.depth.storage()) << "frame " << index;
    EXPECT_EQ(kept.true_depth.storage(), fresh.true_depth.storage()) << "frame " << index;
    EXPECT_EQ(kept.status, fresh.status) << "frame " << index;
    EXPECT_EQ(kept.part_index, fresh.part_index) << "frame " << index;
    EXPECT_EQ(kept.valid_pixels, fresh.valid_pixels);
    EXPECT_GT(kept.valid_pixels, 0u);
  }
}

TEST(StereoSensor, DropoutsRiseAsTheViewNearsTheSpecularDirection) {
  // One polished nut lying flat: its top face mirrors the projector into the cameras when seen
  // head-on; the share of highlight dropouts (saturation, bloom, left/right mismatch) on it must
  // rise as the view turns toward its normal.
  Scene<float> scene;
  scene.add_part(PartType::circle_nut, Matrix3<float>::Identity(), Vector2<float>(0, 0));
  auto s = small_settings(640, 512);
  s.errors.speckle_filter_min_region_px = 0;
  const StereoSensor<float> sensor(s);
  const Eigen::Vector3f target = scene.parts()[0].T_base_part.translation() + Eigen::Vector3f(0, 0, 0.0025f);
  std::vector<double> rate;
  for (const double deg : {30.0, 20.0, 12.0, 6.0, 0.0}) {
    const float a = float(deg * M_PI / 180);
    // Tilt about the base x axis (the baseline stays horizontal).
    const auto f = sensor.render(scene, look_at(target + 0.3f * Eigen::Vector3f(0, std::sin(a), std::cos(a)), target), 0);
    std::size_t top = 0, highlight = 0;
    for (std::size_t i = 0; i < f.status.size(); ++i) {
      if (f.part_index[i] != 0) continue;
      ++top;
      highlight += f.status[i] == PixelStatus::saturated || f.status[i] == PixelStatus::saturation_bloom ||
                   f.status[i] == PixelStatus::left_right_mismatch;
    }
    ASSERT_GT(top, 200u);
    rate.push_back(double(highlight) / double(top));
  }
  RecordProperty("highlight_dropout_30_20_12_6_0_deg",
                 std::to_string(rate[0]) + " " + std::to_string(rate[1]) + " " + std::to_string(rate[2]) + " " +
                     std::to_string(rate[3]) + " " + std::to_string(rate[4]));
  for (std::size_t k = 1; k < rate.size(); ++k) EXPECT_GE(rate[k], rate[k - 1]) << "angle step " << k;
  EXPECT_GT(rate.back(), rate.front() + 0.3) << "head-on must lose far more of the face than 30° off";
}

TEST(StereoSensor, CloseViewsLoseDifferentPixelsAndTheirUnionCoversMore) {
  SceneSettings<float> ss;
  ss.part_type = PartType::mirror_nut;
  const auto scene = Scene<float>::generate(ss, 11);
  auto s = small_settings(640, 512);
  const StereoSensor<float> sensor(s);
  const auto geo = SceneGeometry<float>::build(scene, s.errors.bin_material, s.errors.table_material);
  const Eigen::Vector3f target(0, 0, 0.01f);
  const float a = float(4.0 * M_PI / 180);  // one capture interval of the paper's sensing path
  const auto f0 = sensor.render(geo, look_at(target + 0.3f * Eigen::Vector3f(0, 0, 1), target), 0);
  const auto f1 = sensor.render(geo, look_at(target + 0.3f * Eigen::Vector3f(std::sin(a), 0, std::cos(a)), target), 1);
  const double c0 = part_coverage(sensor, {&f0}), c1 = part_coverage(sensor, {&f1, &f0}) - 0.0;
  const double c1_alone = [&] {
    // view 1's own measurements, reprojected into view 0
    StereoFrame<float> empty = f0;
    std::fill(empty.depth.storage().begin(), empty.depth.storage().end(), 0.0f);
    return part_coverage(sensor, {&empty, &f1});
  }();
  const double both = part_coverage(sensor, {&f0, &f1});
  (void)c1;
  EXPECT_GT(c0, 0.05);
  EXPECT_GT(c1_alone, 0.05);
  EXPECT_GT(both, std::max(c0, c1_alone) + 0.03) << "c0 " << c0 << " c1 " << c1_alone << " union " << both;
  // The masks differ in the image too: pixels valid in one view and not the other.
  std::size_t differ = 0, parts = 0;
  for (std::size_t i = 0; i < f0.status.size(); ++i) {
    if (f0.part_index[i] < 0 && f1.part_index[i] < 0) continue;
    ++parts;
    differ += (f0.depth.data()[i] > 0) != (f1.depth.data()[i] > 0);
  }
  EXPECT_GT(double(differ) / double(parts), 0.1);
}

// Vignetting (vignetting_power, cos^k off the optical axis) darkens a part at the edge of the field and
// leaves one at its centre as it was: the same nut, the same view direction, seen at the image centre
// and 25 cm to the side (≈ 40° off axis), with k = 0 (the default) and k = 2.
TEST(StereoSensor, VignettingDarkensPartsAtTheEdgeOfTheField) {
  Scene<float> scene;
  scene.add_part(PartType::circle_nut, Matrix3<float>::Identity(), Vector2<float>(0, 0));
  const Eigen::Vector3f target = scene.parts()[0].T_base_part.translation() + Eigen::Vector3f(0, 0, 0.0025f);
  const float a = float(20.0 * M_PI / 180);  // off the top face's highlight
  const Isometry3f centre = look_at(target + 0.3f * Eigen::Vector3f(0, std::sin(a), std::cos(a)), target);
  Isometry3f edge = centre;
  edge.translation() -= 0.25f * (centre.linear() * Eigen::Vector3f::UnitX());  // the nut 25 cm to the image's right
  auto dark_share = [&](float k, const Isometry3f& T) {
    auto s = small_settings(640, 512);
    s.errors.vignetting_power = k;
    const auto f = StereoSensor<float>(s).render(scene, T, 0);
    std::size_t part = 0, dark = 0;
    for (std::size_t i = 0; i < f.status.size(); ++i) {
      if (f.part_index[i] != 0) continue;
      ++part;
      dark += f.status[i] == PixelStatus::too_dark;
    }
    EXPECT_GT(part, 200u);
    return double(dark) / double(std::max<std::size_t>(part, 1));
  };
  const double c0 = dark_share(0, centre), c2 = dark_share(2, centre), e0 = dark_share(0, edge), e2 = dark_share(2, edge);
  RecordProperty("too_dark_centre_k0_k2_edge_k0_k2",
                 std::to_string(c0) + " " + std::to_string(c2) + " " + std::to_string(e0) + " " + std::to_string(e2));
  EXPECT_NEAR(c2, c0, 0.03) << "at the centre of the field";
  EXPECT_GT(e2, e0 + 0.1) << "at the edge: k=0 " << e0 << ", k=2 " << e2;
}

TEST(StereoSensor, GhostsLieBehindTheSurface) {
  SceneSettings<float> ss;
  ss.part_type = PartType::mirror_nut;
  ss.pile_spread = 0.02f;
  const auto scene = Scene<float>::generate(ss, 2);
  const StereoSensor<float> sensor(small_settings(640, 512));
  const auto f = sensor.render(scene, look_at(Eigen::Vector3f(0.03f, 0.02f, 0.3f), Eigen::Vector3f(0, 0, 0)), 0);
  std::size_t ghosts = 0, in_front = 0;
  double behind = 0;
  for (std::size_t i = 0; i < f.status.size(); ++i) {
    if (f.status[i] != PixelStatus::ghost) continue;
    ++ghosts;
    // A virtual point behind the mirror, up to the matching noise: a mirror facing a close surface
    // puts it a hair behind, and at grazing incidence the noise reaches millimetres. Piles of seeds
    // 1-6 show 1-5 of 180-266 ghosts more than 1 mm in front (so this counts them, not each pixel).
    in_front += f.depth.data()[i] < f.true_depth.data()[i] - 0.001f;
    behind += f.depth.data()[i] - f.true_depth.data()[i];
  }
  EXPECT_EQ(ghosts, f.ghost_pixels);
  ASSERT_GT(ghosts, 0u) << "a tight pile of polished nuts must mirror something";
  EXPECT_LT(double(in_front), 0.05 * double(ghosts)) << in_front << " of " << ghosts << " ghosts in front of the surface";
  EXPECT_GT(behind / double(ghosts), 0.002) << "ghosts lie behind the surface on average";
}

TEST(StereoSensor, BadSettingsNameTheArgument) {
  auto expect_named = [](StereoSensorSettings<float> s, const char* name) {
    try {
      StereoSensor<float> sensor(s);
      ADD_FAILURE() << "expected std::invalid_argument for " << name;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(std::string("'") + name + "'"), std::string::npos) << e.what();
    }
  };
  StereoSensorSettings<float> s;
  s.width = 0;
  expect_named(s, "width");
  s = {};
  s.height = -3;
  expect_named(s, "height");
  s = {};
  s.baseline = 0;
  expect_named(s, "baseline");
  s = {};
  s.errors.noise_scale = -1;
  expect_named(s, "noise_scale");
  s = {};
  s.num_threads = -1;
  expect_named(s, "num_threads");
  s = {};
  s.errors.vignetting_power = -1;
  expect_named(s, "vignetting_power");
  const StereoSensor<float> ok(small_settings(32, 32));
  Isometry3f bad = Isometry3f::Identity();
  bad.matrix()(0, 0) = 2;
  EXPECT_THROW(ok.render(Scene<float>(), bad, 0), std::invalid_argument);
}

TEST(StereoSensor, DoublePrecisionAgreesWithFloatOnThePlane) {
  // The sensor is templated on the scalar; both render the same exact plane depth.
  StereoSensorSettings<double> sd;
  sd.width = 40;
  sd.height = 32;
  sd.errors.enabled = false;
  StereoSensorSettings<float> sf;
  sf.width = 40;
  sf.height = 32;
  sf.errors.enabled = false;
  Isometry3d T = Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(0.01, -0.02, 0.3);
  const auto fd = StereoSensor<double>(sd).render(Scene<double>(), T, 0);
  const auto ff = StereoSensor<float>(sf).render(Scene<float>(), T.cast<float>(), 0);
  ASSERT_EQ(fd.valid_pixels, ff.valid_pixels);
  std::size_t floor = 0;
  for (std::size_t i = 0; i < fd.depth.storage().size(); ++i) {
    if (std::abs(fd.depth.storage()[i] - 0.3) < 1e-3) {  // the floor (walls and table are elsewhere)
      ++floor;
      EXPECT_NEAR(fd.depth.storage()[i], 0.3, 1e-12);
    }
    EXPECT_NEAR(fd.depth.storage()[i], ff.depth.storage()[i], 1e-5);
  }
  EXPECT_GT(floor, 300u);  // of 40 × 32
}
