// binpick_grasp_eval: how often the reference estimator's grasps would hold, judged by the simulated
// world on many piles, without running the cell. Per pile: the simulated metal stereo sensor takes
// n views of a fresh pile from a given distance (view 1 straight down over the bin centre, the others
// on a circle around it), the library fuses them (exact poses: no motion error), the estimator
// recognizes on the fused depth, and every grasp it finds clear is judged as SimGripper judges a grip
// (sim/grasp_model.hpp). Reported per part type: grasps judged and held, the first pick (the most
// confident clear grasp, the one the cell tries), and why the others would fail.
//
// Also reported: the median offset of the judged grasp points from their nearest true grasp points, in
// the reference camera's frame (x along the image rows, y down the columns, z away from the camera),
// over the grasps within twice the position tolerance of one (gross misrecognitions left out): the
// estimator's systematic error, which a picking run's complete rate hides. On the simulated metal
// sensor it shows the fits pulled toward +x, the side a left-camera stereo matcher fattens edges to.
//
// And for every grasp that matched no true grasp (a pose error, not a collision): whether the
// estimator's own score (ReferenceEstimator::score_pose) rates the nearest true part's pose higher
// than the pose it reported. Not higher: the score itself prefers the wrong pose, and no search over
// it can help; the score, or what the sensor lets it see, must change. Higher: the fit stopped at a
// pose its score rates below the truth; a wider search helps only where no other wrong pose nearby
// scores higher still. Parts farther than their bounding radius from the reported pose count as
// neither (a fit where no part is).
//
// Why next to binpick_sim: a picking run is chaotic (one failed grip changes every later cycle), so
// ten runs of binpick_sim cannot tell an estimator setting that helps from one that does not; the
// hundreds of grasps judged here can (all figures simulated).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "binpick/fusion/fuse.hpp"
#include "io.hpp"
#include "sim_cell.hpp"

using namespace binpick;
using S = float;
using Camera = PinholeCamera<S>;

