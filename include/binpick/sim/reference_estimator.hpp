#pragma once
/// \file reference_estimator.hpp
/// A reference 6D pose estimator with grasp selection for the simulated cell, a model of the
/// `PoseEstimator` concept (cycle/drivers_estimator.hpp). It stands in for the paper's template-based
/// CPU estimator [21] (§III.A): the fused depth of the reference view goes in, recognized top parts
/// with a confidence in % and a grasp pose come out.
///
/// It sees only what a real estimator sees — the fused depth (+ optional votes), the camera and the
/// part models — and never the simulated scene: no constructor or member takes a `Scene`, and this
/// header does not include scene.hpp (tests/estimator guards both).
///
/// Per fused image:
///  1. grid: every `stride`-th pixel inside the region of interest backprojected, normals from grid
///     neighbours;
///  2. segments: 4-connected cells whose depth is continuous (step ≤ edge_jump) and whose surface is
///     not concave between them (touching parts meet in concave creases). Segments larger than a part
///     are background (floor, wall, rim), unless a setting splits them into part-sized pieces around
///     their top-most points: split_large_segments the non-flat ones, cluster_min_height (with the bin
///     known) the flat ones above its floor, parts lying flat side by side. Background too are small
///     segments and those with nearer surface along much of their border (not a local height
///     maximum). Candidates are taken top-most first (smallest depth);
///  3. fit: for each candidate and model, the model's principal axes are aligned to the segment's in
///     every distinct way (24 signed axis permutations, fewer after removing the part's symmetries),
///     each start refined by point-to-plane ICP of a subset of the segment on the model's surface
///     samples (registration/icp.hpp with a voxel nearest-sample association); the best starts
///     (confidence × share of the segment's cells the fit supports: a part turned so that a narrower
///     face lies inside the measured one is as well supported, but covers less) are refined with all
///     depth points around the part (optionally without the stereo edge fringe: edge_band_px), an
///     n-fold prism seen along its axis is turned about it to where the segment's outline has its
///     corners (turn_to_outline: a flat face leaves that turn unobservable to ICP), and each must
///     explain most of its segment (fringe aside); the best so ranked wins;
///  4. score: the fitted model's sampled surface is z-buffered into the grid; a visible cell is
///     supported when the measured depth lies within δ, empty when the sensor sees through it (the
///     measured depth lies beyond the model by more than δ): confidence = 100 · (supported − empty) /
///     visible, in [0, 100];
///  5. keep: hypotheses above min_confidence, greedily by confidence, whose supported cells overlap
///     no kept one by more than max_overlap and, when the input gives the bin, whose part does not
///     sink into its floor (max_floor_penetration);
///  6. grasp: of the grasps registered on the model, repeated under every symmetry of the part, those
///     approaching within max_approach_angle of the line of sight whose gripper shape
///     (detail::gripper_samples, opened to the larger of the grasp's opening and
///     gripper.approach_opening) stays in measured free space: fewer than min_colliding_samples of
///     its samples lie more than collision_margin behind measured points that are not the part's own
///     surface (own_surface_margin; over a hole, the nearest surface within hole_reach), and none
///     stands in the bin's walls or floor when the input gives the bin (EstimatorInput::bin); the one
///     nearest to straight down (the input's up direction; the line of sight when unknown), else
///     (flagged unreachable, grasp_clear false) the best aligned one.
///
/// Known limit, on the simulated metal sensor at 1280 × 1024 from 0.3 m. The stereo edge fringe
/// (foreground depth spread 4 px, 2.3 mm, past every edge) is wider than half a 4 mm screw shank, and
/// both the refinement's optimum and the score can sit off a thin part's turn about the line of
/// sight: on static piles 31 of 311 screw grasps missed the jaws' closing axis, and in the picking
/// test 34 of 45 missed screw grasps were 11.5-16° off. And a model cell over a hole counts as
/// visible but unsupported, so of two poses the one showing a shiny face gets the lower confidence
/// (a LAN connector standing on end: the true pose 371 supported of 872 visible cells, 42.5 %; the
/// pose turned a quarter 334 of 612, 54.6 %). binpick_grasp_eval counts, per missed grasp, whether
/// the score prefers the truth. Tried on static piles without gain: fringe points left out in 2-D,
/// a tighter last refinement round, turn searches scored by the confidence or by a predicted fringe.
/// Ranking fits by their support among measured cells only gained there, but lost 10 of 100
/// connectors in the picking test. A fix would model fringe and holes in one likelihood.
/// A polished hex nut standing on one of its flats, alone on the floor, was recognized in 2 of 20
/// scenes (fused from 3 views at 1280 × 1024): its two faces tilted 60° mirror the projector away
/// and show depth behind them, which the score counts as empty (the true pose scored 5–41 %).
/// Not counting faces over 46° from the line of sight as empty recognized 12 of 20, but 11 of those
/// took the axis a quarter turn off: the 6.5 × 7.5 mm top face alone does not tell the axis. Not kept.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <vector>

#ifdef _OPENMP
#include <omp.h>
#endif

#include "binpick/core/camera_model.hpp"
#include "binpick/core/depth_image.hpp"
#include "binpick/core/errors.hpp"
#include "binpick/core/parallel.hpp"
#include "binpick/core/pose.hpp"
#include "binpick/cycle/drivers_estimator.hpp"
#include "binpick/registration/icp.hpp"
#include "binpick/sim/detail/estimator_model.hpp"
#include "binpick/sim/parts.hpp"

