// The reference estimator and the grasp model on simulated bins. Tests read the scene's ground truth to
// judge; the estimator only ever gets the depth, the camera and the part models.
#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include <cstdio>
#include <limits>
#include <type_traits>

#include "binpick/fusion/fuse.hpp"
#include "binpick/sim.hpp"
#include "sim_instances.hpp"  // the simulated cell's templates, compiled once
#include "test_support.hpp"

using namespace binpick;
using namespace binpick::sim;

namespace {

using Camera = PinholeCamera<float>;
using Estimator = ReferenceEstimator<float, Camera>;

// The guard, type level: a PoseEstimator whose only inputs are models, settings and EstimatorInput.
static_assert(cycle::is_pose_estimator<Estimator>::value, "ReferenceEstimator models PoseEstimator");
static_assert(!std::is_constructible<Estimator, Scene<float>>::value, "no scene in the constructor");
static_assert(!std::is_constructible<Estimator, const Scene<float>&, ReferenceEstimatorSettings<float>>::value,
              "no scene in the constructor");
template <typename T, typename = void>
struct estimates_from_scene : std::false_type {};
template <typename T>
struct estimates_from_scene<T, std::void_t<decltype(std::declval<T&>().estimate(std::declval<const Scene<float>&>()))>>
    : std::true_type {};
static_assert(!estimates_from_scene<Estimator>::value, "estimate() takes no scene");

Isometry3f look_at(const Eigen::Vector3f& eye, const Eigen::Vector3f& target) {
  return camera_looking_at<float>(eye, target, Eigen::Vector3f::UnitY());
}

StereoSensorSettings<float> sensor_settings(bool metal) {
  StereoSensorSettings<float> s;
  s.width = 640;
  s.height = 512;
  s.errors.enabled = metal;
  s.num_threads = 0;
  return s;
}

Scene<float> pile(PartType type, int parts, std::uint64_t seed) {
  SceneSettings<float> s;
  s.part_type = type;
  s.num_parts = parts;
  return Scene<float>::generate(s, seed);
}

const Isometry3f kReference = look_at(Eigen::Vector3f(0, 0, 0.3f), Eigen::Vector3f(0, 0, 0));

// Settings with the region of interest an integrator configures: the bin floor's inside as seen by the
// reference view, kept clear of the walls (the floor rectangle shrunk to ±20 × ±10 cm).
// Default settings whose region of interest is the image box of base points a and b seen from
// T_base_camera.
ReferenceEstimatorSettings<float> settings_with_roi(const Camera& camera, const Isometry3f& T_base_camera,
                                                    const Eigen::Vector3f& a_base, const Eigen::Vector3f& b_base) {
  ReferenceEstimatorSettings<float> s;
  const Isometry3f T_camera_base = T_base_camera.inverse();
  const auto a = camera.project(T_camera_base * a_base);
  const auto b = camera.project(T_camera_base * b_base);
  s.roi_u0 = int(std::min(a->x(), b->x()));
  s.roi_u1 = int(std::max(a->x(), b->x()));
  s.roi_v0 = int(std::min(a->y(), b->y()));
  s.roi_v1 = int(std::max(a->y(), b->y()));
  return s;
}

ReferenceEstimatorSettings<float> settings_for(const Camera& camera) {
  return settings_with_roi(camera, kReference, Eigen::Vector3f(-0.20f, 0.10f, 0), Eigen::Vector3f(0.20f, -0.10f, 0));
}

cycle::EstimatorInput<float, Camera> input_of(const DepthImage<float>& depth, const Camera& camera) {
  cycle::EstimatorInput<float, Camera> in;
  in.depth = depth.view();
  in.camera = &camera;
  return in;
}

// The scene's bin and the camera's pose in the input, as the cell passes them (EstimatorInput::bin).
void give_bin(cycle::EstimatorInput<float, Camera>& in, const Scene<float>& scene, const Isometry3f& T_base_camera) {
  in.bin.length = scene.bin().length;
  in.bin.width = scene.bin().width;
  in.bin.height = scene.bin().wall_height;
  in.T_base_camera = T_base_camera;
}

struct Match {
  int truth = -1;
  float translation = 1e9f, rotation = 1e9f;  // [m], [rad]
};

// The nearest true part of an estimated pose, errors up to the part's symmetry.
Match match(const Scene<float>& scene, const Isometry3f& T_base_camera, const cycle::RecognizedObject<float>& o) {
  Match m;
  const Isometry3f T_base_object = T_base_camera * o.T_camera_object;
  for (std::size_t i = 0; i < scene.parts().size(); ++i) {
    const auto& p = scene.parts()[i];
    const float d = (p.T_base_part.translation() - T_base_object.translation()).norm();
    if (d < m.translation) {
      m.truth = int(i);
      m.translation = d;
      m.rotation = sim::detail::symmetric_rotation_distance<float>(p.T_base_part.linear(), T_base_object.linear(),
                                                              sim::detail::part_symmetry(p.type));
    }
  }
  return m;
}

bool correct(const Match& m, float mm, float deg) {
  return m.translation < mm * 1e-3f && m.rotation < deg * float(M_PI / 180);
}

// Parts the reference view sees (nearly) whole: their true pose scores high on clean depth.
std::vector<int> top_parts(const Estimator& est, const Scene<float>& scene, const cycle::EstimatorInput<float, Camera>& in) {
  std::vector<int> top;
  for (std::size_t i = 0; i < scene.parts().size(); ++i) {
    const Isometry3f T = kReference.inverse() * scene.parts()[i].T_base_part;
    if (est.score_pose(in, 0, T) >= 80.f) top.push_back(int(i));
  }
  return top;
}

// The simulated world's judgement of the grasp the estimator chose for object i, seen from kReference.
PickOutcome<float> judge_grasp(const Scene<float>& scene, PartType type, const ReferenceEstimation<float>& r, std::size_t i) {
  const auto& o = r.result.objects[i];
  const auto& g = scene.model(type).grasps[std::size_t(r.details[i].grasp_index)];
  return evaluate_pick(scene, type, Isometry3f(kReference * o.T_camera_grasp), o.gripper, g.opening);
}

// A coupler clamped to the +x wall, seen on clean depth from above a point 2 cm inside the bin.
struct CouplerAtWall {
  const PartType type = PartType::pencil_coupler;
  Scene<float> scene;
  Isometry3f T_base_camera = Isometry3f::Identity();
  const StereoSensor<float> sensor{sensor_settings(false)};
  StereoFrame<float> frame;
  CouplerAtWall() {
    scene.add_part(type, scene.model(type).rest_orientations[0], Vector2<float>(0.25f, 0.0f));
    const Eigen::Vector3f at = scene.parts()[0].T_base_part.translation();
    T_base_camera = look_at(Eigen::Vector3f(at.x() - 0.02f, at.y(), 0.3f), at);
    frame = sensor.render(scene, T_base_camera, 0);
  }
  const Camera& camera() const { return sensor.camera(); }
  /// Removes the wall's measurements from `depth` except at the pixels `keep(u, v)` names; returns
  /// how many it removed.
  template <typename Keep>
  int remove_wall(DepthImage<float>& depth, Keep keep) const {
    int removed = 0;
    for (int v = 0; v < depth.height(); ++v)
      for (int u = 0; u < depth.width(); ++u) {
        float& z = depth.at(u, v);
        if (!(z > 0) || keep(u, v)) continue;
        const Eigen::Vector3f p = T_base_camera * camera().backproject(float(u), float(v), z);
        if (p.x() > scene.bin().length / 2 - 0.002f) {
          z = 0;
          ++removed;
        }
      }
    return removed;
  }
  /// Samples (1 mm apart) of the gripper at o's grasp that stand inside the wall.
  int fingers_in_wall(const cycle::RecognizedObject<float>& o, const GripperGeometry<float>& gripper) const {
    int n = 0;
    for (const auto& q : sim::detail::gripper_samples(gripper, o.gripper, gripper.approach_opening, 0.001f)) {
      const Eigen::Vector3f p = T_base_camera * (o.T_camera_grasp * q);
      n += p.x() >= scene.bin().length / 2 && p.z() <= scene.bin().wall_height;
    }
    return n;
  }
};

}  // namespace

