#pragma once
/// \file stereo_sensor.hpp
/// A one-shot active stereo camera looking at a scene of shiny metal parts (paper §IV.A: view area
/// about 75 × 50 cm at the 30 cm best working distance). A ray caster renders the true surface; a
/// metal error model driven by geometry (SENSOR_MODEL.md, "a per-pixel model") turns it into the
/// sparse, noisy, view-dependent depth that the paper's multi-view voting repairs (§III.A, §III.B):
///
///  1. hit X on a material {k_d, F0, two GGX lobes} with an interpolated shading normal;
///  2. visibility: X hidden from the right camera or shadowed from the projector → hole;
///  3. radiance in the left and right camera: diffuse + GGX lobes lit by the projector (falling with
///     distance²), normalized to a white matte target at the working distance, darker off the optical
///     axis (vignetting, cos^k), times a per-camera speckle factor on a coarse grid. Saturated (bloom
///     grown by a few px), too dark, or left and right too different → hole. Highlights therefore sit
///     where the projector's mirror reflection enters a camera — they move with the view, so close
///     views lose different pixels;
///  4. ghosts: the left ray reflected at X reaches Y; where Y's light seen in the mirror outshines
///     X's own return, a locally flat mirror reports the unfolded path length |LX| + |XY| along the
///     ray (a fixed virtual point, behind the surface) and a curved one (over the matching window)
///     gives a hole — never random;
///  5. noise in disparity growing as the return darkens and the incidence steepens (Nguyen et al.),
///     quantized to 1/32 px, converted through f·B/d — so σ_z grows with z²;
///  6. edges: on the far side of a depth jump, within half a matching window, the foreground value
///     (fattening), a mix (flying pixel) or a hole;
///  7. speckle filter: connected regions smaller than ~100 px are dropped.
/// Randomness (speckle, threshold jitter, noise, edge draws) is keyed by (seed, frame, pixel, purpose):
/// a frame is reproducible and independent of the thread count; highlights and ghosts come from
/// geometry only. Pixel-size settings are given for a 1280 px wide image and scale with the width.
///
/// The rig in the (left) camera frame — x right, y down, z forward: left camera at the origin,
/// right camera at (baseline, 0, 0), projector half-way between. Depth is reported in the left frame.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "binpick/core/camera_model.hpp"
#include "binpick/core/depth_image.hpp"
#include "binpick/core/errors.hpp"
#include "binpick/core/parallel.hpp"
#include "binpick/core/pose.hpp"
#include "binpick/sim/detail/random.hpp"
#include "binpick/sim/parts.hpp"
#include "binpick/sim/ray_caster.hpp"
#include "binpick/sim/scene.hpp"