namespace binpick::sim {

/// Settings of the reference estimator (defaults tuned for the simulated sensor at ~0.3 m).
template <typename Scalar>
struct ReferenceEstimatorSettings {
  /// Pixel stride of the grid [px]; 0 = automatic: the largest stride at which the smallest model's
  /// bounding radius still spans min_part_cells cells at the image's median depth, at most
  /// ceil(width / 640). At 640 px wide that is every pixel. At 1280 × 1024 from 0.3 m it is every
  /// pixel for the screw, hex nut and round nut (radius under 14 mm) and every second pixel for the
  /// LAN connector and the coupler. Every second pixel hides a hex nut's turn in its 17 px outline:
  /// on the picking test (binpick_sim ours, 1280 × 1024, seed 1, 5 runs of 20) the mirror nut
  /// completed 86 % at stride 2 and 96 % at stride 1, the screw 95 % either way. For the two large
  /// parts every pixel gave 88 and 76 % against 86 and 92 % (runs that also differed in the pipeline's
  /// blocked-grasp rule), at 140 ms mean estimation against 50 ms.
  int stride = 0;
  Scalar min_part_cells = Scalar(12);          ///< automatic stride: cells across the smallest bounding radius
  int min_votes = 0;                           ///< pixels with fewer votes are ignored (when votes are given)
  /// Region of interest [px], inclusive: the bin's inside as the integrator configures it (walls and
  /// rims outside it look like parts to any model fitter). Default: the whole image.
  int roi_u0 = 0, roi_v0 = 0, roi_u1 = std::numeric_limits<int>::max(), roi_v1 = std::numeric_limits<int>::max();
  int normal_offset = 2;                       ///< grid cells spanning the normal's tangents (>= 1)
  Scalar edge_jump = Scalar(0.0025);           ///< depth step between grid neighbours that splits segments [m]
  Scalar concavity_tolerance = Scalar(0.35);   ///< (n_b − n_a)·(p_b − p_a)/|p_b − p_a| below −this: concave crease
  Scalar min_segment_area = Scalar(15e-6);     ///< smaller segments are no candidates [m²]
  Scalar max_segment_area_factor = Scalar(12); ///< segments larger than this × the largest model's area are background
  Scalar planar_rms = Scalar(0.001);           ///< larger-than-a-part segments flatter than this are background [m]
  Scalar max_occluded_border = Scalar(0.35);   ///< candidates with more of their border under nearer surface are dropped
  bool split_large_segments = false;           ///< split part-sized pieces off larger non-flat segments (else: background)
  /// [m] With the bin known (EstimatorInput::bin), a flat segment larger than a part whose mean lies
  /// more than this above the floor, and a part's radius inside the walls, is parts lying flat side
  /// by side, split into part-sized pieces (as split_large_segments splits non-flat ones). Touching
  /// flat parts meet at one height without a crease, and the metal sensor's edge fringe closes the
  /// gap between them: one flat segment, taken for floor (in binpick_sim a mirror-nut run ended with
  /// 3 nuts left that 4 looks in a row recognized none of). Default infinity (off): flat segments
  /// larger than a part are background. binpick_sim (ours, 1280 × 1024, seeds 3-5, 5 runs of 20)
  /// with 0.002 for every type: mirror nut 287 -> 293 of 300, circle nut, LAN connector and coupler
  /// 300 either way, small screw 298 -> 283 (side-by-side shanks pass the flatness test, and a piece
  /// across two of them fits neither: one run failed 5 grips in a row). The simulated cell sets 0.002
  /// for the two nuts (sim_cell).
  Scalar cluster_min_height = std::numeric_limits<Scalar>::infinity();
  int max_candidates = 30;                     ///< candidates fitted per image (top-most first)
  Scalar model_spacing = Scalar(0.0005);       ///< fine model samples (scoring, final ICP) [m]
  Scalar voxel_size = Scalar(0.0006);          ///< voxels of the model's nearest-sample lookup [m]
  int max_coarse_source_points = 120;          ///< segment points used by the first ICP
  int coarse_iterations = 10;                  ///< ICP iterations from each start
  Scalar coarse_distance = Scalar(0.006);      ///< partner distance of the first ICP [m]
  int refined_starts = 2;                      ///< best starts refined on the fine samples
  int fine_iterations = 8;                     ///< ICP iterations of each refinement round (two rounds)
  Scalar fine_distance = Scalar(0.003);        ///< partner distance of the first refinement round [m] (second: half)
  /// Depth points with a farther surface (a drop beyond edge_jump) within this many pixels along
  /// their row, on the edge_band_side, are left out of the refinement and of the share of its segment
  /// a fit must explain. A stereo matcher reports the foreground's depth over part of its matching
  /// window of background beside an edge (edge fattening); that fringe pulls the fit sideways.
  /// 0 (default) = use all points. Measured with 1 on the simulated metal sensor (640 px): on static
  /// piles (binpick_grasp_eval, 40 per type) the pencil couplers' mean position error along the image
  /// rows 1.38 -> 0.63 mm and grasps held 1386 -> 1443 of about 1620 over the 5 types, but the first
  /// pick per pile, the one a cell tries, held 177 of 200 either way; in the picking test (binpick_sim
  /// ours, seed 1, 5 runs of 20) the complete rate fell from 90.6 to 88.2 % (coupler 94 -> 83 %,
  /// mirror nut 81 -> 87 %), and on clean depth 5 instead of 7 of 9 top screws came within 2 mm / 2°
  /// (true points of a thin shank left out). Hence off by default.
  int edge_band_px = 0;
  /// The side of an object its fringe lies on, along the image rows: +1 toward +u (depth in the left
  /// camera of a rig whose right camera sits at +x: the occlusion holes lie on the −u side of the
  /// foreground, the fattening on the +u side), −1 toward −u, 0 both.
  int edge_band_side = 1;
  Scalar support_distance = Scalar(0.0015);    ///< δ: measured depth within this of the model supports it [m]
  Scalar grazing_cosine = Scalar(0.25);        ///< model samples seen more obliquely than this are not scored
  Scalar outline_max_tilt = Scalar(0.6);       ///< n-fold prisms: turn to the outline's corners up to this axis tilt [rad]
  Scalar outline_min_strength = Scalar(0.3);   ///< ... when they show this × as clearly as on the model (0 = never)
  Scalar explain_distance = Scalar(0.0015);    ///< a segment point this near the fitted model is explained [m]
  Scalar min_segment_explained = Scalar(0.6);  ///< fits explaining less of their segment are dropped
  Scalar min_confidence = Scalar(35);          ///< [%] weaker hypotheses are dropped
  /// With the bin known (EstimatorInput::bin), a hypothesis whose part would reach more than this below
  /// the floor is dropped: a flat piece of floor between holes fits a part sunk into it [m].
  Scalar max_floor_penetration = Scalar(0.003);
  Scalar max_overlap = Scalar(0.3);            ///< share of a hypothesis' supported cells another kept one may own
  Scalar max_approach_angle = Scalar(1.05);    ///< grasp approach vs line of sight [rad] (60°)
  /// A gripper sample collides where the measured surface lies more than this in front of it [m]:
  /// about the fused depth's noise on metal (single samples 1-2 mm in front of the truth are common).
  Scalar collision_margin = Scalar(0.002);
  /// Measured points this near the fitted part's own surface are the part, not an obstacle [m]: they
  /// absorb the pose's error and the sensor's bleeding past the part's edges (the fingers stand 1 mm
  /// off its faces). The price: floor and neighbours within it of the part's underside are not seen
  /// either (exempting only faces turned toward the camera cost more picks in the cell than it saved).
  Scalar own_surface_margin = Scalar(0.004);
  int min_colliding_samples = 3;               ///< a grasp is blocked from this many colliding samples (one may be noise)
  /// [m] A gripper sample over a pixel without a measurement is checked against the nearest measured
  /// surface within this distance of it (the window's smallest depth) instead of passing as free space:
  /// a shiny neighbour shows only specks of depth, and fingers went into the holes between them (0 =
  /// holes are free space). Measured with 0.0015 against 0 on static piles (binpick_grasp_eval, 20
  /// piles, 3 views): at 1280 × 1024 gripper hits on neighbours fell from 34 to 22 (pencil coupler)
  /// and 39 to 20 (mirror nut) and first picks held rose from 16 to 18 and 14 to 19 of 20; at 640 × 512
  /// hits fell from 16 to 12 (coupler), 14 to 9 (LAN connector) and 6 to 4 (circle nut), first picks
  /// held 85 -> 89 of 100 over the five types.
  Scalar hole_reach = Scalar(0.0015);
  int symmetry_steps = 36;                     ///< a continuous symmetry offers grasps every 2π / this [-]
  GripperGeometry<Scalar> gripper;             ///< shapes checked against the depth
  int num_threads = 1;                         ///< candidates in parallel (0 = all cores); same output for any count
};

/// Diagnostics of one recognized object (same order as EstimationResult::objects).
template <typename Scalar>
struct RecognitionDetail {
  bool grasp_reachable = false;  ///< a registered grasp approaches from above and misses the measured depth
  int grasp_index = -1;          ///< index into the model's grasps
  Scalar supported_share = 0;    ///< supported / visible cells
  Scalar empty_share = 0;        ///< empty / visible cells
  std::size_t visible_cells = 0;
};

template <typename Scalar>
struct ReferenceEstimation {
  cycle::EstimationResult<Scalar> result;
  std::vector<RecognitionDetail<Scalar>> details;
  int candidates = 0;        ///< segments fitted
  int hypotheses = 0;        ///< ICP starts
  int stride = 0;            ///< pixel stride of the grid (ReferenceEstimatorSettings::stride)
  double runtime_ms = 0;     ///< wall time of the call [ms]
};

namespace detail {

/// The smallest valid (> 0) value `z(i, j)` of the cells within `r` of (i, j) (Chebyshev, clipped to
/// width × height), +inf when none; (bi, bj) is the first such cell in row order.
template <typename Scalar, typename Depth>
Scalar smallest_depth_around(int width, int height, int i, int j, int r, const Depth& z, int& bi, int& bj) {
  Scalar best = std::numeric_limits<Scalar>::infinity();
  for (int jj = std::max(0, j - r); jj <= std::min(height - 1, j + r); ++jj)
    for (int ii = std::max(0, i - r); ii <= std::min(width - 1, i + r); ++ii) {
      const Scalar d = z(ii, jj);
      if (d > Scalar(0) && d < best) {
        best = d;
        bi = ii;
        bj = jj;
      }
    }
  return best;
}

/// The strided grid of backprojected depth.
template <typename Scalar>
struct DepthGrid {
  int width = 0, height = 0, stride = 1;
  std::vector<Vector3<Scalar>> points;   ///< camera frame [m]; z = 0: no measurement
  std::vector<Vector3<Scalar>> normals;  ///< toward the camera; zero: unknown
  std::vector<Scalar> footprint;         ///< side of the cell on the surface [m]
  std::vector<Scalar> nearest;           ///< smallest valid depth of the 3×3 neighbourhood [m] (+inf: none)
  std::vector<Scalar> depth_sample;      ///< scratch: the automatic stride's depth sample (kept across calls)
  std::size_t index(int i, int j) const { return std::size_t(j) * std::size_t(width) + std::size_t(i); }
  bool valid(std::size_t k) const { return points[k].z() > Scalar(0); }
};

/// Per-call scratch memory of the estimator, kept across calls by estimate() (the grid is about 10 MB
/// at 640 px wide: allocating it every cycle churns the heap of a shift-long run).
template <typename Scalar>
struct EstimatorWorkspace {
  DepthGrid<Scalar> grid;
  std::vector<std::int32_t> label;  // segment id per cell
  std::vector<std::uint8_t> owned;  // cell claimed by a kept hypothesis
  // Segments as one flat list: the cells of segment k are members[begin[k] .. begin[k + 1]). A grid of
  // shiny parts has thousands of speck segments; a list per segment made the heap grow in steps.
  std::vector<std::uint32_t> members, begin, stack;
  std::vector<std::uint8_t> member;  // cell of the candidate being tested (all 0 between tests)
};

template <typename Scalar>
struct Hypothesis {
  int model = -1;
  Isometry3<Scalar> T_camera_object = Isometry3<Scalar>::Identity();
  Scalar confidence = 0;
  std::size_t visible = 0, supported = 0, empty = 0;
  std::vector<std::uint32_t> supported_cells;
};

}  // namespace detail

/// The reference estimator (see the file comment). Models the PoseEstimator concept.
template <typename Scalar_, typename Camera_>
class ReferenceEstimator {
 public:
  using Scalar = Scalar_;
  using Camera = Camera_;
  static_assert(is_camera_model<Camera>::value, "Camera must model the camera concept (camera_model.hpp)");
  using Vec3 = Vector3<Scalar>;
  using Mat3 = Matrix3<Scalar>;