// Clean depth: the top parts are found within 2 mm / 2°, and every confident object is right. Counted
// over two piles: one pile's dozen top parts make a share that moves by 10 points when a pile changes.
// The screw's share is lower (the file comment of reference_estimator.hpp: its turn about the line of
// sight); over piles 7-14 the shares were: couplers 96 of 106, circle nuts 92 of 104, screws 52 of 76.
TEST(ReferenceEstimator, CleanDepthFindsTopPartsAccurately) {
  const StereoSensor<float> sensor(sensor_settings(false));
  for (const PartType type : {PartType::pencil_coupler, PartType::circle_nut, PartType::small_screw}) {
    const double least_share = type == PartType::small_screw ? 0.6 : 0.8;
    int found = 0, top_total = 0;
    for (const std::uint64_t seed : {7ULL, 8ULL}) {
      const Scene<float> scene = pile(type, 20, seed);
      const auto frame = sensor.render(scene, kReference, 0);
      Estimator est(scene.model(type), settings_for(sensor.camera()));
      const auto in = input_of(frame.depth, sensor.camera());
      const auto r = est.estimate_detailed(in);
      ASSERT_EQ(r.result.status, cycle::EstimationStatus::ok) << part_type_name(type);
      const std::vector<int> top = top_parts(est, scene, in);
      ASSERT_GE(top.size(), 4u) << part_type_name(type);
      top_total += int(top.size());
      for (const int t : top)
        for (const auto& o : r.result.objects) {
          const Match m = match(scene, kReference, o);
          if (m.truth == t && correct(m, 2, 2)) {
            ++found;
            break;
          }
        }
      for (const auto& o : r.result.objects) {
        EXPECT_EQ(o.part_type, int(type));
        EXPECT_TRUE(o.T_camera_object.matrix().allFinite());
        EXPECT_TRUE(o.T_camera_grasp.matrix().allFinite());
        EXPECT_GE(o.confidence_percent, est.settings().min_confidence);
        EXPECT_LE(o.confidence_percent, 100.f);
        if (o.confidence_percent >= 85.f) {
          EXPECT_TRUE(correct(match(scene, kReference, o), 2, 2)) << part_type_name(type);
        }
      }
      for (std::size_t i = 1; i < r.result.objects.size(); ++i)
        EXPECT_GE(r.result.objects[i - 1].confidence_percent, r.result.objects[i].confidence_percent);
    }
    std::printf("%s: %d of %d\n", part_type_name(type), found, top_total);
    EXPECT_GE(double(found), least_share * double(top_total)) << part_type_name(type) << ": " << found << " of " << top_total;
  }
}

// Flat nuts side by side meet at one height without a crease, and the metal sensor's edge fringe
// bridges the gap between them (drawn in here, on clean depth): one flat segment larger than a part.
// Without the bin, or by default, that is floor; with the bin known and cluster_min_height set it
// lies a nut's height above the floor and is split into nuts.
TEST(ReferenceEstimator, TouchingFlatNutsAreNotTakenForFloor) {
  const StereoSensor<float> sensor(sensor_settings(false));
  const PartType type = PartType::mirror_nut;
  Scene<float> scene;
  // Corner to corner, 1.8 mm apart: the collision spheres reach 8.3 mm from the axis along x.
  const float gap = 0.0168f;
  for (const Vector2<float>& xy : {Vector2<float>(0, 0), Vector2<float>(gap, 0), Vector2<float>(2 * gap, 0)})
    scene.add_part(type, scene.model(type).rest_orientations[0], xy);
  for (const auto& p : scene.parts())
    ASSERT_GT(p.T_base_part.linear()(2, 2), 0.99f) << "a nut does not lie flat at x " << p.T_base_part.translation().x();
  const Eigen::Vector3f centre(gap, 0, 0);
  const Isometry3f T_base_camera = look_at(Eigen::Vector3f(centre.x() + 0.01f, centre.y(), 0.3f), centre);
  auto frame = sensor.render(scene, T_base_camera, 0);
  // The fringe: the floor between the nuts, within 3 mm of their line, reads the nuts' top.
  const float top = scene.parts()[0].T_base_part.translation().z() + 0.00325f;
  const Eigen::Vector3f o = T_base_camera.translation();
  const Isometry3f T_camera_base = T_base_camera.inverse();
  int bridged = 0;
  for (int v = 0; v < frame.depth.height(); ++v)
    for (int u = 0; u < frame.depth.width(); ++u) {
      const Eigen::Vector3f d = T_base_camera.linear() * sensor.camera().backproject(float(u), float(v), 1.f);
      const Eigen::Vector3f p = o + d * ((top - o.z()) / d.z());
      const Eigen::Vector3f at = T_camera_base * p;
      if (std::abs(p.y()) < 0.003f && p.x() > 0 && p.x() < 2 * gap && frame.depth.at(u, v) > at.z() + 0.002f) {
        frame.depth.at(u, v) = at.z();
        ++bridged;
      }
    }
  ASSERT_GT(bridged, 10);
  auto in = input_of(frame.depth, sensor.camera());
  give_bin(in, scene, T_base_camera);
  // The region of interest: 4 cm round the nuts (the walls' rims would come first, top-most first).
  ReferenceEstimatorSettings<float> es =
      settings_with_roi(sensor.camera(), T_base_camera, centre + Eigen::Vector3f(-0.04f, 0.04f, 0),
                        centre + Eigen::Vector3f(0.04f, -0.04f, 0));
  es.cluster_min_height = 0.002f;  // as the simulated cell sets it for nuts
  ReferenceEstimatorSettings<float> as_floor = es;
  as_floor.cluster_min_height = std::numeric_limits<float>::infinity();
  const Estimator est(scene.model(type), es), est_floor(scene.model(type), as_floor);
  auto found = [&](const Estimator& e) {
    int n = 0;
    for (const auto& o : e.estimate_detailed(in).result.objects) n += correct(match(scene, T_base_camera, o), 3, 10);
    return n;
  };
  const int with_rule = found(est), as_before = found(est_floor);
  std::printf("touching flat nuts found: %d, %d when taken for floor\n", with_rule, as_before);
  EXPECT_EQ(with_rule, 3);
  EXPECT_EQ(as_before, 0);
}