namespace binpick::sim {

/// Settings of the metal error model (defaults to tune, not truths; SENSOR_MODEL.md).
template <typename Scalar>
struct MetalErrorSettings {
  bool enabled = true;                        ///< false: the exact depth of the first surface hit
  Scalar noise_scale = Scalar(1);             ///< multiplies the disparity noise (0 = none)
  Scalar subpixel_sigma = Scalar(0.07);       ///< disparity noise of a bright, frontal return [px]
  Scalar disparity_quantum = Scalar(1.0 / 32);  ///< sub-pixel resolution of the matcher [px]
  Scalar incidence_noise_gain = Scalar(0.5);  ///< weight of θ²/(π/2 − θ)² in the noise
  Scalar saturation = Scalar(4);              ///< brighter than this × white reference → saturated
  Scalar dark = Scalar(0.08);                 ///< darker than this × white reference → no texture
  Scalar left_right_ratio = Scalar(3);        ///< left/right brightness ratio above this → no match
  /// Brightness × cos^k of the ray's angle to each camera's optical axis: the lens's relative
  /// illumination and the projector's beam together. The field is 75 × 50 cm at 30 cm (51° and 40°
  /// half-angles), so with k > 0 its edges get less light than its centre: the paper's "view center
  /// for better sensing results" (§IV.D). 4 is an uncorrected lens's cos⁴ law; 2 a lens designed for
  /// a wide field (≈ 40 % at the long edges, 31 % in the corners). Off (0) by default: the fusion and
  /// estimator settings were tuned without it. With k = 2, the metal registration test (4 views over a
  /// pile from 30 cm, FusionSettings::metal_depth) registers to 3.3 mm instead of under 1 mm; in the
  /// simulated cell (binpick_sim --vignetting 2) the pipeline's registration on its sensing arcs leaves
  /// a view's points 0.84 mm rms from where they truly were at 640 × 512 (0.37 mm with k = 0), 0.42 mm
  /// at 1280 × 1024, and the picking test loses parts (the README's note on the simulated sensor).
  Scalar vignetting_power = Scalar(0);
  Scalar threshold_jitter = Scalar(0.1);      ///< relative per-pixel jitter of the three thresholds
  int saturation_growth_px = 2;               ///< bloom around saturated pixels [px @ 1280 wide]
  Scalar speckle_sigma = Scalar(0.3);         ///< log-normal σ of the speckle factor both cameras share
  Scalar speckle_lr_sigma = Scalar(0.1);      ///< log-normal σ of the part that differs between the cameras
  int speckle_cell_px = 8;                    ///< speckle grid cell [px @ 1280 wide]
  bool ghosts = true;                         ///< one-bounce inter-reflection ghosts
  Scalar ghost_max_path = Scalar(0.15);       ///< longest mirror-to-surface path considered [m]
  Scalar ghost_min_fresnel = Scalar(0.2);     ///< only metals (F0 above this) act as mirrors
  int match_window_px = 9;                    ///< matching window [px @ 1280 wide]
  Scalar curved_mirror_angle = Scalar(0.15);  ///< normal change over the window making a mirror "curved" [rad]
  Scalar edge_jump = Scalar(0.004);           ///< depth jump treated as an edge [m]
  Scalar edge_foreground_probability = Scalar(0.5);  ///< far-side pixel takes the foreground value
  Scalar edge_mix_probability = Scalar(0.2);         ///< far-side pixel takes a foreground/background mix
  int speckle_filter_min_region_px = 40;      ///< smaller connected regions are dropped [px @ 1280 wide]
  Scalar speckle_filter_max_diff = Scalar(1);  ///< disparity step that splits regions [px] (≈ 3.5 mm at 0.3 m)
  Material<Scalar> bin_material{Scalar(0.35), Scalar(0.04), Scalar(0.4), Scalar(0.4), Scalar(0.5)};    ///< painted bin
  Material<Scalar> table_material{Scalar(0.4), Scalar(0.04), Scalar(0.5), Scalar(0.5), Scalar(0.5)};  ///< matte table
};

template <typename Scalar>
struct StereoSensorSettings {
  int width = 1280;                           ///< [px]; 640 × 512 is the other mode of the paper's class of sensor
  int height = 1024;                          ///< [px]
  Scalar view_width = Scalar(0.75);           ///< field width at the working distance [m]
  Scalar view_height = Scalar(0.50);          ///< field height at the working distance [m]
  Scalar working_distance = Scalar(0.30);     ///< best working distance [m]
  Scalar baseline = Scalar(0.05);             ///< left–right camera distance [m]
  Scalar min_range = Scalar(0.15);            ///< nearer depths are not measured [m]
  Scalar max_range = Scalar(1.0);             ///< farther depths are not measured [m]
  Scalar accuracy = Scalar(0.0005);           ///< reported depth accuracy at the working distance [m]
  MetalErrorSettings<Scalar> errors;
  std::uint64_t seed = 1;                     ///< with the frame index, keys every random draw
  int num_threads = 1;                        ///< rows in parallel (0 = all cores); output is identical
  bool diagnostics = false;                   ///< also fill true depth, pixel status and part index
};

/// Why a pixel holds (or lacks) a measurement.
enum class PixelStatus : std::uint8_t {
  valid = 0,
  no_surface,          ///< nothing within the measuring range
  occluded_right,      ///< the right camera does not see the point
  outside_right,       ///< the point is outside the right camera's image
  shadowed,            ///< the projector does not light the point
  saturated,           ///< a highlight: the projector's mirror reflection enters a camera
  saturation_bloom,    ///< next to a highlight
  too_dark,            ///< no texture: too little light returns
  left_right_mismatch, ///< the two cameras see too different brightness
  ghost,               ///< measured, at the depth of an inter-reflection (wrong, behind the surface)
  curved_reflection,   ///< an inter-reflection off a curved mirror: no consistent match
  edge_foreground,     ///< measured, the foreground's depth fattened over an edge
  edge_mix,            ///< measured, a foreground/background mix (flying pixel)
  edge_hole,           ///< near an edge, rejected
  speckle_filtered,    ///< in a small disconnected region
};

template <typename Scalar>
struct StereoFrame {
  DepthImage<Scalar> depth;                                       ///< [m], 0 = no measurement
  Isometry3<Scalar> T_base_camera = Isometry3<Scalar>::Identity();  ///< pose of the left camera
  std::uint64_t frame_index = 0;
  std::size_t surface_pixels = 0;       ///< pixels with a surface in range
  std::size_t valid_pixels = 0;         ///< pixels with a measurement
  std::size_t part_pixels = 0;          ///< pixels whose surface is a part
  std::size_t valid_part_pixels = 0;    ///< … with a measurement
  std::size_t ghost_pixels = 0;         ///< measurements of a ghost
  std::size_t outlier_pixels = 0;       ///< measurements more than 2 mm off the true surface
  // Diagnostics (filled only with settings.diagnostics):
  DepthImage<Scalar> true_depth;        ///< depth of the first surface hit [m], 0 = none
  std::vector<PixelStatus> status;      ///< per pixel, row-major
  std::vector<std::int16_t> part_index; ///< index into scene.parts() per pixel, -1 = bin/table/none
};

/// The scene as one triangle soup with its acceleration structure and per-triangle attributes.
template <typename Scalar>
struct SceneGeometry {
  TriangleMesh<Scalar> mesh;              ///< base frame
  std::vector<int> material;              ///< per triangle: index into `materials`
  std::vector<int> part;                  ///< per triangle: index into scene.parts(), -1 = bin/table
  std::vector<Scalar> curvature;          ///< per triangle: spread of corner normals per length [rad/m]
  std::vector<Material<Scalar>> materials;
  RayCaster<Scalar> part_caster;           ///< over the parts' triangles (the first part_triangles)
  RayCaster<Scalar> bin_caster;            ///< over the bin's triangles (indices offset by part_triangles)
  std::size_t part_triangles = 0;
  Scalar table_z = 0;                      ///< the table under the bin: the plane z = table_z, matte,
                                           ///< intersected analytically (a huge triangle would spoil the BVH)