  /// Recognizes the given part models (a bin usually holds one type). Throws std::invalid_argument
  /// naming `models` when empty or a model has no mesh, or the setting out of range.
  explicit ReferenceEstimator(const std::vector<PartModel<Scalar>>& models, const ReferenceEstimatorSettings<Scalar>& settings = {})
      : s_(settings) {
    require(!models.empty(), "models", "must not be empty");
    const auto& s = settings;
    require(s.stride >= 0, "stride", "must be >= 0 (0 = auto)");
    require(std::isfinite(s.min_part_cells) && s.min_part_cells > 0, "min_part_cells", "must be finite and > 0");
    require(s.min_votes >= 0, "min_votes", "must be >= 0");
    require(s.normal_offset >= 1, "normal_offset", "must be >= 1");
    require(std::isfinite(s.edge_jump) && s.edge_jump > 0, "edge_jump", "must be finite and > 0");
    require(std::isfinite(s.concavity_tolerance) && s.concavity_tolerance >= 0, "concavity_tolerance", "must be finite and >= 0");
    require(std::isfinite(s.min_segment_area) && s.min_segment_area >= 0, "min_segment_area", "must be finite and >= 0");
    require(std::isfinite(s.max_segment_area_factor) && s.max_segment_area_factor > 0, "max_segment_area_factor", "must be > 0");
    require(!std::isnan(s.cluster_min_height), "cluster_min_height", "must not be NaN");
    require(s.max_candidates >= 0, "max_candidates", "must be >= 0");
    require(std::isfinite(s.max_occluded_border) && s.max_occluded_border >= 0, "max_occluded_border", "must be >= 0");
    require(std::isfinite(s.planar_rms) && s.planar_rms >= 0, "planar_rms", "must be finite and >= 0");
    require(std::isfinite(s.model_spacing) && s.model_spacing > Scalar(1e-5), "model_spacing", "must be > 1e-5 m");
    require(std::isfinite(s.voxel_size) && s.voxel_size > Scalar(1e-4), "voxel_size", "must be > 1e-4 m");
    require(s.max_coarse_source_points >= 6, "max_coarse_source_points", "must be >= 6");
    require(s.coarse_iterations >= 1 && s.fine_iterations >= 1, "coarse_iterations", "ICP iterations must be >= 1");
    require(std::isfinite(s.coarse_distance) && s.coarse_distance > 0, "coarse_distance", "must be finite and > 0");
    require(std::isfinite(s.fine_distance) && s.fine_distance > 0, "fine_distance", "must be finite and > 0");
    require(s.refined_starts >= 1, "refined_starts", "must be >= 1");
    require(s.edge_band_px >= 0, "edge_band_px", "must be >= 0");
    require(s.edge_band_side >= -1 && s.edge_band_side <= 1, "edge_band_side", "must be -1, 0 or +1");
    require(std::isfinite(s.support_distance) && s.support_distance > 0, "support_distance", "must be finite and > 0");
    require(std::isfinite(s.grazing_cosine) && s.grazing_cosine >= 0 && s.grazing_cosine < 1, "grazing_cosine",
            "must be in [0, 1)");
    require(std::isfinite(s.outline_max_tilt) && s.outline_max_tilt >= 0, "outline_max_tilt", "must be finite and >= 0");
    require(std::isfinite(s.outline_min_strength) && s.outline_min_strength >= 0, "outline_min_strength",
            "must be finite and >= 0");
    require(std::isfinite(s.explain_distance) && s.explain_distance > 0, "explain_distance", "must be finite and > 0");
    require(std::isfinite(s.min_segment_explained) && s.min_segment_explained >= 0 && s.min_segment_explained <= 1,
            "min_segment_explained", "must be in [0, 1]");
    require(std::isfinite(s.min_confidence) && s.min_confidence >= 0 && s.min_confidence <= 100, "min_confidence",
            "must be in [0, 100]");
    require(std::isfinite(s.max_floor_penetration) && s.max_floor_penetration >= 0, "max_floor_penetration",
            "must be finite and >= 0 [m]");
    require(std::isfinite(s.max_overlap) && s.max_overlap >= 0 && s.max_overlap <= 1, "max_overlap", "must be in [0, 1]");
    require(std::isfinite(s.max_approach_angle) && s.max_approach_angle >= 0, "max_approach_angle", "must be >= 0");
    require(std::isfinite(s.collision_margin) && s.collision_margin >= 0, "collision_margin", "must be >= 0");
    require(std::isfinite(s.own_surface_margin) && s.own_surface_margin >= 0, "own_surface_margin", "must be >= 0");
    require(s.min_colliding_samples >= 1, "min_colliding_samples", "must be >= 1");
    require(std::isfinite(s.hole_reach) && s.hole_reach >= 0, "hole_reach", "must be finite and >= 0");
    require(std::isfinite(s.gripper.approach_opening) && s.gripper.approach_opening >= 0, "gripper.approach_opening",
            "must be >= 0");
    require(s.num_threads >= 0, "num_threads", "must be >= 0 (0 = all cores)");
    require(s.symmetry_steps >= 1, "symmetry_steps", "must be >= 1");
    for (const auto& m : models) {
      require(!m.mesh.triangles.empty(), "models", "a model has no mesh");
      models_.push_back(detail::PreparedModel<Scalar>::make(
          m, s.model_spacing, s.voxel_size,
          std::max({s.coarse_distance, s.fine_distance, s.own_surface_margin}) + Scalar(0.001)));
      max_area_ = std::max(max_area_, surface_area(m.mesh));
      max_radius_ = std::max(max_radius_, m.bounding_radius);
      min_radius_ = models_.size() == 1 ? m.bounding_radius : std::min(min_radius_, m.bounding_radius);
    }
  }

  /// Recognizes one part type (convenience).
  explicit ReferenceEstimator(const PartModel<Scalar>& model, const ReferenceEstimatorSettings<Scalar>& settings = {})
      : ReferenceEstimator(std::vector<PartModel<Scalar>>{model}, settings) {}

  const ReferenceEstimatorSettings<Scalar>& settings() const { return s_; }
  std::size_t num_models() const { return models_.size(); }
  const PartModel<Scalar>& model(std::size_t i) const { return models_.at(i).model; }

  /// The PoseEstimator entry point. `RecognizedObject::part_type` is `int(PartType)` of the model.
  cycle::EstimationResult<Scalar> estimate(const cycle::EstimatorInput<Scalar, Camera>& input) {
    return run(input, workspace_).result;
  }

  /// estimate() with per-object diagnostics and the runtime. Throws std::invalid_argument naming
  /// `camera` when input.camera is null and `depth` when its size differs from the camera's. Depth
  /// without valid pixels (all 0 or NaN) gives status no_objects.
  ReferenceEstimation<Scalar> estimate_detailed(const cycle::EstimatorInput<Scalar, Camera>& input) const {
    detail::EstimatorWorkspace<Scalar> ws;
    return run(input, ws);
  }