// A part whose faces differ little in width (the RJ45 plug: 21 × 14 lying flat, 21 × 11.7 on its side)
// fits a pile's top face turned a quarter about its long axis nearly as well: the narrower face lies
// inside the measured one, so the z-buffer confidence alone (which looks only where the model is) ties.
// Ranked with the share of the segment covered, the confident objects' grasps are true grasps (pose
// only; collisions are the cell's business). On these 3 piles by confidence alone: 19 of 34.
TEST(ReferenceEstimator, ConfidentGraspsOfBoxyPartsAreTrueGrasps) {
  const StereoSensor<float> sensor(sensor_settings(false));
  const PartType type = PartType::lan_connector;
  int confident = 0, matching = 0;
  for (const std::uint64_t seed : {101, 102, 103}) {
    const Scene<float> scene = pile(type, 20, seed);
    const auto frame = sensor.render(scene, kReference, 0);
    const Estimator est(scene.model(type), settings_for(sensor.camera()));
    const auto r = est.estimate_detailed(input_of(frame.depth, sensor.camera()));
    for (std::size_t i = 0; i < r.result.objects.size(); ++i) {
      if (r.result.objects[i].confidence_percent < 85.f || r.details[i].grasp_index < 0) continue;
      ++confident;
      matching += judge_grasp(scene, type, r, i).status != PickStatus::no_matching_grasp;
    }
  }
  ASSERT_GE(confident, 15);
  EXPECT_GE(double(matching), 0.9 * double(confident)) << matching << " of " << confident;
}

// A hex nut seen from above shows a flat face: its depth fixes all but the turn about the axis, which
// only the outline's corners give (turn_to_outline). On clean piles the top nuts are found within
// 2 mm / 5° (the gripper's closing tolerance is 11°) with it, far more often than without it.
TEST(ReferenceEstimator, HexNutsTurnToTheirOutline) {
  const StereoSensor<float> sensor(sensor_settings(false));
  const PartType type = PartType::mirror_nut;
  int top_total = 0, found_with = 0, found_without = 0;
  for (const std::uint64_t seed : {101, 102, 103}) {
    const Scene<float> scene = pile(type, 20, seed);
    const auto frame = sensor.render(scene, kReference, 0);
    const auto in = input_of(frame.depth, sensor.camera());
    ReferenceEstimatorSettings<float> without = settings_for(sensor.camera());
    without.outline_min_strength = 0;
    const Estimator est(scene.model(type), settings_for(sensor.camera())), est_without(scene.model(type), without);
    const std::vector<int> top = top_parts(est, scene, in);
    top_total += int(top.size());
    for (const auto* e : {&est, &est_without}) {
      const auto r = e->estimate_detailed(in);
      for (const int t : top)
        for (const auto& o : r.result.objects) {
          const Match m = match(scene, kReference, o);
          if (m.truth == t && correct(m, 2, 5)) {
            ++(e == &est ? found_with : found_without);
            break;
          }
        }
    }
  }
  ASSERT_GE(top_total, 12);
  std::printf("top nuts %d: found %d with the outline turn, %d without\n", top_total, found_with, found_without);
  EXPECT_GE(double(found_with), 0.6 * double(top_total));
  EXPECT_GE(double(found_with), double(found_without) + 0.2 * double(top_total));
}

// Paper Fig. 11, measured: one metal view yields fewer correct objects than the fusion of four views of
// the same pile (measured on polished circle nuts: on small screws this estimator mostly confuses head
// and tip on metal depth at 640 × 512, so both counts would be near zero).
TEST(ReferenceEstimator, FusedMetalDepthFindsMorePartsThanOneView) {
  const StereoSensor<float> sensor(sensor_settings(true));
  const Camera& camera = sensor.camera();
  int single_found = 0, fused_found = 0;
  for (const std::uint64_t seed : {3u, 11u}) {
    const Scene<float> scene = pile(PartType::circle_nut, 20, seed);
    const auto geo = SceneGeometry<float>::build(scene, sensor.settings().errors.bin_material,
                                                 sensor.settings().errors.table_material);
    std::vector<Isometry3f> poses{kReference};
    for (int k = 0; k < 3; ++k) {  // three more views on a circle around the reference, ~15° off
      const float a = float(2 * M_PI / 3 * k);
      poses.push_back(look_at(Eigen::Vector3f(0.08f * std::cos(a), 0.08f * std::sin(a), 0.29f), Eigen::Vector3f(0, 0, 0)));
    }
    std::vector<StereoFrame<float>> frames;
    for (std::size_t k = 0; k < poses.size(); ++k) frames.push_back(sensor.render(geo, poses[k], k));
    std::vector<DepthImageView<float>> views;
    for (const auto& f : frames) views.push_back(f.depth.view());
    Fuser<float, Camera> fuser(camera);
    const auto fused = fuser.fuse(views, poses, FusionSettings<float>{});
    Estimator est(scene.model(PartType::circle_nut), settings_for(camera));
    auto count = [&](const DepthImage<float>& depth) {
      int n = 0;
      const auto objects = est.estimate(input_of(depth, camera)).objects;
      // estimate() keeps its scratch memory from the previous call; estimate_detailed() starts afresh.
      const auto fresh = est.estimate_detailed(input_of(depth, camera)).result.objects;
      EXPECT_EQ(objects.size(), fresh.size());
      for (std::size_t k = 0; k < std::min(objects.size(), fresh.size()); ++k)
        EXPECT_TRUE(objects[k].T_camera_grasp.matrix() == fresh[k].T_camera_grasp.matrix()) << "object " << k;
      for (const auto& o : objects) n += correct(match(scene, kReference, o), 3, 5);
      return n;
    };
    single_found += count(frames[0].depth);
    fused_found += count(fused.depth);
  }
  EXPECT_LT(single_found, fused_found) << "single view " << single_found << ", fused " << fused_found;
  EXPECT_GT(fused_found, 0);
}

// Confidence tracks correctness: the true pose of a top part outscores the same pose moved off it.
RC_GTEST_PROP(ReferenceEstimator, ConfidenceDropsAwayFromTheTruePose, ()) {
  static const StereoSensor<float> sensor(sensor_settings(false));
  static const Scene<float> scene = pile(PartType::pencil_coupler, 20, 7);
  static const auto frame = sensor.render(scene, kReference, 0);
  static const Estimator est(scene.model(PartType::pencil_coupler), settings_for(sensor.camera()));
  const auto in = input_of(frame.depth, sensor.camera());
  static const std::vector<int> top = top_parts(est, scene, in);
  RC_PRE(!top.empty());
  const int t = top[std::size_t(*rc::gen::inRange<int>(0, int(top.size())))];
  const Isometry3f T = kReference.inverse() * scene.parts()[std::size_t(t)].T_base_part;
  // Perturbation: 3–6 mm away, or 10–30° about an axis across the part's own axis.
  Isometry3f P = T;
  if (*rc::gen::arbitrary<bool>()) {
    Eigen::Vector3f d(float(test::uniform(-1, 1)), float(test::uniform(-1, 1)), float(test::uniform(-1, 1)));
    RC_PRE(d.norm() > 0.1f);
    // Not along the sleeve's own axis (model z): slid 3 mm into itself, a 30 mm sleeve changes only
    // at its ends (a generated case 11.6° off the axis scored 90.7 moved against 90.4 true).
    const float along = std::abs(d.normalized().dot(T.linear().col(2)));
    RC_LOG() << "direction " << std::acos(along) * 180 / M_PI << " deg from the part's axis\n";
    RC_PRE(along < 0.7f);
    P.translation() += d.normalized() * float(test::uniform(0.003, 0.006));
  } else {
    const Eigen::Vector3f axis = T.linear() * Eigen::Vector3f(float(test::uniform(-1, 1)), 1, 0).normalized();
    P.linear() = Eigen::AngleAxisf(float(test::uniform(10, 30) * M_PI / 180), axis).toRotationMatrix() * T.linear();
  }
  RC_ASSERT(est.score_pose(in, 0, T) > est.score_pose(in, 0, P) + 10.f);
}