  static SceneGeometry build(const Scene<Scalar>& scene, const Material<Scalar>& bin, const Material<Scalar>& table) {
    SceneGeometry g;
    for (int k = 0; k < kNumPartTypes; ++k) g.materials.push_back(scene.model(PartType(k)).material);
    g.materials.push_back(bin);
    g.materials.push_back(table);
    auto add = [&](const TriangleMesh<Scalar>& m, const Isometry3<Scalar>& T, int material, int part) {
      g.mesh.append(m, T);
      g.material.insert(g.material.end(), m.size(), material);
      g.part.insert(g.part.end(), m.size(), part);
    };
    for (std::size_t i = 0; i < scene.parts().size(); ++i) {
      const auto& p = scene.parts()[i];
      add(scene.model(p.type).mesh, p.T_base_part, int(p.type), int(i));
    }
    g.part_triangles = g.mesh.size();
    const TriangleMesh<Scalar> bin_mesh = scene.bin_mesh();
    add(bin_mesh, Isometry3<Scalar>::Identity(), kNumPartTypes, -1);
    g.table_z = -scene.bin().wall_thickness;
    g.curvature.resize(g.mesh.size());
    for (std::size_t t = 0; t < g.mesh.size(); ++t) {
      const auto& tri = g.mesh.triangles[t];
      const Vector3<Scalar> a = g.mesh.vertices[std::size_t(tri.x())], b = g.mesh.vertices[std::size_t(tri.y())],
                            c = g.mesh.vertices[std::size_t(tri.z())];
      const Scalar edge = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
      Scalar spread = 0;
      for (int i = 0; i < 3; ++i)
        for (int j = i + 1; j < 3; ++j) {
          const Scalar cosang = std::clamp(g.mesh.corner_normals[3 * t + std::size_t(i)].dot(g.mesh.corner_normals[3 * t + std::size_t(j)]),
                                           Scalar(-1), Scalar(1));
          spread = std::max(spread, std::acos(cosang));
        }
      g.curvature[t] = edge > Scalar(0) ? spread / edge : Scalar(0);
    }
    // Two hierarchies: the bin's few huge triangles would otherwise inflate every box above the
    // small parts' triangles, and most rays then miss the pile's box at the first test.
    TriangleMesh<Scalar> parts_only = g.mesh;
    parts_only.triangles.resize(g.part_triangles);
    g.part_caster.build(parts_only);
    g.bin_caster.build(bin_mesh);
    return g;
  }