  /// Confidence [%] of a given pose of model `model_index` on the input (step 4 alone): what the
  /// estimator would report for that pose. Throws like estimate_detailed and for a bad index.
  Scalar score_pose(const cycle::EstimatorInput<Scalar, Camera>& input, std::size_t model_index,
                    const Isometry3<Scalar>& T_camera_object) const {
    require(input.camera != nullptr, "camera", "input.camera must not be null");
    require(model_index < models_.size(), "model_index", "out of range");
    require(input.depth.width() == input.camera->width() && input.depth.height() == input.camera->height(), "depth",
            "image size differs from the camera's");
    detail::DepthGrid<Scalar> grid;
    make_grid(input, *input.camera, grid);
    detail::Hypothesis<Scalar> h;
    h.model = int(model_index);
    h.T_camera_object = T_camera_object;
    score(grid, *input.camera, models_[model_index], h);
    return h.confidence;
  }

 private:
  ReferenceEstimation<Scalar> run(const cycle::EstimatorInput<Scalar, Camera>& input, detail::EstimatorWorkspace<Scalar>& ws) const {
    const auto t0 = std::chrono::steady_clock::now();
    require(input.camera != nullptr, "camera", "input.camera must not be null");
    const Camera& cam = *input.camera;
    require(input.depth.width() == cam.width() && input.depth.height() == cam.height(), "depth",
            "image size differs from the camera's");
    require(input.obstacles.empty() ||
                (input.obstacles.width() == input.depth.width() && input.obstacles.height() == input.depth.height()),
            "obstacles", "image size differs from the depth's");
    ReferenceEstimation<Scalar> out;
    make_grid(input, cam, ws.grid);
    out.stride = ws.grid.stride;
    const detail::DepthGrid<Scalar>& grid = ws.grid;
    std::vector<std::vector<std::uint32_t>> candidates = segment(grid, ws, input);
    out.candidates = int(candidates.size());

    std::vector<detail::Hypothesis<Scalar>> best(candidates.size());
    std::vector<int> starts(candidates.size(), 0);
    const int threads = binpick::detail::resolve_num_threads(s_.num_threads);
    const long n = long(candidates.size());
    (void)threads;  // no parallel region without OpenMP
    BINPICK_OMP(parallel for schedule(dynamic, 1) num_threads(threads) if (threads > 1))
    for (long c = 0; c < n; ++c) best[std::size_t(c)] = fit_candidate(grid, cam, candidates[std::size_t(c)], starts[std::size_t(c)]);
    out.hypotheses = std::accumulate(starts.begin(), starts.end(), 0);

    // 5. Keep the strongest, non-overlapping hypotheses (fixed order: the output does not depend on threads).
    const std::vector<std::size_t> order =
        detail::stable_order(best.size(), [&](std::size_t a, std::size_t b) { return best[a].confidence > best[b].confidence; });
    std::vector<std::uint8_t>& owned = ws.owned;
    owned.assign(grid.points.size(), 0);
    for (const std::size_t k : order) {
      const auto& h = best[k];
      if (h.model < 0 || !(h.confidence >= s_.min_confidence) || h.supported_cells.empty()) continue;
      const auto& pm = models_[std::size_t(h.model)];
      if (below_floor(input, pm.model, h.T_camera_object)) continue;
      std::size_t shared = 0;
      for (const auto cell : h.supported_cells) shared += owned[cell];
      if (Scalar(shared) > s_.max_overlap * Scalar(h.supported_cells.size())) continue;
      for (const auto cell : h.supported_cells) owned[cell] = 1;
      cycle::RecognizedObject<Scalar> obj;
      obj.part_type = int(pm.model.type);
      obj.T_camera_object = h.T_camera_object;
      obj.confidence_percent = h.confidence;
      obj.gripper = pm.model.gripper;
      RecognitionDetail<Scalar> d;
      choose_grasp(input, cam, pm, h.T_camera_object, obj.T_camera_grasp, d);
      obj.grasp_clear = d.grasp_reachable;
      d.visible_cells = h.visible;
      d.supported_share = h.visible ? Scalar(h.supported) / Scalar(h.visible) : Scalar(0);
      d.empty_share = h.visible ? Scalar(h.empty) / Scalar(h.visible) : Scalar(0);
      out.result.objects.push_back(obj);
      out.details.push_back(d);
    }
    out.result.status = out.result.objects.empty() ? cycle::EstimationStatus::no_objects : cycle::EstimationStatus::ok;
    out.runtime_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    return out;
  }

  /// Whether `p` (camera frame) lies more than cluster_min_height above the known bin's floor and a
  /// part's bounding radius inside its walls (false when no bin is known).
  bool above_floor_inside(const cycle::EstimatorInput<Scalar, Camera>& input, const Vec3& p) const {
    if (!input.bin.known()) return false;
    const Vec3 d = input.T_base_camera * p - input.bin.floor_center;
    return d.z() > s_.cluster_min_height && std::abs(d.x()) < input.bin.length / 2 - max_radius_ &&
           std::abs(d.y()) < input.bin.width / 2 - max_radius_;
  }

  /// Whether the part at T_camera_object reaches more than max_floor_penetration below the known
  /// bin's floor (false when the input gives no bin).
  bool below_floor(const cycle::EstimatorInput<Scalar, Camera>& input, const PartModel<Scalar>& model,
                   const Isometry3<Scalar>& T_camera_object) const {
    if (!input.bin.known()) return false;
    const Isometry3<Scalar> T_base_object = input.T_base_camera * T_camera_object;
    const Scalar limit = input.bin.floor_center.z() - s_.max_floor_penetration;
    for (const auto& v : model.mesh.vertices)
      if ((T_base_object * v).z() < limit) return true;
    return false;
  }

  static Scalar surface_area(const TriangleMesh<Scalar>& m) {
    Scalar a = 0;
    for (const auto& t : m.triangles)
      a += Scalar(0.5) * (m.vertices[std::size_t(t.y())] - m.vertices[std::size_t(t.x())])
                             .cross(m.vertices[std::size_t(t.z())] - m.vertices[std::size_t(t.x())])
                             .norm();
    return a;
  }

  /// The grid's stride for this input (settings: stride, min_part_cells); `z` is scratch memory.
  int stride_for(const cycle::EstimatorInput<Scalar, Camera>& input, const Camera& cam, std::vector<Scalar>& z) const {
    if (s_.stride > 0) return s_.stride;
    const int widest = std::max(1, (cam.width() + 639) / 640);
    if (widest == 1) return 1;
    // Median depth of a sparse sample inside the region of interest.
    z.clear();
    const int u0 = std::max(0, s_.roi_u0), v0 = std::max(0, s_.roi_v0);
    const int u1 = std::min(cam.width() - 1, s_.roi_u1), v1 = std::min(cam.height() - 1, s_.roi_v1);
    for (int v = v0; v <= v1; v += 8)
      for (int u = u0; u <= u1; u += 8) {
        const Scalar d = input.depth.depth(u, v);
        if (d > Scalar(0) && std::isfinite(d)) z.push_back(d);
      }
    if (z.empty()) return widest;
    std::nth_element(z.begin(), z.begin() + std::ptrdiff_t(z.size() / 2), z.end());
    const Scalar depth = z[z.size() / 2];
    // One pixel's width at that depth, at the image centre.
    const Scalar cu = Scalar(cam.width() / 2), cv = Scalar(cam.height() / 2);
    const Scalar pixel = (cam.backproject(cu + Scalar(1), cv, depth) - cam.backproject(cu, cv, depth)).norm();
    if (!(pixel > Scalar(0)) || !std::isfinite(pixel)) return widest;
    const Scalar cells = min_radius_ / (pixel * s_.min_part_cells);  // stride at which the radius spans min_part_cells
    return std::clamp(int(std::floor(std::min(cells, Scalar(widest)))), 1, widest);
  }