// ... and over the estimator's own output on clean depth: correct objects carry more confidence than
// wrong ones. (On single-view metal depth this does not hold for small screws: a head/tip flip scores
// like the true pose.)
TEST(ReferenceEstimator, ConfidenceOfCorrectObjectsExceedsWrongOnes) {
  const StereoSensor<float> sensor(sensor_settings(false));
  double sum_ok = 0, sum_bad = 0;
  int n_ok = 0, n_bad = 0;
  for (const PartType type : {PartType::small_screw, PartType::mirror_nut, PartType::pencil_coupler}) {
    const Scene<float> scene = pile(type, 20, 5);
    const auto frame = sensor.render(scene, kReference, 0);
    ReferenceEstimatorSettings<float> s = settings_for(sensor.camera());
    s.min_confidence = 10;  // keep weak hypotheses too
    Estimator est(scene.model(type), s);
    for (const auto& o : est.estimate(input_of(frame.depth, sensor.camera())).objects) {
      const bool ok = correct(match(scene, kReference, o), 2, 5);
      (ok ? sum_ok : sum_bad) += o.confidence_percent;
      (ok ? n_ok : n_bad) += 1;
    }
  }
  ASSERT_GT(n_ok, 0);
  ASSERT_GT(n_bad, 0) << "no wrong object to compare with";
  EXPECT_GT(sum_ok / n_ok, sum_bad / n_bad + 5) << n_ok << " correct, " << n_bad << " wrong";
}

TEST(ReferenceEstimator, EmptyBinGivesNoObjects) {
  const StereoSensor<float> sensor(sensor_settings(true));
  const Scene<float> empty;
  const auto frame = sensor.render(empty, kReference, 0);
  ASSERT_GT(frame.valid_pixels, 0u);
  Estimator est(make_part<float>(PartType::small_screw), settings_for(sensor.camera()));
  const auto r = est.estimate(input_of(frame.depth, sensor.camera()));
  EXPECT_EQ(r.status, cycle::EstimationStatus::no_objects);
  EXPECT_TRUE(r.objects.empty());
}

// With the bin known, a part sunk into its floor is no object. A sensor darker off axis
// (vignetting_power 2) leaves the floor near the field's edges as flat pieces between holes, and parts
// fit into them (all five models did, 0.3–8 mm deep, before max_floor_penetration); parts that lie
// in the bin are all still found (a pile of each type, clean depth).
TEST(ReferenceEstimator, KnownFloorRejectsPartsSunkIntoIt) {
  auto st = sensor_settings(true);
  st.errors.vignetting_power = 2;
  const StereoSensor<float> sensor(st), clean(sensor_settings(false));
  auto with_bin = [&](const Scene<float>& scene, const DepthImage<float>& depth) {
    auto in = input_of(depth, sensor.camera());
    give_bin(in, scene, kReference);
    return in;
  };
  const Scene<float> empty;
  const auto frame = sensor.render(empty, kReference, 0);
  for (const PartType type : {PartType::small_screw, PartType::lan_connector, PartType::mirror_nut,
                              PartType::pencil_coupler, PartType::circle_nut}) {
    Estimator est(make_part<float>(type), settings_for(sensor.camera()));
    const auto r = est.estimate(with_bin(empty, frame.depth));
    EXPECT_TRUE(r.objects.empty()) << part_type_name(type) << ": " << r.objects.size() << " objects in an empty bin";
  }
  for (const PartType type : {PartType::small_screw, PartType::lan_connector, PartType::mirror_nut,
                              PartType::pencil_coupler, PartType::circle_nut}) {
    const Scene<float> scene = pile(type, 20, 7);
    const auto f = clean.render(scene, kReference, 0);
    Estimator est(scene.model(type), settings_for(sensor.camera()));
    const auto known = est.estimate(with_bin(scene, f.depth));
    const auto unknown = est.estimate(input_of(f.depth, sensor.camera()));
    int correct_known = 0, correct_unknown = 0;
    for (const auto& o : known.objects) correct_known += correct(match(scene, kReference, o), 2, 5);
    for (const auto& o : unknown.objects) correct_unknown += correct(match(scene, kReference, o), 2, 5);
    std::printf("%s: correct objects %d with the bin known, %d without\n", part_type_name(type), correct_known, correct_unknown);
    EXPECT_GT(correct_unknown, 0) << part_type_name(type);
    EXPECT_GE(correct_known, correct_unknown) << part_type_name(type);
  }
}

TEST(ReferenceEstimator, CorruptedDepthGivesNoObjectsAndNoError) {
  const Camera camera(256.f, 256.f, 159.5f, 127.5f, 320, 256);
  Estimator est(make_part<float>(PartType::mirror_nut));
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  for (const float fill : {0.f, nan, inf, -1.f}) {
    DepthImage<float> depth(320, 256, fill);
    const auto r = est.estimate(input_of(depth, camera));
    EXPECT_EQ(r.status, cycle::EstimationStatus::no_objects);
    EXPECT_TRUE(r.objects.empty());
  }
  // Garbage: a mix of NaN, inf, negative and wild values.
  DepthImage<float> depth(320, 256);
  sim::detail::Rng rng(42);
  for (auto& z : depth.storage()) {
    const double u = rng.uniform();
    z = u < 0.25 ? nan : u < 0.5 ? -inf : u < 0.75 ? float(rng.uniform(-1, 1)) : float(rng.uniform(0, 1e6));
  }
  const auto r = est.estimate(input_of(depth, camera));
  for (const auto& o : r.objects) EXPECT_TRUE(o.T_camera_object.matrix().allFinite());
}