  /// Closest hit over parts and bin (not the table).
  bool intersect(const Vector3<Scalar>& o, const Vector3<Scalar>& d, Scalar t_min, Scalar t_max, RayHit<Scalar>& hit) const {
    RayHit<Scalar> b;
    const bool hb = bin_caster.intersect(o, d, t_min, t_max, b);
    if (hb) {
      b.triangle += int(part_triangles);
      t_max = b.t;
    }
    if (part_caster.intersect(o, d, t_min, t_max, hit)) return true;
    if (hb) hit = b;
    return hb;
  }
  bool occluded(const Vector3<Scalar>& o, const Vector3<Scalar>& d, Scalar t_min, Scalar t_max) const {
    return part_caster.occluded(o, d, t_min, t_max) || bin_caster.occluded(o, d, t_min, t_max);
  }
};

namespace detail {

/// π × BRDF × cos(incidence): the brightness returned toward v relative to a white matte target under
/// the same irradiance (SENSOR_MODEL step 3). Cook–Torrance with Schlick Fresnel and Smith–GGX.
template <typename Scalar>
Scalar relative_reflectance(const Vector3<Scalar>& n, const Vector3<Scalar>& l, const Vector3<Scalar>& v,
                            const Material<Scalar>& m) {
  const Scalar nl = n.dot(l), nv = n.dot(v);
  if (!(nl > Scalar(0)) || !(nv > Scalar(0))) return Scalar(0);
  const Vector3<Scalar> h = (l + v).normalized();
  const Scalar nh = std::max(n.dot(h), Scalar(0)), vh = std::max(v.dot(h), Scalar(0));
  const Scalar c = Scalar(1) - vh, c2 = c * c;
  const Scalar f = m.fresnel0 + (Scalar(1) - m.fresnel0) * c2 * c2 * c;
  auto lobe = [&](Scalar alpha) {
    const Scalar a2 = alpha * alpha;
    const Scalar den = nh * nh * (a2 - Scalar(1)) + Scalar(1);
    const Scalar D = a2 / (Scalar(M_PI) * den * den);
    auto g1 = [&](Scalar x) { return Scalar(2) * x / (x + std::sqrt(a2 + (Scalar(1) - a2) * x * x)); };
    return D * g1(nl) * g1(nv);
  };
  const Scalar spec = f * ((Scalar(1) - m.broad_weight) * lobe(m.alpha_sharp) + m.broad_weight * lobe(m.alpha_broad)) /
                      (Scalar(4) * nl * nv);
  return m.diffuse * nl + Scalar(M_PI) * spec * nl;
}

enum RandomPurpose : std::uint64_t { kNoise = 1, kJitter = 2, kEdge = 3, kSpeckle = 4 };

/// Uniform in [-√3, √3) (unit variance) from 21 bits of a hash: cheap threshold jitter.
inline double unit_variance_uniform(std::uint64_t h, int which) {
  return (double((h >> (21 * which)) & 0x1FFFFF) * (1.0 / 2097152.0) - 0.5) * 3.4641016151377544;
}

}  // namespace detail

/// Scratch memory of StereoSensor::render. A caller that renders every cycle keeps one (FakeSensor
/// does), so the per-pixel buffers are allocated once instead of per frame and a shift-long run's heap
/// does not churn through image-sized blocks. One workspace per thread that renders.
template <typename Scalar>
struct RenderWorkspace {
  DepthImage<Scalar> truth;
  std::vector<PixelStatus> status;
  std::vector<std::int16_t> part;
  std::vector<Scalar> speckle, rowmin;
  std::vector<std::uint8_t> row, full, label;
  std::vector<std::int32_t> stack, members;
};

/// The simulated stereo camera. Thread-safe to share: render() is const (give each thread its own
/// RenderWorkspace).
template <typename Scalar>
class StereoSensor {
 public:
  using Camera = PinholeCamera<Scalar>;

  /// Throws std::invalid_argument naming the setting: non-positive width/height/view/working
  /// distance/baseline, an empty or inverted range, negative noise or thresholds, num_threads < 0.
  explicit StereoSensor(const StereoSensorSettings<Scalar>& s = {})
      : s_(validated(s)),
        camera_(Scalar(s.width) * s.working_distance / s.view_width, Scalar(s.height) * s.working_distance / s.view_height,
                Scalar(s.width - 1) / 2, Scalar(s.height - 1) / 2, s.width, s.height) {}

  const Camera& camera() const { return camera_; }
  const StereoSensorSettings<Scalar>& settings() const { return s_; }

  /// Renders the scene seen from T_base_camera (left camera in the base frame) as frame number
  /// `frame_index` (part of the random key: the same index and pose reproduce the frame).
  StereoFrame<Scalar> render(const Scene<Scalar>& scene, const Isometry3<Scalar>& T_base_camera,
                             std::uint64_t frame_index) const {
    return render(SceneGeometry<Scalar>::build(scene, s_.errors.bin_material, s_.errors.table_material), T_base_camera,
                  frame_index);
  }

  StereoFrame<Scalar> render(const SceneGeometry<Scalar>& geo, const Isometry3<Scalar>& T_base_camera,
                             std::uint64_t frame_index) const {
    RenderWorkspace<Scalar> ws;
    return render(geo, T_base_camera, frame_index, ws);
  }