  // 1. The grid and its normals.
  void make_grid(const cycle::EstimatorInput<Scalar, Camera>& input, const Camera& cam, detail::DepthGrid<Scalar>& g) const {
    g.stride = stride_for(input, cam, g.depth_sample);
    g.width = (cam.width() + g.stride - 1) / g.stride;
    g.height = (cam.height() + g.stride - 1) / g.stride;
    const std::size_t n = std::size_t(g.width) * std::size_t(g.height);
    g.points.assign(n, Vec3::Zero());
    g.normals.assign(n, Vec3::Zero());
    g.footprint.assign(n, Scalar(0));
    for (int j = 0; j < g.height; ++j)
      for (int i = 0; i < g.width; ++i) {
        const int u = i * g.stride, v = j * g.stride;
        if (u < s_.roi_u0 || v < s_.roi_v0 || u > s_.roi_u1 || v > s_.roi_v1) continue;
        if (input.votes && s_.min_votes > 0 &&
            int(input.votes[std::size_t(v) * std::size_t(cam.width()) + std::size_t(u)]) < s_.min_votes)
          continue;
        const Scalar z = input.depth.depth(u, v);
        if (!(z > Scalar(0)) || !std::isfinite(z)) continue;
        const Vec3 p = cam.backproject(Scalar(u), Scalar(v), z);
        const Vec3 q = cam.backproject(Scalar(u + g.stride), Scalar(v), z);
        if (!p.allFinite() || !q.allFinite() || !(p.z() > Scalar(0))) continue;
        g.points[g.index(i, j)] = p;
        g.footprint[g.index(i, j)] = (q - p).norm();
      }
    g.nearest.assign(n, std::numeric_limits<Scalar>::infinity());
    const auto grid_z = [&](int i, int j) { return g.points[g.index(i, j)].z(); };
    for (int j = 0; j < g.height; ++j)
      for (int i = 0; i < g.width; ++i) {
        int bi, bj;
        g.nearest[g.index(i, j)] = detail::smallest_depth_around<Scalar>(g.width, g.height, i, j, 1, grid_z, bi, bj);
      }
    for (int j = 0; j < g.height; ++j)
      for (int i = 0; i < g.width; ++i) {
        const std::size_t k = g.index(i, j);
        if (!g.valid(k)) continue;
        const Vec3& c = g.points[k];
        auto usable = [&](int ii, int jj) {
          if (ii < 0 || jj < 0 || ii >= g.width || jj >= g.height) return false;
          const Vec3& p = g.points[g.index(ii, jj)];
          return p.z() > Scalar(0) && std::abs(p.z() - c.z()) <= s_.edge_jump;
        };
        auto tangent = [&](int di, int dj, Vec3& t) {
          const bool f = usable(i + di, j + dj), b = usable(i - di, j - dj);
          if (f && b) t = g.points[g.index(i + di, j + dj)] - g.points[g.index(i - di, j - dj)];
          else if (f) t = g.points[g.index(i + di, j + dj)] - c;
          else if (b) t = c - g.points[g.index(i - di, j - dj)];
          else return false;
          return true;
        };
        Vec3 tu, tv;
        // Tangents over ±normal_offset cells (noise averages out), ±1 near edges.
        const int o = s_.normal_offset;
        if (!(tangent(o, 0, tu) || tangent(1, 0, tu)) || !(tangent(0, o, tv) || tangent(0, 1, tv))) continue;
        Vec3 nrm = tu.cross(tv);
        const Scalar len = nrm.norm();
        if (!(len > Scalar(1e-12))) continue;
        nrm /= len;
        if (nrm.dot(c) > Scalar(0)) nrm = -nrm;
        g.normals[k] = nrm;
      }
  }

  // 2. Depth-continuous, non-concave segments; split when larger than a part; top-most first.
  std::vector<std::vector<std::uint32_t>> segment(const detail::DepthGrid<Scalar>& g, detail::EstimatorWorkspace<Scalar>& ws,
                                                  const cycle::EstimatorInput<Scalar, Camera>& input) const {
    const std::size_t n = g.points.size();
    std::vector<std::int32_t>& label = ws.label;
    label.assign(n, -1);
    std::vector<std::uint32_t>& members = ws.members;
    std::vector<std::uint32_t>& begin = ws.begin;
    std::vector<std::uint32_t>& stack = ws.stack;
    members.clear();
    members.reserve(n);
    begin.clear();
    auto linked = [&](std::size_t a, std::size_t b) {
      if (!g.valid(b)) return false;
      const Vec3 d = g.points[b] - g.points[a];
      if (!(std::abs(d.z()) <= s_.edge_jump)) return false;
      const Vec3 &na = g.normals[a], &nb = g.normals[b];
      if (na.squaredNorm() == Scalar(0) || nb.squaredNorm() == Scalar(0)) return true;
      const Scalar len = d.norm();
      return !(len > Scalar(0)) || (nb - na).dot(d) / len >= -s_.concavity_tolerance;
    };
    for (std::size_t seed = 0; seed < n; ++seed) {
      if (label[seed] >= 0 || !g.valid(seed)) continue;
      const std::int32_t id = std::int32_t(begin.size());
      begin.push_back(std::uint32_t(members.size()));
      label[seed] = id;
      stack.assign(1, std::uint32_t(seed));
      while (!stack.empty()) {
        const std::uint32_t p = stack.back();
        stack.pop_back();
        members.push_back(p);
        const int i = int(p % std::uint32_t(g.width)), j = int(p / std::uint32_t(g.width));
        const int ni[4] = {i - 1, i + 1, i, i}, nj[4] = {j, j, j - 1, j + 1};
        for (int k = 0; k < 4; ++k) {
          if (ni[k] < 0 || nj[k] < 0 || ni[k] >= g.width || nj[k] >= g.height) continue;
          const std::size_t q = g.index(ni[k], nj[k]);
          if (label[q] >= 0 || !linked(p, q)) continue;
          label[q] = id;
          stack.push_back(std::uint32_t(q));
        }
      }
    }
    begin.push_back(std::uint32_t(members.size()));
    struct Candidate {
      Scalar top;
      std::vector<std::uint32_t> cells;
    };
    std::vector<Candidate> out;
    const Scalar background_area = s_.max_segment_area_factor * max_area_;
    // Whether any rule may split a segment larger than a part (else it is background, unexamined).
    const bool may_split = s_.split_large_segments || (input.bin.known() && std::isfinite(s_.cluster_min_height));
    std::vector<Vec3> pts;  // a large segment's points, reused
    struct Span {  // one segment's cells in `members`
      const std::uint32_t *b, *e;
      const std::uint32_t* begin() const { return b; }
      const std::uint32_t* end() const { return e; }
      std::size_t size() const { return std::size_t(e - b); }
      std::uint32_t operator[](std::size_t i) const { return b[i]; }
    };
    for (std::size_t sid = 0; sid + 1 < begin.size(); ++sid) {
      const std::uint32_t* const first = members.data() + begin[sid];
      const std::uint32_t* const last = members.data() + begin[sid + 1];
      const Span seg{first, last};
      Scalar area = 0;
      for (const auto c : seg) area += g.footprint[c] * g.footprint[c];
      if (area < s_.min_segment_area || area > background_area) continue;
      Vec3 centroid = Vec3::Zero();
      for (const auto c : seg) centroid += g.points[c];
      centroid /= Scalar(seg.size());
      Scalar radius = 0;
      for (const auto c : seg) radius = std::max(radius, (g.points[c] - centroid).norm());
      if (radius <= Scalar(1.2) * max_radius_) {
        Scalar top = std::numeric_limits<Scalar>::max();
        for (const auto c : seg) top = std::min(top, g.points[c].z());
        out.push_back({top, std::vector<std::uint32_t>(first, last)});
        continue;
      }
      // Larger than a part. Flat: floor, wall or rim, not a pile of parts, unless it lies above the
      // known floor (flat parts side by side meet without a crease).
      if (!may_split) continue;
      pts.clear();
      for (const auto c : seg) pts.push_back(g.points[c]);
      Mat3 axes;
      Vec3 mean, var;
      detail::principal_axes(pts, axes, mean, &var);
      const bool flat = std::sqrt(std::max(var.z(), Scalar(0))) < s_.planar_rms;
      if (flat ? !above_floor_inside(input, mean) : !s_.split_large_segments) continue;
      // Touching parts not split by a crease: pieces around the top-most points.
      std::sort(members.begin() + begin[sid], members.begin() + begin[sid + 1],
                [&](std::uint32_t a, std::uint32_t b) { return g.points[a].z() < g.points[b].z(); });
      std::vector<std::uint8_t> taken(seg.size(), 0);
      for (int piece = 0; piece < 8; ++piece) {
        std::size_t s0 = 0;
        while (s0 < seg.size() && taken[s0]) ++s0;
        if (s0 == seg.size()) break;
        const Vec3 top = g.points[seg[s0]];
        Candidate cand{top.z(), {}};
        for (std::size_t k = 0; k < seg.size(); ++k)
          if (!taken[k] && (g.points[seg[k]] - top).norm() <= max_radius_) {
            taken[k] = 1;
            cand.cells.push_back(seg[k]);
          }
        Scalar a = 0;
        for (const auto c : cand.cells) a += g.footprint[c] * g.footprint[c];
        if (a >= s_.min_segment_area) out.push_back(std::move(cand));
      }
    }
    // Local height maxima only: a part on top is surrounded by deeper surface or holes; a strip of a
    // steep wall (or a part deep under others) has nearer surface along much of its border.
    std::vector<std::uint8_t>& member = ws.member;
    member.assign(n, 0);
    out.erase(std::remove_if(out.begin(), out.end(),
                             [&](const Candidate& c) {
                               for (const auto k : c.cells) member[k] = 1;
                               std::size_t nearer = 0, border = 0;
                               for (const auto k : c.cells) {
                                 const int i = int(k % std::uint32_t(g.width)), j = int(k / std::uint32_t(g.width));
                                 const int ni[4] = {i - 1, i + 1, i, i}, nj[4] = {j, j, j - 1, j + 1};
                                 for (int e = 0; e < 4; ++e) {
                                   if (ni[e] < 0 || nj[e] < 0 || ni[e] >= g.width || nj[e] >= g.height) continue;
                                   const std::size_t q = g.index(ni[e], nj[e]);
                                   if (member[q] || !g.valid(q)) continue;
                                   ++border;
                                   nearer += g.points[q].z() < g.points[k].z() - s_.edge_jump;
                                 }
                               }
                               for (const auto k : c.cells) member[k] = 0;
                               return Scalar(nearer) > s_.max_occluded_border * Scalar(border);
                             }),
              out.end());
    std::stable_sort(out.begin(), out.end(), [](const Candidate& a, const Candidate& b) { return a.top < b.top; });
    if (out.size() > std::size_t(s_.max_candidates)) out.resize(std::size_t(s_.max_candidates));
    std::vector<std::vector<std::uint32_t>> cells;
    for (auto& c : out) cells.push_back(std::move(c.cells));
    return cells;
  }