// Edge fattening (stereo_sensor.hpp, step 6): beside a depth drop a stereo matcher reports the
// foreground's depth over some background pixels, on the side away from the occlusion (+u for the
// left-camera depth of the simulated rig). Clean depth of couplers with such a fringe added, 2 px wide
// right of every drop: fitted with the fringe (the default) the parts lean toward +u; leaving a band as
// wide out of the refinement (edge_band_px, on the default side) takes most of that error away. Mean
// error along the camera's x axis over the parts found within 3 mm (measured: 0.74 and 0.09 mm).
TEST(ReferenceEstimator, EdgeFringeDoesNotPullFitsSideways) {
  const StereoSensor<float> sensor(sensor_settings(false));
  const Camera& camera = sensor.camera();
  double with_band = 0, without_band = 0;
  for (const bool band : {false, true}) {
    double sum = 0;
    int n = 0;
    for (const std::uint64_t seed : {3ULL, 4ULL}) {
      const Scene<float> scene = pile(PartType::pencil_coupler, 12, seed);
      DepthImage<float> depth = sensor.render(scene, kReference, 0).depth;
      const DepthImage<float> clean = depth;
      const int w = depth.width(), h = depth.height();
      for (int v = 0; v < h; ++v)
        for (int u = 0; u + 1 < w; ++u) {
          const float z = clean.at(u, v), zr = clean.at(u + 1, v);
          if (!(z > 0.f) || !(zr > z + 0.004f)) continue;  // a drop to the right of (u, v)
          for (int k = 1; k <= 2 && u + k < w; ++k)
            if (clean.at(u + k, v) > z + 0.004f) depth.at(u + k, v) = z;
        }
      ReferenceEstimatorSettings<float> s = settings_for(camera);
      s.edge_band_px = band ? 2 : 0;
      Estimator est(scene.model(PartType::pencil_coupler), s);
      for (const auto& o : est.estimate(input_of(depth, camera)).objects) {
        const Match m = match(scene, kReference, o);
        if (!(m.translation < 0.003f)) continue;
        const Isometry3f T_camera_true = kReference.inverse() * scene.parts()[std::size_t(m.truth)].T_base_part;
        sum += double(o.T_camera_object.translation().x() - T_camera_true.translation().x());
        ++n;
      }
    }
    ASSERT_GE(n, 6) << "band " << band;
    (band ? with_band : without_band) = sum / n;
  }
  std::printf("mean error along x: fringe fitted %.2f mm, left out %.2f mm\n", without_band * 1e3, with_band * 1e3);
  EXPECT_GT(without_band, 0.0003) << "the fringe should pull the fit toward +u";
  EXPECT_LT(std::abs(with_band), 0.5 * without_band);
}

TEST(ReferenceEstimator, RejectsBadInput) {
  const Camera camera(256.f, 256.f, 159.5f, 127.5f, 320, 256);
  Estimator est(make_part<float>(PartType::mirror_nut));
  DepthImage<float> depth(320, 256);
  cycle::EstimatorInput<float, Camera> in;
  in.depth = depth.view();
  EXPECT_THROW(est.estimate(in), std::invalid_argument);  // no camera
  DepthImage<float> small(100, 80);
  EXPECT_THROW(est.estimate(input_of(small, camera)), std::invalid_argument);
  EXPECT_THROW(Estimator(std::vector<PartModel<float>>{}), std::invalid_argument);
  ReferenceEstimatorSettings<float> bad;
  bad.support_distance = 0;
  EXPECT_THROW(Estimator(make_part<float>(PartType::mirror_nut), bad), std::invalid_argument);
  for (int k = 0; k < 12; ++k) {
    ReferenceEstimatorSettings<float> b;
    if (k == 11) b.cluster_min_height = std::numeric_limits<float>::quiet_NaN();
    if (k == 9) b.max_floor_penetration = -0.001f;
    if (k == 10) b.max_floor_penetration = std::numeric_limits<float>::quiet_NaN();
    if (k == 7) b.hole_reach = -0.001f;
    if (k == 8) b.hole_reach = std::numeric_limits<float>::infinity();
    if (k == 5) b.min_part_cells = 0;
    if (k == 6) b.min_part_cells = std::numeric_limits<float>::quiet_NaN();
    if (k == 0) b.own_surface_margin = std::numeric_limits<float>::quiet_NaN();
    if (k == 1) b.min_colliding_samples = 0;
    if (k == 2) b.gripper.approach_opening = std::numeric_limits<float>::infinity();
    if (k == 3) b.edge_band_px = -1;
    if (k == 4) b.edge_band_side = 2;
    EXPECT_THROW(Estimator(make_part<float>(PartType::mirror_nut), b), std::invalid_argument) << k;
  }
}

// The automatic grid stride: every pixel at 640 px wide; at 1280 px, every pixel for the hex nut (its
// 9.9 mm bounding radius spans 17 px at 0.3 m) and every second pixel for the coupler (16.9 mm, 29 px),
// every pixel for both models together, and for the coupler again when it lies twice as far. The
// stride follows the image's depth and the smallest model, never coarser than ceil(width / 640).
TEST(ReferenceEstimator, AutomaticStrideFollowsTheSmallestPart) {
  const auto stride = [](std::vector<PartType> types, int width, float depth_m, int fixed = 0) {
    StereoSensorSettings<float> ss;
    ss.width = width;
    ss.height = width * 4 / 5;
    const Camera camera = StereoSensor<float>(ss).camera();
    const DepthImage<float> depth(camera.width(), camera.height(), depth_m);
    std::vector<PartModel<float>> models;
    for (const PartType t : types) models.push_back(make_part<float>(t));
    ReferenceEstimatorSettings<float> s;
    s.stride = fixed;
    return Estimator(models, s).estimate_detailed(input_of(depth, camera)).stride;
  };
  for (const PartType t : {PartType::small_screw, PartType::lan_connector, PartType::mirror_nut, PartType::pencil_coupler,
                           PartType::circle_nut})
    EXPECT_EQ(stride({t}, 640, 0.3f), 1) << part_type_name(t);
  EXPECT_EQ(stride({PartType::mirror_nut}, 1280, 0.3f), 1);
  EXPECT_EQ(stride({PartType::pencil_coupler}, 1280, 0.3f), 2);
  EXPECT_EQ(stride({PartType::pencil_coupler, PartType::mirror_nut}, 1280, 0.3f), 1);
  EXPECT_EQ(stride({PartType::pencil_coupler}, 1280, 0.6f), 1);
  EXPECT_EQ(stride({PartType::mirror_nut}, 2560, 0.3f), 2);  // 34 px across its radius: 17 cells at stride 2
  EXPECT_EQ(stride({PartType::mirror_nut}, 1280, 0.3f, 3), 3);  // as set
}

// Grasp model: a true grasp of a lone part succeeds; moved off it, it matches nothing; the same grasp
// against a wall or next to a neighbour collides.
// What a drag moves: the part whose top the closed tool presses on, the upper of two stacked ones.
TEST(GraspModel, PressedPartIsTheOneUnderTheTool) {
  const PartType type = PartType::circle_nut;  // 20 mm across, 5 mm thick
  Scene<float> scene;
  const int low = scene.add_part(type, Eigen::Matrix3f::Identity(), Vector2<float>(0, 0));
  const int far = scene.add_part(type, Eigen::Matrix3f::Identity(), Vector2<float>(0.1f, 0));
  EXPECT_EQ(pressed_part(scene, Eigen::Vector3f(0, 0, 0.003f), 0.005f), low);   // 2 mm into its top
  EXPECT_EQ(pressed_part(scene, Eigen::Vector3f(0.1f, 0, 0.003f), 0.005f), far);
  EXPECT_EQ(pressed_part(scene, Eigen::Vector3f(0, 0, 0.02f), 0.005f), -1);     // above it
  EXPECT_EQ(pressed_part(scene, Eigen::Vector3f(0.05f, 0, 0.003f), 0.005f), -1);  // between them
  const int high = scene.add_part(type, Eigen::Matrix3f::Identity(), Vector2<float>(0, 0));  // on top of `low`
  ASSERT_GT(scene.parts().back().T_base_part.translation().z(), 0.004f);
  EXPECT_EQ(pressed_part(scene, Eigen::Vector3f(0, 0, 0.006f), 0.005f), high);
}