  /// render() with caller-kept scratch memory (the same frame as without it).
  StereoFrame<Scalar> render(const SceneGeometry<Scalar>& geo, const Isometry3<Scalar>& T_base_camera,
                             std::uint64_t frame_index, RenderWorkspace<Scalar>& ws) const {
    require_valid_pose(T_base_camera, "T_base_camera");
    const int W = s_.width, H = s_.height;
    const std::size_t N = std::size_t(W) * std::size_t(H);
    StereoFrame<Scalar> f;
    f.T_base_camera = T_base_camera;
    f.frame_index = frame_index;
    f.depth.resize(W, H);
    DepthImage<Scalar>& truth = ws.truth;
    truth.resize(W, H);
    std::vector<PixelStatus>& status = ws.status;
    status.assign(N, PixelStatus::no_surface);
    std::vector<std::int16_t>& part = ws.part;
    part.assign(N, -1);
    const std::uint64_t key = sim::detail::hash_keys(s_.seed, frame_index);

    const int threads = binpick::detail::resolve_num_threads(s_.num_threads);
    (void)threads;  // no parallel region without OpenMP
    // Speckle: one log-normal factor per camera and grid cell of the left image (SENSOR_MODEL step 3).
    const int cell = scaled_px(s_.errors.speckle_cell_px);
    const int gw = (W + cell - 1) / cell, gh = (H + cell - 1) / cell;
    const std::size_t cells = std::size_t(gw) * std::size_t(gh);
    std::vector<Scalar>& speckle = ws.speckle;
    speckle.resize(2 * cells);
    for (std::size_t c = 0; c < cells; ++c) {
      sim::detail::Rng rng(sim::detail::hash_keys(key, detail::kSpeckle, c));
      const double common = s_.errors.speckle_sigma * rng.normal();
      speckle[c] = Scalar(std::exp(common + s_.errors.speckle_lr_sigma * rng.normal()));
      speckle[cells + c] = Scalar(std::exp(common + s_.errors.speckle_lr_sigma * rng.normal()));
    }
    const PixelContext ctx{geo, T_base_camera, T_base_camera.inverse(Eigen::Isometry), key, cell, gw, speckle.data(),
                           speckle.data() + std::size_t(gw) * std::size_t(gh)};
    BINPICK_OMP(parallel for num_threads(threads) schedule(dynamic, 4))
    for (int v = 0; v < H; ++v)
      for (int u = 0; u < W; ++u) shade_pixel(ctx, u, v, f.depth, truth, status, part);

    if (s_.errors.enabled) {
      grow_saturation(status, f.depth, ws);
      edges(key, truth, status, f.depth, ws);
      speckle_filter(status, f.depth, ws);
    }
    for (std::size_t i = 0; i < N; ++i) {
      const Scalar z = f.depth.data()[i], zt = truth.data()[i];
      f.surface_pixels += zt > Scalar(0);
      f.valid_pixels += z > Scalar(0);
      f.part_pixels += part[i] >= 0;
      f.valid_part_pixels += part[i] >= 0 && z > Scalar(0);
      f.ghost_pixels += status[i] == PixelStatus::ghost;
      f.outlier_pixels += z > Scalar(0) && std::abs(z - zt) > Scalar(0.002);
    }
    if (s_.diagnostics) {  // copies: the workspace keeps its buffers
      f.true_depth = truth;
      f.status = status;
      f.part_index = part;
    }
    return f;
  }

 private:
  using Vec3 = Vector3<Scalar>;

  static StereoSensorSettings<Scalar> validated(const StereoSensorSettings<Scalar>& s) {
    require(s.width > 0, "width", "must be > 0");
    require(s.height > 0, "height", "must be > 0");
    require(std::isfinite(s.view_width) && s.view_width > 0, "view_width", "must be finite and > 0");
    require(std::isfinite(s.view_height) && s.view_height > 0, "view_height", "must be finite and > 0");
    require(std::isfinite(s.working_distance) && s.working_distance > 0, "working_distance", "must be finite and > 0");
    require(std::isfinite(s.baseline) && s.baseline > 0, "baseline", "must be finite and > 0");
    require(std::isfinite(s.min_range) && s.min_range >= 0, "min_range", "must be finite and >= 0");
    require(std::isfinite(s.max_range) && s.max_range > s.min_range, "max_range", "must be finite and > min_range");
    require(std::isfinite(s.accuracy) && s.accuracy > 0, "accuracy", "must be finite and > 0");
    require(s.num_threads >= 0, "num_threads", "must be >= 0 (0 = all cores)");
    const auto& e = s.errors;
    require(std::isfinite(e.noise_scale) && e.noise_scale >= 0, "noise_scale", "must be finite and >= 0");
    require(e.subpixel_sigma >= 0 && e.disparity_quantum > 0, "disparity_quantum", "noise must be >= 0, quantum > 0");
    require(e.saturation > e.dark && e.dark >= 0, "saturation", "must exceed dark >= 0");
    require(e.left_right_ratio >= 1, "left_right_ratio", "must be >= 1");
    require(std::isfinite(e.vignetting_power) && e.vignetting_power >= 0, "vignetting_power", "must be finite and >= 0");
    require(e.match_window_px >= 1 && e.speckle_cell_px >= 1 && e.saturation_growth_px >= 0 &&
                e.speckle_filter_min_region_px >= 0,
            "match_window_px", "pixel sizes must be >= 1 (growth, region >= 0)");
    return s;
  }

  /// A pixel size given for a 1280 px wide image, scaled to this width.
  int scaled_px(int px_at_1280) const { return std::max(1, int(std::lround(px_at_1280 * s_.width / 1280.0))); }

  struct PixelContext {
    const SceneGeometry<Scalar>& geo;
    const Isometry3<Scalar>& T;
    Isometry3<Scalar> T_camera_base;
    std::uint64_t key;
    int cell, grid_width;
    const Scalar* speckle_left;
    const Scalar* speckle_right;
  };