namespace {

struct Options {
  std::vector<sim::PartType> types;
  int piles = 20, parts = 20, views = 4;
  std::uint64_t seed = 1;
  double distance = 0.30;  // camera height over the bin floor [m]
  int width = 640, height = 512;
  bool json = false;
};

struct TypeResult {
  int piles = 0, recognized = 0, first_tried = 0, first_held = 0;
  int truth_scores_higher = 0, truth_scores_lower = 0, no_part_near = 0;  // of the grasps matching no true grasp
  simcell::GripLedger grips;
};

int usage(const char* argv0) {
  std::fprintf(stderr,
               "usage: %s [--types all|NAME,...] [--piles N] [--parts P] [--views N] [--seed S]\n"
               "          [--distance M] [--resolution 640x512|1280x1024] [--json]\n"
               "  The reference estimator's clear grasps on simulated metal piles, judged by the simulated\n"
               "  world (all figures simulated). Defaults: all 5 types, 20 piles of 20 parts, 4 views from\n"
               "  0.30 m, 640x512, seed 1.\n",
               argv0);
  return 2;
}

Isometry3<S> look_at(const Vector3<S>& eye, const Vector3<S>& target) {
  return camera_looking_at<S>(eye, target, Vector3<S>::UnitY());
}

// The nearest true part (by origin) to a recognized object whose grasp matched no true grasp, scored
// as the estimator scored its fit (the object's confidence is that score; see the file comment).
void score_truth(const sim::ReferenceEstimator<S, Camera>& est, const cycle::EstimatorInput<S, Camera>& in,
                 const sim::Scene<S>& scene, const Isometry3<S>& T_base_reference, const cycle::RecognizedObject<S>& obj,
                 TypeResult& out) {
  const Vector3<S> at = T_base_reference * obj.T_camera_object.translation();
  const sim::PlacedPart<S>* nearest = nullptr;
  S best = std::numeric_limits<S>::infinity();
  for (const auto& p : scene.parts()) {
    const S d = (p.T_base_part.translation() - at).norm();
    if (d < best) best = d, nearest = &p;
  }
  if (!nearest || !(best <= scene.model(nearest->type).bounding_radius)) {
    ++out.no_part_near;
    return;
  }
  const S truth = est.score_pose(in, 0, Isometry3<S>(T_base_reference.inverse(Eigen::Isometry) * nearest->T_base_part));
  ++(truth > obj.confidence_percent ? out.truth_scores_higher : out.truth_scores_lower);
}

TypeResult evaluate(sim::PartType type, const Options& o) {
  sim::StereoSensorSettings<S> ss;
  ss.width = o.width;
  ss.height = o.height;
  ss.num_threads = 0;
  const Camera camera = sim::StereoSensor<S>(ss).camera();  // the same for every pile (seed: noise only)
  TypeResult out;
  const sim::GraspModelSettings<S> judge;  // SimGripper's tolerances
  FusionSettings<S> fs = cycle::PipelineSettings<S>::default_fusion();  // as the cell fuses
  fs.sensor_accuracy = ss.accuracy;
  fs.num_threads = 0;
  Fuser<S, Camera> fuser(camera);
  // View 1 over the bin centre; the others on a circle of distance/6 (a sensing arc's spread), a
  // little lower, turned further for each pile.
  const S height = S(o.distance);
  const Vector3<S> centre = Vector3<S>::Zero();
  const Isometry3<S> T_base_reference = look_at(Vector3<S>(0, 0, height), centre);
  std::optional<sim::ReferenceEstimator<S, Camera>> est;  // made with the first pile's part model
  sim::ReferenceEstimatorSettings<S> es;
  for (int pile = 0; pile < o.piles; ++pile) {
    const std::uint64_t seed = o.seed * 1000003ULL + std::uint64_t(int(type)) * 7919ULL + std::uint64_t(pile);
    ss.seed = seed;
    const sim::StereoSensor<S> sensor(ss);
    sim::SceneSettings<S> sc;
    sc.part_type = type;
    sc.num_parts = o.parts;
    const sim::Scene<S> scene = sim::Scene<S>::generate(sc, seed);
    const auto geo = sim::SceneGeometry<S>::build(scene, ss.errors.bin_material, ss.errors.table_material);
    std::vector<Isometry3<S>> poses{T_base_reference};
    for (int k = 1; k < o.views; ++k) {
      const S a = S(2 * M_PI) * S(k - 1) / S(o.views - 1) + S(0.3) * S(pile);
      const S r = height / 6;
      poses.push_back(look_at(Vector3<S>(r * std::cos(a), r * std::sin(a), height - S(0.01)), centre));
    }
    std::vector<sim::StereoFrame<S>> frames;
    for (std::size_t k = 0; k < poses.size(); ++k) frames.push_back(sensor.render(geo, poses[k], k));
    std::vector<DepthImageView<S>> views;
    for (const auto& f : frames) views.push_back(f.depth.view());
    const auto fused = fuser.fuse(views, poses, fs);

    if (!est) {
      // The estimator as the cell sets it up, its region of interest the bin's inside shrunk by 1 cm
      // (the cell crops the fused depth to it instead).
      es.num_threads = 0;
      es.gripper.approach_opening = sim::widest_opening(scene.model(type));
      const Isometry3<S> T_camera_base = T_base_reference.inverse(Eigen::Isometry);
      const S hx = scene.bin().length / 2 - S(0.01), hy = scene.bin().width / 2 - S(0.01);
      const auto a = camera.project(T_camera_base * Vector3<S>(-hx, hy, 0));
      const auto b = camera.project(T_camera_base * Vector3<S>(hx, -hy, 0));
      if (a && b) {
        es.roi_u0 = std::max(0, int(std::min(a->x(), b->x())));
        es.roi_u1 = int(std::max(a->x(), b->x()));
        es.roi_v0 = std::max(0, int(std::min(a->y(), b->y())));
        es.roi_v1 = int(std::max(a->y(), b->y()));
      }
      est.emplace(scene.model(type), es);
    }
    cycle::EstimatorInput<S, Camera> in;
    in.depth = fused.depth.view();
    in.camera = &camera;
    in.up_camera = T_base_reference.linear().transpose() * Vector3<S>::UnitZ();
    const auto r = est->estimate_detailed(in);
    ++out.piles;
    out.recognized += int(r.result.objects.size());
    bool first = true;  // objects come most confident first
    for (const auto& obj : r.result.objects) {
      if (!obj.grasp_clear) continue;
      const auto judged = sim::evaluate_pick(scene, type, Isometry3<S>(T_base_reference * obj.T_camera_grasp), obj.gripper,
                                             es.gripper.approach_opening, judge);
      out.grips.record(judged, judge);
      out.grips.record_offset(judged, judge, T_base_reference);
      if (judged.status == sim::PickStatus::no_matching_grasp) score_truth(*est, in, scene, T_base_reference, obj, out);
      if (first) {
        ++out.first_tried;
        out.first_held += judged.success();
        first = false;
      }
    }
    if (first) ++out.grips.nothing_recognized;  // no clear grasp on this pile
  }
  return out;
}

std::string percent(int a, int b) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f %%", b > 0 ? 100.0 * a / b : 0.0);
  return buf;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  std::string types = "all";
  try {
    for (tools::Args args(argc, argv); args.next();) {
      const std::string& a = args.flag();
      auto next = [&] { return args.value(); };
      if (a == "--types") types = next();
      else if (a == "--piles") o.piles = std::stoi(next());
      else if (a == "--parts") o.parts = std::stoi(next());
      else if (a == "--views") o.views = std::stoi(next());
      else if (a == "--seed") o.seed = std::stoull(next());
      else if (a == "--distance") o.distance = std::stod(next());
      else if (a == "--json") o.json = true;
      else if (a == "--resolution") {
        const std::string r = next();
        if (r == "640x512") o.width = 640, o.height = 512;
        else if (r == "1280x1024") o.width = 1280, o.height = 1024;
        else throw std::invalid_argument("--resolution must be 640x512 or 1280x1024");
      } else if (a == "--help" || a == "-h") return usage(argv[0]);
      else throw std::invalid_argument("unknown option " + a);
    }
    if (o.piles < 1 || o.parts < 1 || o.views < 1) throw std::invalid_argument("--piles, --parts and --views must be >= 1");
    if (!(std::isfinite(o.distance) && o.distance >= 0.16 && o.distance <= 0.9))
      throw std::invalid_argument("--distance must be in [0.16, 0.9] m (the sensor's range, parts below it)");
    o.types = simcell::part_types(types);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "binpick_grasp_eval: %s\n", e.what());
    return usage(argv[0]);
  }
  if (!o.json)
    std::printf("%-15s %6s %10s %7s %13s %16s %14s %14s %22s %24s\n", "type", "piles", "recognized", "judged", "held",
                "first pick held", "missed p/a/c", "hit part/bin", "offset x/y/z [mm]", "truth scores >/<=/none");
  for (const sim::PartType type : o.types) {
    const TypeResult r = evaluate(type, o);
    const auto& g = r.grips;
    using L = simcell::GripLedger;
    if (o.json) {
      std::printf(
          "{\"name\": \"grasp_eval\", \"type\": %s, \"piles\": %d, \"parts\": %d, \"views\": %d, \"distance_m\": %s, "
          "\"width\": %d, \"height\": %d, \"recognized\": %d, \"judged\": %d, \"held\": %d, \"held_share\": %s, "
          "\"first_tried\": %d, \"first_held\": %d, \"no_clear_grasp_piles\": %d, \"no_matching_grasp\": %d, "
          "\"missed_position\": %d, \"missed_approach\": %d, \"missed_closing\": %d, \"part_collision\": %d, "
          "\"bin_collision\": %d, \"offset_grasps\": %zu, \"offset_x_mm\": %s, \"offset_y_mm\": %s, \"offset_z_mm\": %s, "
          "\"missed_truth_scores_higher\": %d, \"missed_truth_scores_lower\": %d, \"missed_no_part_near\": %d}\n",
          tools::json_string(sim::part_type_name(type)).c_str(), r.piles, o.parts, o.views,
          tools::json_number(o.distance).c_str(), o.width, o.height, r.recognized, g.tried(), g.held(),
          tools::json_number(g.tried() ? double(g.held()) / g.tried() : 0.0).c_str(), r.first_tried, r.first_held,
          g.nothing_recognized, g.of(sim::PickStatus::no_matching_grasp), g.missed[L::position], g.missed[L::approach],
          g.missed[L::closing], g.of(sim::PickStatus::part_collision), g.of(sim::PickStatus::bin_collision),
          g.offset_mm[0].size(), tools::json_number(g.offset_median_mm(0)).c_str(), tools::json_number(g.offset_median_mm(1)).c_str(),
          tools::json_number(g.offset_median_mm(2)).c_str(), r.truth_scores_higher, r.truth_scores_lower, r.no_part_near);
    } else {
      char missed[48], hit[32], first[32];
      std::snprintf(missed, sizeof missed, "%d/%d/%d", g.missed[L::position], g.missed[L::approach], g.missed[L::closing]);
      std::snprintf(hit, sizeof hit, "%d/%d", g.of(sim::PickStatus::part_collision), g.of(sim::PickStatus::bin_collision));
      std::snprintf(first, sizeof first, "%d/%d", r.first_held, r.first_tried);
      char offset[48];
      std::snprintf(offset, sizeof offset, "%+.2f/%+.2f/%+.2f", g.offset_median_mm(0), g.offset_median_mm(1), g.offset_median_mm(2));
      char truth[48];
      std::snprintf(truth, sizeof truth, "%d/%d/%d", r.truth_scores_higher, r.truth_scores_lower, r.no_part_near);
      std::printf("%-15s %6d %10d %7d %6d %6s %16s %14s %14s %22s %24s\n", sim::part_type_name(type), r.piles, r.recognized,
                  g.tried(), g.held(), percent(g.held(), g.tried()).c_str(), first, missed, hit, offset, truth);
    }
    std::fflush(stdout);
  }
  return 0;
}