TEST(GraspModel, JudgesTolerancesAndCollisions) {
  const PartType type = PartType::pencil_coupler;
  Scene<float> scene;
  const auto& model = scene.model(type);
  scene.add_part(type, model.rest_orientations[0], Vector2<float>(0, 0));
  const auto& part = scene.parts()[0];
  // The registered grasp approaching most nearly straight down (base −z).
  int best = -1;
  float best_dot = -2;
  for (std::size_t k = 0; k < model.grasps.size(); ++k) {
    const float d = (part.T_base_part * model.grasps[k].T_part_grasp).linear().col(2).dot(-Eigen::Vector3f::UnitZ());
    if (d > best_dot) {
      best_dot = d;
      best = int(k);
    }
  }
  ASSERT_GT(best_dot, 0.9f);
  const auto& g = model.grasps[std::size_t(best)];
  const Isometry3f T = part.T_base_part * g.T_part_grasp;
  const auto ok = evaluate_pick(scene, type, T, model.gripper, g.opening);
  EXPECT_EQ(ok.status, PickStatus::success) << to_string(ok.status);
  EXPECT_EQ(ok.part_id, part.id);
  // 6 mm sideways and up, or tilted by 23°: beyond the tolerances.
  Isometry3f off = T;
  off.translation() += Eigen::Vector3f(0.006f, 0, 0);
  off.translation().z() += 0.006f;
  const auto missed = evaluate_pick(scene, type, off, model.gripper, g.opening);
  EXPECT_EQ(missed.status, PickStatus::no_matching_grasp);
  // The offset to the nearest true grasp is the displacement (every registered grasp of the coupler
  // shares its grasp point), and its norm the nearest position error.
  EXPECT_LT((missed.nearest_offset - Eigen::Vector3f(0.006f, 0, 0.006f)).norm(), 1e-5f);
  EXPECT_NEAR(missed.nearest_offset.norm(), missed.nearest_position_error, 1e-6f);
  EXPECT_LT(ok.nearest_offset.norm(), 1e-5f);
  Isometry3f near = T;  // 2 mm along −y: within the position tolerance, offset as displaced
  near.translation().y() -= 0.002f;
  const auto held = evaluate_pick(scene, type, near, model.gripper, g.opening);
  EXPECT_EQ(held.status, PickStatus::success) << to_string(held.status);
  EXPECT_LT((held.nearest_offset - Eigen::Vector3f(0, -0.002f, 0)).norm(), 1e-5f);
  // Turned by 23° about the approach axis: the closing axis is 23° off, beyond angle_tolerance.
  const Eigen::Vector3f closing = T.linear().col(0), approach = T.linear().col(2);
  Isometry3f tilted = T;
  tilted.linear() = Eigen::AngleAxisf(0.4f, approach).toRotationMatrix() * T.linear();
  EXPECT_EQ(evaluate_pick(scene, type, tilted, model.gripper, g.opening).status, PickStatus::no_matching_grasp);
  // Turned by 23° about the closing axis: the jaws' planes stay where they were, so the grip holds
  // (within jaw_turn_tolerance, 29°) although the approach axis is 23° off; by 34° it misses, and so
  // does the 23° turn when the approach axis must lie within angle_tolerance (jaw_turn_tolerance 0).
  Isometry3f turned = T;
  turned.linear() = Eigen::AngleAxisf(0.4f, closing).toRotationMatrix() * T.linear();
  const auto turned_held = evaluate_pick(scene, type, turned, model.gripper, g.opening);
  EXPECT_EQ(turned_held.status, PickStatus::success) << to_string(turned_held.status);
  EXPECT_NEAR(turned_held.jaw_turn, 0.4f, 1e-3f);
  EXPECT_NEAR(turned_held.angle_error, 0.4f, 1e-3f);
  EXPECT_LT(turned_held.closing_error, 1e-3f);
  EXPECT_LT(ok.jaw_turn, 1e-3f);
  Isometry3f turned_far = T;
  turned_far.linear() = Eigen::AngleAxisf(-0.6f, closing).toRotationMatrix() * T.linear();
  EXPECT_EQ(evaluate_pick(scene, type, turned_far, model.gripper, g.opening).status, PickStatus::no_matching_grasp);
  GraspModelSettings<float> approach_axis;
  approach_axis.jaw_turn_tolerance = 0;
  EXPECT_EQ(evaluate_pick(scene, type, turned, model.gripper, g.opening, approach_axis).status,
            PickStatus::no_matching_grasp);
  // A turn and a tilt of the closing axis together: the tilt still counts.
  Isometry3f turned_tilted = T;
  turned_tilted.linear() = Eigen::AngleAxisf(0.3f, approach).toRotationMatrix() *
                           Eigen::AngleAxisf(0.3f, closing).toRotationMatrix() * T.linear();
  EXPECT_EQ(evaluate_pick(scene, type, turned_tilted, model.gripper, g.opening).status, PickStatus::no_matching_grasp);
  // The jaws closing from the other side (x and −x swapped) turn alike.
  Isometry3f turned_flipped = turned;
  turned_flipped.linear() = turned.linear() * Eigen::AngleAxisf(float(M_PI), Eigen::Vector3f::UnitZ()).toRotationMatrix();
  EXPECT_EQ(evaluate_pick(scene, type, turned_flipped, model.gripper, g.opening).status, PickStatus::success);

  // Collisions are judged at the turned pose: a coupler with one end at a wall, gripped in its middle.
  // Turned 27° about the closing axis the fingers' upper ends swing 14 mm along the coupler's axis:
  // into the wall when they swing toward it, clear of it the other way.
  Scene<float> at_wall;
  at_wall.add_part(type, model.rest_orientations[0], Vector2<float>(0, 1.0f));  // clamped to the +y wall
  const Isometry3f Tw = at_wall.parts()[0].T_base_part * g.T_part_grasp;
  const float to_wall = at_wall.bin().width / 2 - Tw.translation().y();
  ASSERT_GT(to_wall, 0.006f);
  ASSERT_LT(to_wall, 0.0165f);
  ASSERT_EQ(evaluate_pick(at_wall, type, Tw, model.gripper, g.opening).status, PickStatus::success);
  int into_wall = 0, clear_of_wall = 0;
  for (const float sign : {-1.0f, 1.0f}) {
    Isometry3f Tt = Tw;
    Tt.linear() = Eigen::AngleAxisf(sign * 0.48f, Tw.linear().col(0)).toRotationMatrix() * Tw.linear();
    const auto r = evaluate_pick(at_wall, type, Tt, model.gripper, g.opening);
    into_wall += r.status == PickStatus::bin_collision;
    clear_of_wall += r.status == PickStatus::success;
  }
  EXPECT_EQ(into_wall, 1);
  EXPECT_EQ(clear_of_wall, 1);

  // Against the wall: the same part dropped into a corner, the jaw closing toward the wall.
  Scene<float> corner;
  corner.add_part(type, model.rest_orientations[0], Vector2<float>(0.25f, 0.0f));  // axis along y, clamped to the +x wall
  const auto& cp = corner.parts()[0];
  int down = -1;
  float dd = -2;
  for (std::size_t k = 0; k < model.grasps.size(); ++k) {
    const float d = (cp.T_base_part * model.grasps[k].T_part_grasp).linear().col(2).dot(-Eigen::Vector3f::UnitZ());
    if (d > dd) {
      dd = d;
      down = int(k);
    }
  }
  const Isometry3f Tc = cp.T_base_part * model.grasps[std::size_t(down)].T_part_grasp;
  EXPECT_EQ(evaluate_pick(corner, type, Tc, model.gripper, g.opening).status, PickStatus::bin_collision);

  // A neighbour lying alongside, touching: the jaw between them hits its spheres.
  Scene<float> pair;
  pair.add_part(type, model.rest_orientations[0], Vector2<float>(0, 0));
  const Eigen::Vector3f across = pair.parts()[0].T_base_part.linear() * Eigen::Vector3f::UnitX();  // the jaws close along it
  pair.add_part(type, model.rest_orientations[0], Vector2<float>(0.011f * across.x(), 0.011f * across.y()));
  const Isometry3f Tp = pair.parts()[0].T_base_part * g.T_part_grasp;
  const auto hit = evaluate_pick(pair, type, Tp, model.gripper, g.opening);
  EXPECT_EQ(hit.status, PickStatus::part_collision) << to_string(hit.status);
  EXPECT_TRUE(hit.part_collision_in_mesh);  // 1 mm apart: the 4 mm finger enters the neighbour itself
  EXPECT_FALSE(hit.grazed_spheres_only);
  GraspModelSettings<float> on_spheres;
  on_spheres.jaws_against_mesh = false;
  EXPECT_EQ(evaluate_pick(pair, type, Tp, model.gripper, g.opening, on_spheres).status, PickStatus::part_collision);
  // 15.5 mm apart: 0.5 mm between the finger (10 mm off the axis) and the neighbour's side; its
  // spheres reach 0.9 mm past that side. Held when judged on the mesh (the default), failed on spheres.
  Scene<float> gap;
  gap.add_part(type, model.rest_orientations[0], Vector2<float>(0, 0));
  gap.add_part(type, model.rest_orientations[0], Vector2<float>(0.0155f * across.x(), 0.0155f * across.y()));
  const Isometry3f Tg = gap.parts()[0].T_base_part * g.T_part_grasp;
  const auto grazed = evaluate_pick(gap, type, Tg, model.gripper, g.opening);
  EXPECT_EQ(grazed.status, PickStatus::success) << to_string(grazed.status);
  EXPECT_TRUE(grazed.grazed_spheres_only);
  const auto grazed_on_spheres = evaluate_pick(gap, type, Tg, model.gripper, g.opening, on_spheres);
  EXPECT_EQ(grazed_on_spheres.status, PickStatus::part_collision) << to_string(grazed_on_spheres.status);
  EXPECT_FALSE(grazed_on_spheres.part_collision_in_mesh);
  EXPECT_FALSE(grazed_on_spheres.grazed_spheres_only);
  // Far apart: not even the spheres are reached.
  Scene<float> apart;
  apart.add_part(type, model.rest_orientations[0], Vector2<float>(0, 0));
  apart.add_part(type, model.rest_orientations[0], Vector2<float>(0.03f * across.x(), 0.03f * across.y()));
  const auto clear = evaluate_pick(apart, type, apart.parts()[0].T_base_part * g.T_part_grasp, model.gripper, g.opening);
  EXPECT_EQ(clear.status, PickStatus::success) << to_string(clear.status);
  EXPECT_FALSE(clear.grazed_spheres_only);
}