  void shade_pixel(const PixelContext& ctx, int u, int v, DepthImage<Scalar>& depth, DepthImage<Scalar>& truth,
                   std::vector<PixelStatus>& status, std::vector<std::int16_t>& part) const {
    const SceneGeometry<Scalar>& geo = ctx.geo;
    const Isometry3<Scalar>& T = ctx.T;
    const std::uint64_t key = ctx.key;
    const std::size_t idx = std::size_t(v) * std::size_t(s_.width) + std::size_t(u);
    const Vec3 d_cam((Scalar(u) - camera_.cx()) / camera_.fx(), (Scalar(v) - camera_.cy()) / camera_.fy(), Scalar(1));
    const Vec3 origin = T.translation();
    const Vec3 d = T.linear() * d_cam;  // t along d is the depth (d_cam.z = 1)
    RayHit<Scalar> hit;
    bool on_table = false;
    if (!geo.intersect(origin, d, s_.min_range * Scalar(0.5), s_.max_range * Scalar(2), hit)) {
      if (!(d.z() < Scalar(0))) return;
      hit.t = (geo.table_z - origin.z()) / d.z();
      on_table = true;
    }
    if (!(hit.t >= s_.min_range && hit.t <= s_.max_range)) return;
    truth.at(u, v) = hit.t;
    part[idx] = on_table ? std::int16_t(-1) : std::int16_t(geo.part[std::size_t(hit.triangle)]);
    if (!s_.errors.enabled) {
      depth.at(u, v) = hit.t;
      status[idx] = PixelStatus::valid;
      return;
    }
    const auto& e = s_.errors;
    const Scalar wd2 = s_.working_distance * s_.working_distance;
    const Vec3 X = origin + hit.t * d;
    const Vec3 dn = d.normalized();
    Vec3 ng = Vec3::UnitZ(), ns = Vec3::UnitZ();
    if (!on_table) surface_normals(geo, hit, dn, ng, ns);
    const Material<Scalar>& mat = on_table ? s_.errors.table_material
                                           : geo.materials[std::size_t(geo.material[std::size_t(hit.triangle)])];
    const Vec3 right = T * Vec3(s_.baseline, 0, 0), projector = T * Vec3(s_.baseline / 2, 0, 0);
    const Vec3 Xo = X + ng * Scalar(2e-5);

    // 2. Visibility from the right camera and the projector.
    const Vec3 x_right = ctx.T_camera_base * X - Vec3(s_.baseline, 0, 0);
    if (!camera_.project(x_right)) return set(status, idx, PixelStatus::outside_right);
    if (ng.dot(right - X) <= Scalar(0) || geo.occluded(Xo, right - Xo, Scalar(0), Scalar(1)))
      return set(status, idx, PixelStatus::occluded_right);
    if (ng.dot(projector - X) <= Scalar(0) || geo.occluded(Xo, projector - Xo, Scalar(0), Scalar(1)))
      return set(status, idx, PixelStatus::shadowed);

    // 3. Brightness in each camera relative to a white matte target at the working distance.
    const Vec3 l = (projector - X).normalized();
    const Scalar irradiance = wd2 / (projector - X).squaredNorm();
    const Scalar direct_left = irradiance * detail::relative_reflectance(ns, l, Vec3(-dn), mat);
    const Scalar direct_right = irradiance * detail::relative_reflectance(ns, l, Vec3((right - X).normalized()), mat);
    const std::size_t cell_index = std::size_t(v / ctx.cell) * std::size_t(ctx.grid_width) + std::size_t(u / ctx.cell);
    const Scalar speckle_left = ctx.speckle_left[cell_index], speckle_right = ctx.speckle_right[cell_index];
    const std::uint64_t jitter = sim::detail::hash_keys(key, detail::kJitter, idx);
    const Scalar j_sat = Scalar(1 + e.threshold_jitter * detail::unit_variance_uniform(jitter, 0));
    const Scalar j_dark = Scalar(1 + e.threshold_jitter * detail::unit_variance_uniform(jitter, 1));
    const Scalar j_ratio = Scalar(1 + e.threshold_jitter * detail::unit_variance_uniform(jitter, 2));

    // 4. One-bounce inter-reflection: what the left camera sees in the mirror at X.
    Scalar range = hit.t * d.norm();
    Scalar left = direct_left, right_b = direct_right;
    bool ghost = false;
    if (e.ghosts && mat.fresnel0 >= e.ghost_min_fresnel) {
      const Vec3 r = dn - Scalar(2) * dn.dot(ns) * ns;
      RayHit<Scalar> h2;
      if (r.dot(ng) > Scalar(0) && geo.intersect(Xo, r, Scalar(0), e.ghost_max_path, h2)) {
        const Vec3 Y = Xo + h2.t * r;
        Vec3 ng2, ns2;
        surface_normals(geo, h2, r, ng2, ns2);
        const Material<Scalar>& mat2 = geo.materials[std::size_t(geo.material[std::size_t(h2.triangle)])];
        const Scalar cos_mirror = std::clamp(-dn.dot(ns), Scalar(0), Scalar(1));
        const Scalar fresnel = mat.fresnel0 + (Scalar(1) - mat.fresnel0) * std::pow(Scalar(1) - cos_mirror, Scalar(5));
        const Scalar mirrored = fresnel * wd2 / (projector - Y).squaredNorm() *
                                detail::relative_reflectance(ns2, Vec3((projector - Y).normalized()), Vec3(-r), mat2);
        if (mirrored > direct_left) {
          const Scalar footprint = Scalar(scaled_px(e.match_window_px)) * hit.t / camera_.fx();  // [m] on the surface
          if (!on_table && geo.curvature[std::size_t(hit.triangle)] * footprint > e.curved_mirror_angle)
            return set(status, idx, PixelStatus::curved_reflection);
          ghost = true;
          range += h2.t;  // the unfolded path: a virtual point behind the mirror
          left = right_b = mirrored;
        }
      }
    }
    if (e.vignetting_power > Scalar(0)) {
      left *= std::pow(Scalar(1) / d_cam.norm(), e.vignetting_power);
      right_b *= std::pow(x_right.z() / x_right.norm(), e.vignetting_power);
    }
    left *= speckle_left;
    right_b *= speckle_right;
    const Scalar sat = e.saturation * j_sat;
    if (left > sat || right_b > sat) return set(status, idx, PixelStatus::saturated);
    if (std::min(left, right_b) < e.dark * j_dark) return set(status, idx, PixelStatus::too_dark);
    if (!ghost && std::max(left, right_b) > e.left_right_ratio * j_ratio * std::min(left, right_b))
      return set(status, idx, PixelStatus::left_right_mismatch);

    // 5. Disparity noise: grows as the return darkens and the incidence steepens; 1/32 px steps.
    const Scalar z = range / d.norm();
    const Scalar theta = std::min(std::acos(std::clamp(-dn.dot(ns), Scalar(-1), Scalar(1))), Scalar(1.4));
    const Scalar incidence = theta * theta / ((Scalar(M_PI / 2) - theta) * (Scalar(M_PI / 2) - theta));
    const Scalar sigma = e.noise_scale * e.subpixel_sigma * std::sqrt(std::max(Scalar(1), Scalar(1) / std::min(left, right_b))) *
                         (Scalar(1) + e.incidence_noise_gain * incidence);
    const Scalar fb = camera_.fx() * s_.baseline;
    Scalar disparity = fb / z + sigma * Scalar(sim::detail::Rng(sim::detail::hash_keys(key, detail::kNoise, idx)).normal());
    disparity = std::round(disparity / e.disparity_quantum) * e.disparity_quantum;
    if (!(disparity > Scalar(0))) return set(status, idx, PixelStatus::too_dark);
    const Scalar zm = fb / disparity;
    if (!(zm >= s_.min_range && zm <= s_.max_range)) return set(status, idx, PixelStatus::no_surface);
    depth.at(u, v) = zm;
    status[idx] = ghost ? PixelStatus::ghost : PixelStatus::valid;
  }