  // 3. Fit every model to one candidate; returns the best scored hypothesis (model = -1 if none).
  detail::Hypothesis<Scalar> fit_candidate(const detail::DepthGrid<Scalar>& g, const Camera& cam,
                                           const std::vector<std::uint32_t>& cells, int& starts) const {
    detail::Hypothesis<Scalar> best;
    Scalar best_rank = 0;
    std::vector<Vec3> seg;
    seg.reserve(cells.size());
    for (const auto c : cells) seg.push_back(g.points[c]);
    Mat3 E;
    Vec3 centroid;
    detail::principal_axes(seg, E, centroid);
    if (E.col(2).dot(centroid) > Scalar(0)) {  // third axis toward the camera
      E.col(2) = -E.col(2);
      E.col(1) = -E.col(1);
    }
    // What the refined fit must explain: the segment, without its edge fringe when edge_band_px is set.
    std::vector<Vec3> core;
    if (s_.edge_band_px > 0)
      for (const auto c : cells)
        if (!beside_drop(g, int(c % std::uint32_t(g.width)), int(c / std::uint32_t(g.width)))) core.push_back(g.points[c]);
    const std::vector<Vec3>& to_explain = core.empty() ? seg : core;
    std::vector<std::uint32_t> sorted_cells(cells);
    std::sort(sorted_cells.begin(), sorted_cells.end());
    PointCloud<Scalar> coarse_src;
    const std::size_t step = std::max<std::size_t>(1, (seg.size() + std::size_t(s_.max_coarse_source_points) - 1) /
                                                         std::size_t(s_.max_coarse_source_points));
    for (std::size_t k = 0; k < seg.size(); k += step) coarse_src.points.push_back(seg[k]);

    for (std::size_t mi = 0; mi < models_.size(); ++mi) {
      const auto& pm = models_[mi];
      std::vector<Scalar> fitted_rank;  // confidence × coverage per start
      std::vector<Isometry3<Scalar>> fitted;  // T_camera_object per start (sorted through indices: Eigen alignment)
      for (const Mat3& R : start_rotations(E, pm)) {
        ++starts;
        // The part's centre lies behind its visible surface: step back from the segment's centroid by
        // the model's extent toward the camera.
        const Vec3 toward = R.transpose() * E.col(2);
        Scalar h = 0;
        for (std::size_t k = 0; k < pm.fine.points.size(); k += 8) h = std::max(h, pm.fine.points[k].dot(toward));
        Isometry3<Scalar> T_co = Isometry3<Scalar>::Identity();
        T_co.linear() = R;
        T_co.translation() = centroid - E.col(2) * (Scalar(0.6) * h) - R * pm.centroid;
        IcpSettings<Scalar> is;
        is.max_iterations = s_.coarse_iterations;
        is.max_correspondence_distance = s_.coarse_distance;
        is.kernel = RobustKernel::huber;
        is.kernel_scale = Scalar(0.0015);
        is.num_threads = 1;
        is.rotation_epsilon = Scalar(1e-3);
        is.translation_epsilon = Scalar(1e-5);
        const auto r = icp(coarse_src, *pm.association, Isometry3<Scalar>(T_co.inverse(Eigen::Isometry)), is);
        if (r.status == IcpStatus::diverged || r.status == IcpStatus::too_few_correspondences) continue;
        detail::Hypothesis<Scalar> h2;
        h2.model = int(mi);
        h2.T_camera_object = registration_detail::orthonormalized(Isometry3<Scalar>(r.T_target_source.inverse(Eigen::Isometry)));
        score(g, cam, pm, h2, true);
        fitted_rank.push_back(h2.confidence * coverage(h2, sorted_cells));
        fitted.push_back(h2.T_camera_object);
      }
      const std::vector<std::size_t> order =
          detail::stable_order(fitted.size(), [&](std::size_t a, std::size_t b) { return fitted_rank[a] > fitted_rank[b]; });
      for (std::size_t k = 0; k < order.size() && k < std::size_t(s_.refined_starts); ++k) {
        detail::Hypothesis<Scalar> h2;
        h2.model = int(mi);
        h2.T_camera_object = turn_to_outline(pm, refine(g, cam, pm, fitted[order[k]]), seg);
        // The part must explain its own segment (a part-sized piece of a bin rim does not).
        if (explained_share(pm, h2.T_camera_object, to_explain) < s_.min_segment_explained) continue;
        score(g, cam, pm, h2, true);
        const Scalar rank = h2.confidence * coverage(h2, sorted_cells);
        if (rank > best_rank || best.model < 0) {
          best_rank = rank;
          best = std::move(h2);
        }
      }
    }
    return best;
  }

  /// Where the gripper check looks for obstacles: input.obstacles when given, else the depth.
  static const DepthImageView<Scalar>& obstacles_of(const cycle::EstimatorInput<Scalar, Camera>& input) {
    return input.obstacles.empty() ? input.depth : input.obstacles;
  }

  /// The input's up direction as a unit vector in the camera frame, zero when unknown.
  static Vec3 unit_up(const cycle::EstimatorInput<Scalar, Camera>& input) {
    const Scalar norm = input.up_camera.norm();
    return input.up_camera.allFinite() && norm > Scalar(0.5) ? Vec3(input.up_camera / norm) : Vec3::Zero();
  }

  /// An n-fold prism seen along its axis (a hex nut from above) shows a face whose depth fixes
  /// everything but the turn about the axis, and ICP leaves an unobservable direction alone: the turn
  /// comes from where the segment's outline has its corners (the n-th angular harmonic of its points
  /// about the fitted axis, as the model's). Kept when the axis is within outline_max_tilt of the line
  /// of sight and the corners show at least outline_min_strength × as clearly as on the model; else
  /// the fit as it is.
  Isometry3<Scalar> turn_to_outline(const detail::PreparedModel<Scalar>& pm, const Isometry3<Scalar>& T_camera_object,
                                    const std::vector<Vec3>& seg) const {
    const int n = pm.symmetry.z_fold;
    if (pm.symmetry.continuous_z || n < 3 || !(s_.outline_min_strength > 0) || std::abs(pm.outline) == 0)
      return T_camera_object;
    const Vec3 sight = T_camera_object.translation().normalized();
    if (!(std::abs(T_camera_object.linear().col(2).dot(sight)) >= std::cos(s_.outline_max_tilt))) return T_camera_object;
    const Isometry3<Scalar> T_oc = T_camera_object.inverse(Eigen::Isometry);
    std::vector<Vec3> local;
    local.reserve(seg.size());
    for (const Vec3& p : seg) local.push_back(T_oc * p);
    const std::complex<double> seen =
        detail::outline_harmonic(local, n, double(pm.model.bounding_radius) + double(s_.support_distance));
    if (!(std::abs(seen) >= double(s_.outline_min_strength) * std::abs(pm.outline))) return T_camera_object;
    const double turn = std::arg(seen / pm.outline) / double(n);
    Isometry3<Scalar> T = T_camera_object;
    T.linear() = T.linear() * Eigen::AngleAxis<Scalar>(Scalar(turn), Vec3::UnitZ()).toRotationMatrix();
    return T;
  }