namespace {

// Whether a dense barycentric sampling of the triangle (a, b, c) has a point within `grow` of the box
// (grow < 0: at least -grow inside it).
bool sampled_overlap(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                     const Eigen::Vector3d& c, double grow, int n) {
  for (int i = 0; i <= n; ++i)
    for (int j = 0; i + j <= n; ++j) {
      const Eigen::Vector3d p = a + (b - a) * (double(i) / n) + (c - a) * (double(j) / n);
      if (grow < 0 ? ((p - lo).minCoeff() >= -grow && (hi - p).minCoeff() >= -grow)
                   : ((p - hi).cwiseMax(lo - p).cwiseMax(0.0)).norm() <= grow)
        return true;
    }
  return false;
}

}  // namespace

// The exact box–triangle test of the judge agrees with a dense sampling of the triangle: a sample in
// the box (1 µm inside: touching is decided by rounding) means overlap, and overlap means a sample
// within one sampling step of the box.
RC_GTEST_PROP(GraspModel, BoxTriangleTestAgreesWithSampling, ()) {
  const auto coord = [] { return *rc::gen::inRange(-30, 31) * 1e-3; };
  Eigen::Vector3d lo(coord(), coord(), coord()), hi = lo;
  hi += Eigen::Vector3d(*rc::gen::inRange(1, 25), *rc::gen::inRange(1, 25), *rc::gen::inRange(1, 25)) * 1e-3;
  const Eigen::Vector3d a(coord(), coord(), coord()), b(coord(), coord(), coord()), c(coord(), coord(), coord());
  const bool overlap = sim::detail::box_overlaps_triangle(lo, hi, a, b, c);
  const int n = 120;
  const double step = std::max({(b - a).norm(), (c - a).norm(), (c - b).norm()}) / n;
  if (sampled_overlap(lo, hi, a, b, c, -1e-6, n)) RC_ASSERT(overlap);
  if (overlap) RC_ASSERT(sampled_overlap(lo, hi, a, b, c, step, n));
  RC_TAG(overlap ? "overlap" : "apart");
}

// End to end on clean depth of a sparse bin: most estimated reachable grasps are judged successful.
TEST(GraspModel, EstimatedReachableGraspsMostlySucceed) {
  const StereoSensor<float> sensor(sensor_settings(false));
  int tried = 0, succeeded = 0;
  for (const PartType type : {PartType::pencil_coupler, PartType::circle_nut}) {
    SceneSettings<float> s;
    s.part_type = type;
    s.num_parts = 8;
    s.pile_spread = 0.06f;
    const Scene<float> scene = Scene<float>::generate(s, 21);
    const auto frame = sensor.render(scene, kReference, 0);
    const Estimator est(scene.model(type), settings_for(sensor.camera()));
    const auto r = est.estimate_detailed(input_of(frame.depth, sensor.camera()));
    for (std::size_t i = 0; i < r.result.objects.size(); ++i) {
      if (!r.details[i].grasp_reachable) continue;
      ++tried;
      succeeded += judge_grasp(scene, type, r, i).success();
    }
  }
  ASSERT_GE(tried, 4);
  EXPECT_GE(double(succeeded), 0.75 * double(tried)) << succeeded << " of " << tried;
}