  static void set(std::vector<PixelStatus>& status, std::size_t idx, PixelStatus s) { status[idx] = s; }

  /// Geometric normal (facing the ray) and interpolated shading normal (falls back to the geometric
  /// one where interpolation turns it away from the ray, at silhouettes of curved surfaces).
  static void surface_normals(const SceneGeometry<Scalar>& geo, const RayHit<Scalar>& hit, const Vec3& dir, Vec3& ng, Vec3& ns) {
    const auto& tri = geo.mesh.triangles[std::size_t(hit.triangle)];
    const Vec3 a = geo.mesh.vertices[std::size_t(tri.x())];
    ng = (geo.mesh.vertices[std::size_t(tri.y())] - a).cross(geo.mesh.vertices[std::size_t(tri.z())] - a).normalized();
    if (ng.dot(dir) > Scalar(0)) ng = -ng;
    const std::size_t c = 3 * std::size_t(hit.triangle);
    ns = ((Scalar(1) - hit.u - hit.v) * geo.mesh.corner_normals[c] + hit.u * geo.mesh.corner_normals[c + 1] +
          hit.v * geo.mesh.corner_normals[c + 2]);
    const Scalar len = ns.norm();
    ns = len > Scalar(0) ? Vec3(ns / len) : ng;
    if (ns.dot(dir) >= Scalar(0)) ns = ng;
  }

  /// Saturated pixels bloom into their neighbours (square dilation, separable).
  void grow_saturation(std::vector<PixelStatus>& status, DepthImage<Scalar>& depth, RenderWorkspace<Scalar>& ws) const {
    const int g = s_.errors.saturation_growth_px == 0 ? 0 : scaled_px(s_.errors.saturation_growth_px);
    if (g == 0) return;
    const int W = s_.width, H = s_.height;
    std::vector<std::uint8_t>& row = ws.row;
    std::vector<std::uint8_t>& full = ws.full;
    row.assign(std::size_t(W) * std::size_t(H), 0);
    full.assign(row.size(), 0);
    for (int v = 0; v < H; ++v)
      for (int u = 0; u < W; ++u) {
        if (status[std::size_t(v) * std::size_t(W) + std::size_t(u)] != PixelStatus::saturated) continue;
        for (int k = std::max(0, u - g); k <= std::min(W - 1, u + g); ++k) row[std::size_t(v) * std::size_t(W) + std::size_t(k)] = 1;
      }
    for (int v = 0; v < H; ++v)
      for (int u = 0; u < W; ++u) {
        if (!row[std::size_t(v) * std::size_t(W) + std::size_t(u)]) continue;
        for (int k = std::max(0, v - g); k <= std::min(H - 1, v + g); ++k) full[std::size_t(k) * std::size_t(W) + std::size_t(u)] = 1;
      }
    for (std::size_t i = 0; i < full.size(); ++i)
      if (full[i] && depth.data()[i] > Scalar(0)) {
        depth.data()[i] = 0;
        status[i] = PixelStatus::saturation_bloom;
      }
  }