  /// Share of the segment's cells (`sorted_cells`) that the scored hypothesis supports. It ranks a
  /// candidate's fits together with the confidence: a part turned so that a narrower face lies inside
  /// the measured one is as well supported (the confidence looks only where the model is), but leaves
  /// a strip of its segment uncovered.
  static Scalar coverage(const detail::Hypothesis<Scalar>& h, const std::vector<std::uint32_t>& sorted_cells) {
    if (sorted_cells.empty()) return 0;
    std::size_t n = 0;
    for (const auto c : h.supported_cells) n += std::binary_search(sorted_cells.begin(), sorted_cells.end(), c);
    return Scalar(n) / Scalar(sorted_cells.size());
  }

  /// Share of `points` (camera frame) within explain_distance of the model at T_camera_object.
  Scalar explained_share(const detail::PreparedModel<Scalar>& pm, const Isometry3<Scalar>& T_camera_object,
                         const std::vector<Vec3>& points) const {
    if (points.empty()) return 0;
    const Isometry3<Scalar> T_oc = T_camera_object.inverse(Eigen::Isometry);
    std::vector<Vec3> in_model;
    in_model.reserve(points.size());
    for (const Vec3& p : points) in_model.push_back(T_oc * p);
    std::vector<std::ptrdiff_t> partners;
    pm.association->associate(in_model, s_.explain_distance, 1, partners);
    const auto n = std::count_if(partners.begin(), partners.end(), [](std::ptrdiff_t q) { return q >= 0; });
    return Scalar(n) / Scalar(points.size());
  }

  /// Starts: the model's principal axes onto the segment's in every signed permutation (proper
  /// rotations), dropping those equal up to the part's symmetry.
  std::vector<Mat3> start_rotations(const Mat3& E, const detail::PreparedModel<Scalar>& pm) const {
    std::vector<Mat3> out;
    const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
    for (const auto& p : perms)
      for (int signs = 0; signs < 8; ++signs) {
        Mat3 S = Mat3::Zero();
        for (int r = 0; r < 3; ++r) S(p[r], r) = (signs >> r) & 1 ? Scalar(-1) : Scalar(1);
        if (S.determinant() < Scalar(0)) continue;
        const Mat3 R = E * S * pm.axes.transpose();
        bool duplicate = false;
        for (const Mat3& o : out)
          if (detail::symmetric_rotation_distance(o, R, pm.symmetry) < Scalar(0.2)) {
            duplicate = true;
            break;
          }
        if (!duplicate) out.push_back(R);
      }
    return out;
  }

  /// Point-to-plane ICP of all grid points near the part onto the fine model samples, two rounds.
  Isometry3<Scalar> refine(const detail::DepthGrid<Scalar>& g, const Camera& cam, const detail::PreparedModel<Scalar>& pm,
                           const Isometry3<Scalar>& T_camera_object) const {
    Isometry3<Scalar> T = T_camera_object;
    PointCloud<Scalar> crop;
    for (int round = 0; round < 2; ++round) {
      const Scalar reach = pm.model.bounding_radius + Scalar(0.002);
      crop.points.clear();
      int i0, i1, j0, j1;
      if (!grid_window(g, cam, T.translation(), reach, i0, i1, j0, j1)) break;
      for (int j = j0; j <= j1; ++j)
        for (int i = i0; i <= i1; ++i) {
          const std::size_t k = g.index(i, j);
          if (g.valid(k) && (g.points[k] - T.translation()).squaredNorm() <= reach * reach && !beside_drop(g, i, j))
            crop.points.push_back(g.points[k]);
        }
      IcpSettings<Scalar> is;
      is.max_iterations = s_.fine_iterations;
      is.max_correspondence_distance = round == 0 ? s_.fine_distance : s_.fine_distance / 2;
      is.kernel = RobustKernel::tukey;
      is.kernel_scale = is.max_correspondence_distance;
      is.num_threads = 1;
      const auto r = icp(crop, *pm.association, Isometry3<Scalar>(T.inverse(Eigen::Isometry)), is);
      if (r.status == IcpStatus::diverged || r.status == IcpStatus::too_few_correspondences) break;
      T = registration_detail::orthonormalized(Isometry3<Scalar>(r.T_target_source.inverse(Eigen::Isometry)));
    }
    return T;
  }

  /// True when a valid cell of row j within edge_band_px (in cells) of (i, j), on the edge_band_side,
  /// lies more than edge_jump farther: (i, j) may be the foreground value a stereo matcher spread over
  /// the background. Holes do not count: the occlusion side of an edge is a hole.
  bool beside_drop(const detail::DepthGrid<Scalar>& g, int i, int j) const {
    const int band = (s_.edge_band_px + g.stride - 1) / g.stride;
    if (band <= 0) return false;
    const Scalar limit = g.points[g.index(i, j)].z() + s_.edge_jump;
    const int lo = s_.edge_band_side > 0 ? i + 1 : std::max(0, i - band);
    const int hi = s_.edge_band_side < 0 ? i - 1 : std::min(g.width - 1, i + band);
    for (int ii = lo; ii <= hi; ++ii)
      if (g.points[g.index(ii, j)].z() > limit) return true;
    return false;
  }

  /// The width [m] of pixel (u, v) on a surface at `depth` facing the camera.
  static Scalar pixel_width(const Camera& cam, Scalar u, Scalar v, Scalar depth) {
    return (cam.backproject(u + Scalar(1), v, depth) - cam.backproject(u, v, depth)).norm();
  }

  /// Grid cells [i0, i1] × [j0, j1] covering the sphere (centre, radius) in the camera; false if none.
  static bool grid_window(const detail::DepthGrid<Scalar>& g, const Camera& cam, const Vec3& centre, Scalar radius, int& i0,
                          int& i1, int& j0, int& j1) {
    if (!(centre.z() > radius)) return false;
    // Pixel radius from a point one radius off the centre, across the line of sight.
    const Scalar px_per_m = Scalar(1) / std::max(pixel_width(cam, Scalar(0), Scalar(0), centre.z() - radius), Scalar(1e-9));
    const Vec3 ray = centre / centre.z();
    const Vec3 near = ray * (centre.z() - radius);
    const auto pc = cam.project(near);
    if (!pc) return full_window(g, i0, i1, j0, j1);  // centre off the image: scan everything (rare)
    const Scalar u = pc->x(), v = pc->y();
    const Scalar r = radius * px_per_m * Scalar(1.2) + Scalar(2);
    i0 = std::max(0, int(std::floor((u - r) / Scalar(g.stride))));
    i1 = std::min(g.width - 1, int(std::ceil((u + r) / Scalar(g.stride))));
    j0 = std::max(0, int(std::floor((v - r) / Scalar(g.stride))));
    j1 = std::min(g.height - 1, int(std::ceil((v + r) / Scalar(g.stride))));
    return i0 <= i1 && j0 <= j1;
  }
  static bool full_window(const detail::DepthGrid<Scalar>& g, int& i0, int& i1, int& j0, int& j1) {
    i0 = 0;
    j0 = 0;
    i1 = g.width - 1;
    j1 = g.height - 1;
    return g.width > 0 && g.height > 0;
  }