// The gripper check on metal depth (noise, edge bleeding): of the grasps on correctly estimated parts,
// those it finds clear must mostly succeed and more often than the ones it flags, and it must find
// some clear (a check that flags every grasp tells the cell nothing). Judged with the jaw opened as
// the estimator was told it opens.
TEST(ReferenceEstimator, GraspClearanceOnMetalDepthSeparatesGoodFromBlockedGrasps) {
  const StereoSensor<float> sensor(sensor_settings(true));
  int clear = 0, clear_ok = 0, blocked = 0, blocked_ok = 0;
  for (const PartType type : {PartType::lan_connector, PartType::mirror_nut}) {
    for (std::uint64_t seed = 31; seed < 37; ++seed) {
      const Scene<float> scene = pile(type, 10, seed);
      const auto frame = sensor.render(scene, kReference, 0);
      ReferenceEstimatorSettings<float> es = settings_for(sensor.camera());
      es.gripper.approach_opening = widest_opening(scene.model(type));
      const Estimator est(scene.model(type), es);
      auto in = input_of(frame.depth, sensor.camera());
      in.up_camera = kReference.linear().transpose() * Eigen::Vector3f::UnitZ();
      const auto r = est.estimate_detailed(in);
      for (std::size_t i = 0; i < r.result.objects.size(); ++i) {
        const auto& o = r.result.objects[i];
        const auto judged = evaluate_pick(scene, type, Isometry3f(kReference * o.T_camera_grasp), o.gripper,
                                          es.gripper.approach_opening);
        if (judged.status == PickStatus::no_matching_grasp) continue;  // a wrong pose: not the check's doing
        const bool ok = judged.success();
        (o.grasp_clear ? clear : blocked) += 1;
        (o.grasp_clear ? clear_ok : blocked_ok) += ok;
      }
    }
  }
  ASSERT_GE(clear, 6) << "clear " << clear << ", blocked " << blocked;
  ASSERT_GE(blocked, 1) << "clear " << clear << ", blocked " << blocked;
  const double clear_rate = double(clear_ok) / clear, blocked_rate = double(blocked_ok) / blocked;
  EXPECT_GE(clear_rate, 0.75) << clear_ok << " of " << clear << " clear grasps succeed";
  EXPECT_GT(clear_rate, blocked_rate) << clear_ok << "/" << clear << " vs " << blocked_ok << "/" << blocked;
}

// A coupler against a wall that shows only specks of depth (1 pixel in 9 measured, as shiny metal
// does): read as free space, the holes between the specks let the gripper check pass a grasp whose
// fingers stand in the wall; with hole_reach the specks around a hole stand in for it and the check
// turns the grasp away from the wall, as it does on the whole wall.
TEST(ReferenceEstimator, GripperCheckDoesNotReachIntoHoles) {
  const CouplerAtWall cell;
  DepthImage<float> specks = cell.frame.depth;
  ASSERT_GT(cell.remove_wall(specks, [](int u, int v) { return u % 3 == 0 && v % 3 == 0; }), 1000);  // in view
  // Gripper samples of the clear grasp inside the wall (the grasp's fingers also meet the floor: see
  // the next test), -1 when the grasp is blocked.
  const auto fingers_in_wall = [&](const DepthImage<float>& depth, float hole_reach) {
    ReferenceEstimatorSettings<float> es;
    es.gripper.approach_opening = widest_opening(cell.scene.model(cell.type));
    es.hole_reach = hole_reach;
    Estimator est(cell.scene.model(cell.type), es);
    auto in = input_of(depth, cell.camera());
    in.up_camera = cell.T_base_camera.linear().transpose() * Eigen::Vector3f::UnitZ();
    const auto r = est.estimate(in);
    EXPECT_EQ(r.objects.size(), 1u);
    if (r.objects.empty() || !r.objects[0].grasp_clear) return -1;
    return cell.fingers_in_wall(r.objects[0], es.gripper);
  };
  const float reach = ReferenceEstimatorSettings<float>().hole_reach;
  ASSERT_GT(reach, 0.f);
  EXPECT_EQ(fingers_in_wall(cell.frame.depth, reach), 0) << "whole wall";
  const int free_space = fingers_in_wall(specks, 0.f);
  EXPECT_GT(free_space, 50) << "holes read as free space";
  // The default bridges a pixel around each sample here (1.2 mm): a finger edge still grazes the wall
  // (measured: 9 samples at 1 mm spacing, against 108); 2 mm bridges two and none touches.
  const int bridged = fingers_in_wall(specks, reach);
  EXPECT_GE(bridged, 0) << "blocked";
  EXPECT_LT(bridged, free_space / 10) << "holes bridged by hole_reach";
  EXPECT_EQ(fingers_in_wall(specks, 0.002f), 0);
}

// A part against a wall, the wall cropped out of the depth the estimator recognizes on: without the
// uncropped depth (EstimatorInput::obstacles) the gripper check cannot see the wall and closes the jaw
// into it; with it, it turns the grasp about the part's axis until no finger stands in the wall. (That
// tilted grasp still meets the floor: floor within own_surface_margin of the part's underside counts
// as the part, the known price of that margin.)
TEST(ReferenceEstimator, GripperCheckSeesWallsInTheObstacleDepth) {
  const CouplerAtWall cell;
  const PartType type = cell.type;
  const Scene<float>& scene = cell.scene;
  const auto& model = scene.model(type);
  const Isometry3f& T_base_camera = cell.T_base_camera;
  const auto& frame = cell.frame;
  const Camera& cam = cell.camera();
  DepthImage<float> cropped = frame.depth;
  ASSERT_GT(cell.remove_wall(cropped, [](int, int) { return false; }), 1000);  // the wall was in view
  ReferenceEstimatorSettings<float> es;
  es.gripper.approach_opening = widest_opening(model);
  Estimator est(model, es);
  auto in = input_of(cropped, cam);
  in.up_camera = T_base_camera.linear().transpose() * Eigen::Vector3f::UnitZ();
  const auto blind = est.estimate(in);
  in.obstacles = frame.depth.view();
  const auto seeing = est.estimate(in);
  ASSERT_EQ(blind.objects.size(), 1u);
  ASSERT_EQ(seeing.objects.size(), 1u);
  const auto judge = [&](const cycle::RecognizedObject<float>& o) {
    return evaluate_pick(scene, type, Isometry3f(T_base_camera * o.T_camera_grasp), o.gripper, es.gripper.approach_opening).status;
  };
  EXPECT_TRUE(blind.objects[0].grasp_clear);
  EXPECT_EQ(judge(blind.objects[0]), PickStatus::bin_collision);
  EXPECT_TRUE(seeing.objects[0].grasp_clear);
  EXPECT_GT(cell.fingers_in_wall(blind.objects[0], es.gripper), 10);
  EXPECT_EQ(cell.fingers_in_wall(seeing.objects[0], es.gripper), 0);
  // The known bin (EstimatorInput::bin) instead of the obstacle depth. Lying against the wall, every
  // grasp of the coupler puts a finger in the wall or the floor; the depth alone does not show it
  // (its choice above hits the bin too), the known bin does: no grasp is clear.
  EXPECT_EQ(judge(seeing.objects[0]), PickStatus::bin_collision);
  in.obstacles = DepthImageView<float>();
  give_bin(in, scene, T_base_camera);
  const auto knowing = est.estimate(in);
  ASSERT_EQ(knowing.objects.size(), 1u);
  EXPECT_FALSE(knowing.objects[0].grasp_clear);
  // The same bin believed 5 cm further along x: the grasp from above is clear to the estimator.
  in.T_base_camera.translation().x() -= 0.05f;
  const auto elsewhere = est.estimate(in);
  ASSERT_EQ(elsewhere.objects.size(), 1u);
  EXPECT_TRUE(elsewhere.objects[0].grasp_clear);
  DepthImage<float> small(10, 10);
  in.obstacles = small.view();
  EXPECT_THROW(est.estimate(in), std::invalid_argument);
}