  /// Far side of a depth jump within half a matching window: foreground value, mix, or hole.
  void edges(std::uint64_t key, const DepthImage<Scalar>& truth, std::vector<PixelStatus>& status,
             DepthImage<Scalar>& depth, RenderWorkspace<Scalar>& ws) const {
    const auto& e = s_.errors;
    const int h = scaled_px(e.match_window_px) / 2;
    if (h == 0) return;
    const int W = s_.width, H = s_.height;
    const Scalar inf = std::numeric_limits<Scalar>::infinity();
    std::vector<Scalar>& rowmin = ws.rowmin;  // nearest true depth within ±h in the row
    rowmin.resize(std::size_t(W) * std::size_t(H));
    for (int v = 0; v < H; ++v)
      for (int u = 0; u < W; ++u) {
        Scalar m = inf;
        for (int k = std::max(0, u - h); k <= std::min(W - 1, u + h); ++k) {
          const Scalar z = truth.at(k, v);
          if (z > Scalar(0)) m = std::min(m, z);
        }
        rowmin[std::size_t(v) * std::size_t(W) + std::size_t(u)] = m;
      }
    for (int v = 0; v < H; ++v)
      for (int u = 0; u < W; ++u) {
        const std::size_t i = std::size_t(v) * std::size_t(W) + std::size_t(u);
        const Scalar z = depth.data()[i], zt = truth.data()[i];
        if (!(z > Scalar(0))) continue;
        Scalar zf = inf;  // nearest true depth in the (2h+1)² window
        for (int k = std::max(0, v - h); k <= std::min(H - 1, v + h); ++k) zf = std::min(zf, rowmin[std::size_t(k) * std::size_t(W) + std::size_t(u)]);
        if (!(zt - zf > e.edge_jump)) continue;
        const double r = sim::detail::Rng(sim::detail::hash_keys(key, detail::kEdge, i)).uniform();
        if (r < e.edge_foreground_probability) {
          depth.data()[i] = zf + (z - zt);  // the foreground value, with this pixel's matching error
          status[i] = PixelStatus::edge_foreground;
        } else if (r < e.edge_foreground_probability + e.edge_mix_probability) {
          depth.data()[i] = (z + zf) / 2;
          status[i] = PixelStatus::edge_mix;
        } else {
          depth.data()[i] = 0;
          status[i] = PixelStatus::edge_hole;
        }
      }
  }

  /// Drops 4-connected regions (depth steps <= max_diff) smaller than the minimum size.
  void speckle_filter(std::vector<PixelStatus>& status, DepthImage<Scalar>& depth, RenderWorkspace<Scalar>& ws) const {
    const auto& e = s_.errors;
    if (e.speckle_filter_min_region_px == 0) return;
    const std::size_t min_region = std::size_t(std::max<long>(
        1, std::lround(e.speckle_filter_min_region_px * (s_.width / 1280.0) * (s_.width / 1280.0))));
    const int W = s_.width, H = s_.height;
    const Scalar fb = camera_.fx() * s_.baseline;
    std::vector<std::uint8_t>& label = ws.label;  // 1 = visited
    label.assign(std::size_t(W) * std::size_t(H), 0);
    std::vector<std::int32_t>& stack = ws.stack;
    std::vector<std::int32_t>& members = ws.members;
    for (std::size_t seed = 0; seed < label.size(); ++seed) {
      if (label[seed] || !(depth.data()[seed] > Scalar(0))) continue;
      members.clear();
      stack.assign(1, std::int32_t(seed));
      label[seed] = 1;
      while (!stack.empty()) {
        const std::int32_t p = stack.back();
        stack.pop_back();
        members.push_back(p);
        const int u = p % W, v = p / W;
        const Scalar zp = depth.data()[p];
        const int nu[4] = {u - 1, u + 1, u, u}, nv[4] = {v, v, v - 1, v + 1};
        for (int k = 0; k < 4; ++k) {
          if (nu[k] < 0 || nv[k] < 0 || nu[k] >= W || nv[k] >= H) continue;
          const std::int32_t q = nv[k] * W + nu[k];
          if (label[std::size_t(q)]) continue;
          const Scalar zq = depth.data()[q];
          if (!(zq > Scalar(0)) || std::abs(fb / zq - fb / zp) > e.speckle_filter_max_diff) continue;
          label[std::size_t(q)] = 1;
          stack.push_back(q);
        }
      }
      if (members.size() >= min_region) continue;
      for (const std::int32_t p : members) {
        depth.data()[p] = 0;
        status[std::size_t(p)] = PixelStatus::speckle_filtered;
      }
    }
  }

  StereoSensorSettings<Scalar> s_;
  Camera camera_;
};

}  // namespace binpick::sim