  // 4. The z-buffer score.
  void score(const detail::DepthGrid<Scalar>& g, const Camera& cam, const detail::PreparedModel<Scalar>& pm,
             detail::Hypothesis<Scalar>& h, bool keep_cells = false) const {
    h.visible = h.supported = h.empty = 0;
    h.confidence = 0;
    h.supported_cells.clear();
    const Mat3 R = h.T_camera_object.linear();
    const Vec3 t = h.T_camera_object.translation();
    struct Splat {
      std::uint32_t cell;
      Scalar z;
    };
    std::vector<Splat> splats;
    splats.reserve(pm.fine.points.size() / 2);
    for (std::size_t k = 0; k < pm.fine.points.size(); ++k) {
      const Vec3 p = R * pm.fine.points[k] + t;
      const Vec3 nrm = R * pm.fine.normals[k];
      const Scalar pn = p.norm();
      if (!(pn > Scalar(0)) || !(-nrm.dot(p) > s_.grazing_cosine * pn)) continue;  // back-facing or grazing
      const auto px = cam.project(p);
      if (!px) continue;
      const int i = int(std::lround(px->x() / Scalar(g.stride))), j = int(std::lround(px->y() / Scalar(g.stride)));
      if (i < 0 || j < 0 || i >= g.width || j >= g.height) continue;
      splats.push_back({std::uint32_t(g.index(i, j)), p.z()});
    }
    if (splats.empty()) return;
    std::sort(splats.begin(), splats.end(), [](const Splat& a, const Splat& b) { return a.cell != b.cell ? a.cell < b.cell : a.z < b.z; });
    for (std::size_t k = 0; k < splats.size(); ++k) {
      if (k > 0 && splats[k].cell == splats[k - 1].cell) continue;  // z-buffer: the nearest sample of the cell
      ++h.visible;
      const std::uint32_t c = splats[k].cell;
      if (!g.valid(c)) continue;  // no measurement: neither support nor contradiction
      const Scalar dz = g.points[c].z() - splats[k].z;
      if (std::abs(dz) <= s_.support_distance) {
        ++h.supported;
        if (keep_cells) h.supported_cells.push_back(c);
      } else if (g.nearest[c] - splats[k].z > s_.support_distance) {
        ++h.empty;  // the sensor sees through where the model would be (all neighbours too: not a silhouette)
      }
    }
    const Scalar conf = Scalar(100) * (Scalar(h.supported) - Scalar(h.empty)) / Scalar(h.visible);
    h.confidence = std::clamp(conf, Scalar(0), Scalar(100));
  }

  // 6. The grasp: the registered grasps under every symmetry of the part (a symmetric part offers
  // each of them all around: a screw can be taken across its shank from any side), within
  // max_approach_angle of the line of sight (the side the sensor sees), nearest to straight down
  // (input.up_camera; the line of sight when unknown), gripper in measured free space.
  void choose_grasp(const cycle::EstimatorInput<Scalar, Camera>& input, const Camera& cam,
                    const detail::PreparedModel<Scalar>& pm, const Isometry3<Scalar>& T_camera_object,
                    Isometry3<Scalar>& T_camera_grasp, RecognitionDetail<Scalar>& d) const {
    const auto& grasps = pm.model.grasps;
    const std::vector<Mat3> syms = detail::symmetry_rotations<Scalar>(pm.symmetry, s_.symmetry_steps);
    const Vec3 down = -unit_up(input);
    const bool have_up = !down.isZero();
    struct Option {
      Isometry3<Scalar> T_camera_grasp;
      Scalar key;       // angle to the preferred approach [rad]
      bool in_sight;    // within max_approach_angle of the line of sight
      std::size_t grasp;
    };
    std::vector<Option> options;
    options.reserve(syms.size() * grasps.size());
    for (const Mat3& sym : syms)
      for (std::size_t k = 0; k < grasps.size(); ++k) {
        Isometry3<Scalar> T_sym = Isometry3<Scalar>::Identity();
        T_sym.linear() = sym;  // symmetries fix the part origin (estimator_symmetry.hpp)
        const Isometry3<Scalar> T = T_camera_object * T_sym * grasps[k].T_part_grasp;
        const Vec3 sight = T.translation().normalized();
        const Vec3 a = T.linear().col(2);
        const Scalar sight_angle = std::acos(std::clamp(a.dot(sight), Scalar(-1), Scalar(1)));
        const Scalar key = have_up ? std::acos(std::clamp(a.dot(down), Scalar(-1), Scalar(1))) : sight_angle;
        options.push_back({T, key, sight_angle <= s_.max_approach_angle, k});
      }
    if (options.empty()) {
      d.grasp_reachable = false;
      d.grasp_index = -1;
      T_camera_grasp = T_camera_object;
      return;
    }
    // Through indices: an Option holds an Eigen pose (detail::stable_order).
    const std::vector<std::size_t> order = detail::stable_order(options.size(), [&](std::size_t a, std::size_t b) {
      const Option &x = options[a], &y = options[b];
      return x.in_sight != y.in_sight ? x.in_sight : x.key < y.key;
    });
    const Option* chosen = nullptr;
    const Isometry3<Scalar> T_object_camera = T_camera_object.inverse(Eigen::Isometry);
    std::vector<std::vector<Vec3>> gripper(grasps.size());  // its samples per grasp, made when first needed
    for (const std::size_t i : order) {
      const Option& o = options[i];
      if (!o.in_sight) break;
      std::vector<Vec3>& samples = gripper[o.grasp];
      if (samples.empty())
        samples = detail::gripper_samples(s_.gripper, pm.model.gripper,
                                          std::max(grasps[o.grasp].opening, s_.gripper.approach_opening), Scalar(0.002));
      if (gripper_collides(input, cam, pm, T_object_camera, o.T_camera_grasp, samples)) continue;
      chosen = &o;
      break;
    }
    d.grasp_reachable = chosen != nullptr;
    if (!chosen) chosen = &options[order.front()];  // flagged: the best aligned one
    d.grasp_index = int(chosen->grasp);
    T_camera_grasp = chosen->T_camera_grasp;
  }

  /// Whether the gripper (its `samples`, grasp frame) at T_camera_grasp stands in the known bin
  /// (input.bin, at any sample) or behind measured surfaces
  /// that are not the part's own (collision_margin, own_surface_margin) at min_colliding_samples or
  /// more of its samples. A sample over a hole is checked against the nearest surface within
  /// hole_reach of it.
  bool gripper_collides(const cycle::EstimatorInput<Scalar, Camera>& input, const Camera& cam,
                        const detail::PreparedModel<Scalar>& pm, const Isometry3<Scalar>& T_object_camera,
                        const Isometry3<Scalar>& T_camera_grasp, const std::vector<Vec3>& samples) const {
    const DepthImageView<Scalar>& scene = obstacles_of(input);
    // hole_reach in pixels at 1 m depth, at the grasp (divided by a sample's depth below).
    Scalar reach_px_at_1m = 0;
    if (s_.hole_reach > Scalar(0)) {
      const auto g = cam.project(T_camera_grasp.translation());
      reach_px_at_1m = s_.hole_reach / pixel_width(cam, g ? g->x() : Scalar(cam.width()) / 2,
                                                   g ? g->y() : Scalar(cam.height()) / 2, Scalar(1));
    }
    // The known bin first: one sample in a wall or the floor is a collision (no measurement noise).
    if (input.bin.known()) {
      const Isometry3<Scalar> T_base_grasp = input.T_base_camera * T_camera_grasp;
      for (const Vec3& q : samples)
        if (input.bin.blocks(T_base_grasp * q)) return true;
    }
    int colliding = 0;
    for (const Vec3& q : samples) {
      const Vec3 p = T_camera_grasp * q;
      const auto px = cam.project(p);
      if (!px) continue;
      int u = int(std::lround(px->x())), v = int(std::lround(px->y()));
      Scalar z = scene.depth(u, v);
      if (!(z > Scalar(0))) nearest_surface_around(scene, reach_px_at_1m / p.z(), u, v, z);
      if (!(z > Scalar(0) && z < p.z() - s_.collision_margin)) continue;  // not behind a measured surface
      const auto m = cam.backproject(Scalar(u), Scalar(v), z);
      if (pm.association->partner(T_object_camera * m.template cast<Scalar>(), s_.own_surface_margin) >= 0) continue;
      if (++colliding >= s_.min_colliding_samples) return true;
    }
    return false;
  }

  /// The smallest measured depth within `radius` pixels (Chebyshev, rounded) of (u, v), and its pixel
  /// in (u, v); nothing changes when there is none or the radius rounds to 0.
  static void nearest_surface_around(const DepthImageView<Scalar>& depth, Scalar radius, int& u, int& v, Scalar& z) {
    if (!(radius >= Scalar(0.5))) return;  // rounds to 0 (or NaN)
    const int r = int(std::lround(std::min(radius, Scalar(64))));  // bounded: a sample at a tiny depth
    int bu = u, bv = v;
    const Scalar best = detail::smallest_depth_around<Scalar>(
        depth.width(), depth.height(), u, v, r, [&](int uu, int vv) { return depth.depth(uu, vv); }, bu, bv);
    if (best < std::numeric_limits<Scalar>::infinity()) {
      z = best;
      u = bu;
      v = bv;
    }
  }

  ReferenceEstimatorSettings<Scalar> s_;
  std::vector<detail::PreparedModel<Scalar>> models_;
  detail::EstimatorWorkspace<Scalar> workspace_;  // estimate()'s scratch memory
  Scalar max_area_ = 0, max_radius_ = 0, min_radius_ = 0;
};

}  // namespace binpick::sim
