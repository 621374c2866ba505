#pragma once
/// \file fuse.hpp
/// The fusion pipeline (paper §III.B, Alg. 1, Figs. 3–4): views 2..n, captured while the robot moves
/// and so with late kinematic poses, are first registered to view 1 (the reference, captured at the
/// pull-up stop with an exact pose) with point-to-plane ICP starting from their kinematic poses
/// (§III.B.2), then reprojected into view 1 and voted per pixel into ONE depth image of view 1. When
/// ICP fails or would move a view further than a bound from its kinematic prior, the kinematic pose is
/// kept and the per-view report says so. The result is expressed in the reference camera; `T_base_target` puts it into the robot
/// base frame (Fig. 3: the reference view is the bridge to the robot).
///
/// \code
///   binpick::Fuser<float, binpick::PinholeCamera<float>> fuser(camera);   // keep it across cycles
///   binpick::FusionSettings<float> settings;                              // δ = 2 × 1 mm
///   auto result = fuser.fuse(views, T_base_views, settings);              // views[0] is the target
///   // result.depth: fused depth of view 1 [m]; result.T_base_target: its pose in the robot base
/// \endcode

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <vector>

#include "binpick/core/brown_conrady_camera.hpp"
#include "binpick/core/camera_model.hpp"
#include "binpick/core/depth_image.hpp"
#include "binpick/core/parallel.hpp"
#include "binpick/core/pose.hpp"
#include "binpick/fusion/reproject.hpp"
#include "binpick/fusion/voting.hpp"
#include "binpick/registration/align_depth_views.hpp"

namespace binpick {
namespace detail {

/// A camera that sees every k-th pixel of `camera` (pixel u' is pixel k u'): intrinsics divided by k,
/// lens distortion (in normalized coordinates) unchanged.
template <typename Scalar>
PinholeCamera<Scalar> scaled_camera(const PinholeCamera<Scalar>& c, int k) {
  return PinholeCamera<Scalar>(c.fx() / Scalar(k), c.fy() / Scalar(k), c.cx() / Scalar(k), c.cy() / Scalar(k),
                               (c.width() + k - 1) / k, (c.height() + k - 1) / k);
}
template <typename Scalar>
BrownConradyCamera<Scalar> scaled_camera(const BrownConradyCamera<Scalar>& c, int k) {
  return BrownConradyCamera<Scalar>(c.fx() / Scalar(k), c.fy() / Scalar(k), c.cx() / Scalar(k), c.cy() / Scalar(k),
                                    (c.width() + k - 1) / k, (c.height() + k - 1) / k, c.distortion());
}
template <typename T, typename = void>
struct is_scalable_camera : std::false_type {};
template <typename T>
struct is_scalable_camera<T, std::void_t<decltype(scaled_camera(std::declval<const T&>(), 2))>> : std::true_type {};

}  // namespace detail

/// Settings of the fusion pipeline.
template <typename Scalar>
struct FusionSettings {
  Scalar sensor_accuracy = Scalar(0.001);  ///< [m] depth accuracy of the sensor
  Scalar delta = Scalar(0);                ///< [m] voting threshold δ; 0 = 2 × sensor_accuracy (Alg. 1)
  int min_votes = 1;                       ///< fewer votes → no measurement (1: a single view passes)
  bool compute_votes = false;              ///< also output the per-pixel vote count (a confidence map)
  /// 0 = all cores. The result has the same bits for any count: reprojection and voting have no
  /// reduction across threads, and views 2..n are registered in parallel, each view's ICP on one
  /// thread (IcpSettings::num_threads is ignored here).
  int num_threads = 1;

  /// Register views 2..n to view 1 with point-to-plane ICP before voting (§III.B.2).
  bool register_views = true;
  /// ICP of the registration: projective association into view 1, every 4th row and column of the
  /// source (more in wide images, see stride_width), Tukey kernel. Its num_threads is not used (see
  /// num_threads above).
  IcpSettings<Scalar> icp = default_icp();
  ProjectiveAssociationSettings association{};  ///< search window in view 1
  /// Estimate normals for the source points: points without one (depth edges, holes) are left out,
  /// and pairs whose normals differ by more than IcpSettings::max_normal_angle are rejected. false:
  /// every source point pairs (point-to-plane needs only view 1's normals). On by default, for clean
  /// geometry (it keeps box edges from sliding); the picking cell turns it off for single-shot metal
  /// depth, where it biases the pose (cycle::PipelineSettings::default_fusion, measured there).
  bool source_normals = true;
  /// View 1 is sampled every `reference_stride`-th row and column (with intrinsics scaled to match,
  /// which is exact) for its normals and the association: the source is already every 4th pixel, so
  /// a full-resolution reference only costs time. 1 = full resolution (also used for camera models
  /// other than pinhole and Brown–Conrady).
  int reference_stride = 2;
  /// The strides above (icp.stride, reference_stride) are meant for images up to this many pixels
  /// wide; a wider camera multiplies both by ceil(width / stride_width) (at 1280 x 1024: the source
  /// every 8th, view 1 every 4th pixel), so registration samples a view as densely in angle, and
  /// costs the same, at any resolution. ICP's precision comes from the number and spread of its
  /// points, not from the pixel pitch. Measured at 1280 x 1024 (5 part types x 2 piles x 3 views on
  /// the simulated sensing arc, kinematic poses up to 18 mm / 3.5 deg off): scaled, the views land
  /// 0.10 mm / 0.047 deg from the truth on average (worst 0.26 mm / 0.12 deg) for 7.5 ms of
  /// registration a fusion; unscaled, 0.13 mm / 0.021 deg (worst 0.29 mm / 0.042 deg) for 35 ms.
  /// Either is far below the voting threshold δ. 0 = the strides as given at any resolution.
  int stride_width = 640;
  /// Normals of view 1 (and of the sources with source_normals): tangents over 3 (sampled) pixels and
  /// a tolerant crease test, because single-shot depth on metal is noisy at the pixel scale.
  OrganizedNormalSettings<Scalar> normals = default_normals();
  /// Bounds on the ICP correction relative to the kinematic pose; a larger correction is not trusted
  /// and the kinematic pose is kept. Defaults: 3 cm and 5° (motion error is a few mm and about 1°).
  Scalar max_correction_translation = Scalar(0.03);  ///< [m]
  Scalar max_correction_rotation = Scalar(0.0873);   ///< [rad]

  Scalar effective_delta() const { return delta > Scalar(0) ? delta : Scalar(2) * sensor_accuracy; }
  /// The factor stride_width applies to the strides for an image `width` pixels wide (>= 1).
  int stride_scale(int width) const { return stride_width > 0 ? std::max(1, (width + stride_width - 1) / stride_width) : 1; }

  static OrganizedNormalSettings<Scalar> default_normals() {
    OrganizedNormalSettings<Scalar> n;
    n.pixel_offset = 3;
    n.max_crease_angle = Scalar(0.7);
    return n;
  }

  /// Registration settings for single-shot depth of shiny metal (SENSOR_MODEL.md: holes, ghosts,
  /// edge effects, speckle): a 3 x 3 search window in view 1 (the pixel a source point projects to is
  /// often a hole or a ghost; the window finds the surface beside it), a crease limit of 1.2 rad and a
  /// loose source-normal test of 1.5 rad (a tight one dropped most of the noisy source points and left
  /// the pose biased; leaving out points without a normal still keeps clean box edges from sliding).
  ///
  /// Measured on simulated metal piles (4 part types x 3 piles x 3 views at 640 x 512, kinematic poses
  /// off by 3 mm and 1 deg, i.e. 7.0 mm rms displacement of the view's points): the defaults leave the
  /// registered views 3.8 mm off on average (worst 6.5 mm), these settings 0.88 mm (worst 1.47 mm;
  /// with source_normals = false and 30 iterations 0.43 mm). Not the default yet: in the simulated
  /// picking test (2 runs x 10 parts per type, with 30 iterations) the complete rate did not change
  /// beyond its noise (81 % vs 82 % over the 5 types) while processing took 58 ms a cycle instead of 37
  /// (the association makes 9 lookups per point instead of one).
  static FusionSettings<Scalar> metal_depth() {
    FusionSettings<Scalar> f;
    f.association.window_radius = 1;
    f.normals.max_crease_angle = Scalar(1.2);
    f.icp.max_normal_angle = Scalar(1.5);
    return f;
  }

  static IcpSettings<Scalar> default_icp() {
    IcpSettings<Scalar> s;
    s.max_normal_angle = Scalar(0.5);
    s.stride = 4;
    s.max_iterations = 15;
    // Converged when an update moves less than 50 um / 0.01 deg: far below the voting threshold
    // (2 mm), and above the jitter that sensor noise leaves in the last updates.
    s.translation_epsilon = Scalar(5e-5);
    s.rotation_epsilon = Scalar(1.7e-4);
    s.max_correspondence_distance = Scalar(0.02);
    s.kernel = RobustKernel::tukey;
    s.kernel_scale = Scalar(0.01);
    return s;
  }
};

/// How a view's pose was obtained.
enum class ViewPose {
  reference,         ///< the target view itself (exact pose, not registered)
  kinematic,         ///< registration off: the kinematic pose as given
  registered,        ///< ICP refined the kinematic pose
  kept_icp_failed,   ///< ICP failed (too few correspondences, diverged): the kinematic pose was kept
  kept_too_far,      ///< ICP moved the view beyond the correction bounds: the kinematic pose was kept
};

inline const char* to_string(ViewPose p) {
  switch (p) {
    case ViewPose::reference: return "reference";
    case ViewPose::kinematic: return "kinematic";
    case ViewPose::registered: return "registered";
    case ViewPose::kept_icp_failed: return "kept_icp_failed";
    default: return "kept_too_far";
  }
}

/// What happened to one input view.
template <typename Scalar>
struct FusionViewReport {
  std::size_t valid_pixels = 0;  ///< valid depth pixels in the input view
  ViewPose pose = ViewPose::kinematic;
  /// The pose used for the view: the registered one, or the kinematic one when kept.
  Isometry3<Scalar> T_base_view = Isometry3<Scalar>::Identity();
  // Registration diagnostics (meaningful when registration ran for this view):
  IcpStatus icp_status = IcpStatus::converged;
  Scalar icp_rmse = Scalar(0);            ///< [m]
  std::size_t icp_inliers = 0;
  int icp_iterations = 0;
  Scalar correction_translation = Scalar(0);  ///< [m] ICP result vs the kinematic pose (even if rejected)
  Scalar correction_rotation = Scalar(0);     ///< [rad]
};

template <typename Scalar>
struct FusionResult {
  DepthImage<Scalar> depth;         ///< fused depth of the target view [m]; 0 = no measurement
  VoteMap votes;                    ///< votes per pixel; empty unless settings.compute_votes
  Isometry3<Scalar> T_base_target;  ///< pose of the target camera in the robot base frame
  std::vector<FusionViewReport<Scalar>> views;
  std::size_t valid_pixels = 0;     ///< valid pixels of the fused depth
  /// Measured wall time [ms] of the stages: registration of views 2..n (view 1's normals, the
  /// sources' normals, ICP; 0 when off), line 1 of Alg. 1 (view 1 decoded, the others reprojected)
  /// and the vote (lines 2-10).
  double registration_ms = 0, reprojection_ms = 0, voting_ms = 0;
};

/// Reusable fusion context for one camera: keeps the camera's ray table, the per-view planes and the
/// registration's reference cloud, so a cycle after the first allocates nothing large (with the
/// overload of fuse() that fills a kept FusionResult, not even the output).
template <typename Scalar, typename Camera>
class Fuser {
  static_assert(is_camera_model<Camera>::value, "Fuser: Camera must model the camera concept (core/camera_model.hpp)");

 public:
  explicit Fuser(const Camera& camera) : camera_(camera), rays_(detail::RayTable<Scalar>::make(camera)) {}

  const Camera& camera() const { return camera_; }

  /// Fuses `views` (views[0] is the target, views[1..] are reprojected into it) whose camera poses in
  /// the robot base frame are `T_base_views`. All views come from this fuser's camera.
  /// Throws std::invalid_argument naming the argument: empty or mismatched lists, a view whose size
  /// differs from the camera's, a non-rigid or non-finite pose, δ ≤ 0, min_votes < 1, more than
  /// kMaxFusionViews views.
  FusionResult<Scalar> fuse(const std::vector<DepthImageView<Scalar>>& views,
                            const std::vector<Isometry3<Scalar>>& T_base_views, const FusionSettings<Scalar>& settings) {
    FusionResult<Scalar> result;
    fuse(views, T_base_views, settings, result);
    return result;
  }

  /// fuse() into `result`, reusing its memory (keep one FusionResult across cycles). Same errors.
  void fuse(const std::vector<DepthImageView<Scalar>>& views, const std::vector<Isometry3<Scalar>>& T_base_views,
            const FusionSettings<Scalar>& settings, FusionResult<Scalar>& result) {
    require(!views.empty(), "views", "is empty");
    require(views.size() == T_base_views.size(), "T_base_views", "must have one pose per view");
    fuse_into(T_base_views[0], views, T_base_views, 1, settings, result);
  }

  /// Fuses all `views` into a virtual target camera at `T_base_target` that has no depth of its own
  /// (also how a fusion is checked against a real frame left out of it).
  FusionResult<Scalar> fuse_virtual(const Isometry3<Scalar>& T_base_target, const std::vector<DepthImageView<Scalar>>& views,
                                    const std::vector<Isometry3<Scalar>>& T_base_views,
                                    const FusionSettings<Scalar>& settings) {
    require(!views.empty(), "views", "is empty");
    require(views.size() == T_base_views.size(), "T_base_views", "must have one pose per view");
    FusionResult<Scalar> result;
    fuse_into(T_base_target, views, T_base_views, 0, settings, result);
    return result;
  }

 private:
  // Defined below the class, not inline, so that `extern template class Fuser<...>;` keeps a
  // translation unit from instantiating the fusion (and the ICP it runs) again.
  void fuse_into(const Isometry3<Scalar>& T_base_target, const std::vector<DepthImageView<Scalar>>& views,
                 const std::vector<Isometry3<Scalar>>& T_base_views, std::size_t first_reprojected,
                 const FusionSettings<Scalar>& settings, FusionResult<Scalar>& result);

  // The projective target of the registration: view 1, decimated when the camera model allows it,
  // built in the kept buffers (register_to_first hands the cloud back).
  ProjectiveAssociation<Scalar, Camera> make_reference(const DepthImageView<Scalar>& view,
                                                       const FusionSettings<Scalar>& settings) {
    Camera cam = camera_;
    DepthImageView<Scalar> source = view;
    if constexpr (detail::is_scalable_camera<Camera>::value) {
      const int k = settings.reference_stride;
      cam = detail::scaled_camera(camera_, k);
      ref_depth_.resize(cam.width(), cam.height());
      for (int v = 0; v < ref_depth_.height(); ++v)
        for (int u = 0; u < ref_depth_.width(); ++u) ref_depth_.at(u, v) = view.depth(u * k, v * k);
      source = ref_depth_.view();
    }
    return make_projective_target(source, cam, settings.association, settings.normals, std::move(ref_cloud_));
  }

  // §III.B.2: views[1..] are registered to views[0], whose pose is exact, starting from their
  // kinematic poses. Fills each view's pose and diagnostics in `result`.
  void register_to_first(const std::vector<DepthImageView<Scalar>>& views, const std::vector<Isometry3<Scalar>>& T_base_views,
                         const FusionSettings<Scalar>& settings, int threads, FusionResult<Scalar>& result) {
    require(std::isfinite(settings.max_correction_translation) && settings.max_correction_translation > Scalar(0),
            "max_correction_translation", "must be finite and > 0");
    require(std::isfinite(settings.max_correction_rotation) && settings.max_correction_rotation > Scalar(0),
            "max_correction_rotation", "must be finite and > 0");
    require(settings.reference_stride >= 1, "reference_stride", "must be >= 1");
    require(settings.stride_width >= 0, "stride_width", "must be >= 0 (0 = strides as given)");
    require(settings.icp.stride >= 1, "stride", "must be >= 1");
    FusionSettings<Scalar> st = settings;
    st.normals.num_threads = threads;  // never more threads than the caller asked for
    const int scale = settings.stride_scale(camera_.width());
    st.reference_stride *= scale;
    st.icp.stride *= scale;
    ProjectiveAssociation<Scalar, Camera> reference = make_reference(views[0], st);
    const Isometry3<Scalar> T_ref_base = T_base_views[0].inverse(Eigen::Isometry);
    // Views are registered in parallel, each on one thread: a pose then has the same bits for any
    // thread count, and three views on two threads took less time than each view's sums split over
    // both (bench_cycle, 1280x1024). View 1's normals above use all threads.
    IcpSettings<Scalar> icp_settings = st.icp;
    icp_settings.num_threads = 1;
    OrganizedNormalSettings<Scalar> source_normals = settings.normals;
    source_normals.num_threads = 1;
    const long nreg = long(views.size()) - 1;
    // An exception must not leave a parallel region: kept per view, the first rethrown after it.
    std::vector<std::exception_ptr> errors(static_cast<std::size_t>(nreg));
    if (align_.size() < std::size_t(nreg)) align_.resize(std::size_t(nreg));
    BINPICK_OMP(parallel for schedule(dynamic, 1) num_threads(threads) if (threads > 1 && nreg > 1))
    for (long k = 0; k < nreg; ++k) {
      const std::size_t i = std::size_t(k) + 1;
      try {
        FusionViewReport<Scalar>& rep = result.views[i];
        const Isometry3<Scalar> T_ref_view_prior = T_ref_base * T_base_views[i];
        AlignWorkspace<Scalar>& ws = align_[std::size_t(k)];
        const IcpResult<Scalar> r =
            settings.source_normals
                ? align_depth_view(views[i], camera_, reference, T_ref_view_prior, icp_settings, source_normals, ws)
                : align_depth_view_points(views[i], camera_, reference, T_ref_view_prior, icp_settings, ws);
        const Isometry3<Scalar> correction = r.T_target_source * T_ref_view_prior.inverse(Eigen::Isometry);
        rep.icp_status = r.status;
        rep.icp_rmse = r.rmse;
        rep.icp_inliers = r.inliers;
        rep.icp_iterations = r.iterations;
        rep.correction_translation = correction.translation().norm();
        rep.correction_rotation = rotation_angle(correction);
        // A run that hit max_iterations still moved the view toward view 1; within the bounds it is
        // better than the late kinematic pose.
        const bool usable = r.ok() || r.status == IcpStatus::max_iterations;
        if (!usable) {
          rep.pose = ViewPose::kept_icp_failed;
        } else if (!(rep.correction_translation <= settings.max_correction_translation &&
                     rep.correction_rotation <= settings.max_correction_rotation)) {
          rep.pose = ViewPose::kept_too_far;
        } else {
          rep.pose = ViewPose::registered;
          rep.T_base_view = T_base_views[0] * r.T_target_source;
        }
      } catch (...) {
        errors[std::size_t(k)] = std::current_exception();
      }
    }
    ref_cloud_ = std::move(reference).release_target();  // the memory serves the next fusion
    for (const std::exception_ptr& e : errors)
      if (e) std::rethrow_exception(e);
  }

  // The target view's own depths as a plane (+inf = none); returns its valid pixel count.
  static std::size_t decode(const DepthImageView<Scalar>& view, Scalar* plane) {
    const int w = view.width();
    return view.dispatch([&](auto tag) {
      using T = decltype(tag);
      std::size_t valid = 0;
      for (int v = 0; v < view.height(); ++v)
        valid += detail::decode_row(view.template row<T>(v), w, view.metres_per_unit(),
                                    std::numeric_limits<Scalar>::infinity(), plane + std::size_t(v) * std::size_t(w));
      return valid;
    });
  }

  Camera camera_;
  detail::RayTable<Scalar> rays_;
  std::vector<std::vector<Scalar>> planes_;
  DepthImage<Scalar> ref_depth_;       // view 1 decimated for the registration's reference
  OrganizedCloud<Scalar> ref_cloud_;   // its cloud and normals, lent to the association each fusion
  std::vector<AlignWorkspace<Scalar>> align_;  // one per registered view: source clouds, ICP scratch
};

template <typename Scalar, typename Camera>
void Fuser<Scalar, Camera>::fuse_into(const Isometry3<Scalar>& T_base_target, const std::vector<DepthImageView<Scalar>>& views,
                                      const std::vector<Isometry3<Scalar>>& T_base_views, std::size_t first_reprojected,
                                      const FusionSettings<Scalar>& settings, FusionResult<Scalar>& result) {
  require(int(views.size()) <= kMaxFusionViews, "views", "more than kMaxFusionViews views");
  require(std::isfinite(settings.sensor_accuracy) && settings.sensor_accuracy > Scalar(0), "sensor_accuracy",
          "must be finite and > 0");
  require(std::isfinite(settings.delta) && settings.delta >= Scalar(0), "delta", "must be finite and >= 0 (0 = 2 x accuracy)");
  require(settings.min_votes >= 1, "min_votes", "must be >= 1");
  const int threads = detail::resolve_num_threads(settings.num_threads);
  require_valid_pose(T_base_target, "T_base_target");
  for (std::size_t i = 0; i < views.size(); ++i) {
    require(views[i].width() == camera_.width() && views[i].height() == camera_.height(), "views",
            "a view's size differs from the camera's");
    require_valid_pose(T_base_views[i], "T_base_views");
  }

  const int w = camera_.width(), h = camera_.height();
  const std::size_t npix = std::size_t(w) * std::size_t(h);
  const std::size_t nplanes = views.size();
  planes_.resize(nplanes);
  for (auto& p : planes_) p.resize(npix);

  result.T_base_target = T_base_target;
  result.views.assign(views.size(), FusionViewReport<Scalar>{});
  const Isometry3<Scalar> T_target_base = T_base_target.inverse(Eigen::Isometry);
  for (std::size_t i = 0; i < views.size(); ++i) {
    result.views[i].T_base_view = T_base_views[i];
    result.views[i].pose = i < first_reprojected ? ViewPose::reference : ViewPose::kinematic;
  }
  using clock = std::chrono::steady_clock;
  const auto ms_since = [](clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(clock::now() - t0).count();
  };
  auto t0 = clock::now();
  if (settings.register_views && views.size() > 1) register_to_first(views, T_base_views, settings, threads, result);
  result.registration_ms = ms_since(t0);
  t0 = clock::now();

  // Line 1 of Alg. 1: one plane per view (the target view decoded, the others reprojected). Views are
  // independent, so threads take whole views and the result does not depend on the thread count.
  const long nviews = long(nplanes);
  BINPICK_OMP(parallel for schedule(dynamic, 1) num_threads(threads) if (threads > 1))
  for (long i = 0; i < nviews; ++i) {
    Scalar* plane = planes_[std::size_t(i)].data();
    const DepthImageView<Scalar>& view = views[std::size_t(i)];
    result.views[std::size_t(i)].valid_pixels =
        std::size_t(i) < first_reprojected
            ? decode(view, plane)
            : detail::reproject_to_plane(view, rays_,
                                         Isometry3<Scalar>(T_target_base * result.views[std::size_t(i)].T_base_view),
                                         camera_, plane);
  }

  result.reprojection_ms = ms_since(t0);
  t0 = clock::now();

  // Lines 2-10: vote per pixel; rows are independent.
  std::vector<const Scalar*> ptrs(nplanes);
  for (std::size_t i = 0; i < nplanes; ++i) ptrs[i] = planes_[i].data();
  result.depth.resize(w, h);
  std::uint8_t* vote_ptr = nullptr;
  if (settings.compute_votes) {
    result.votes.width = w;
    result.votes.height = h;
    result.votes.votes.resize(npix);  // the vote writes every pixel's count
    vote_ptr = result.votes.votes.data();
  } else {
    result.votes = VoteMap{};
  }
  const Scalar delta = settings.effective_delta();
  const long nrows = h;
  BINPICK_OMP(parallel for schedule(static) num_threads(threads) if (threads > 1))
  for (long v = 0; v < nrows; ++v) {
    const std::size_t b = std::size_t(v) * std::size_t(w);
    detail::vote_pixels(ptrs.data(), int(nplanes), b, b + std::size_t(w), delta, settings.min_votes,
                        first_reprojected > 0, result.depth.data(), vote_ptr);
  }

  result.valid_pixels = result.depth.valid_count();
  result.voting_ms = ms_since(t0);
}

/// One-shot fusion (builds a Fuser; keep a Fuser instead when fusing every cycle).
template <typename Scalar, typename Camera>
FusionResult<Scalar> fuse(const std::vector<DepthImageView<Scalar>>& views, const std::vector<Isometry3<Scalar>>& T_base_views,
                          const Camera& camera, const FusionSettings<Scalar>& settings = {}) {
  Fuser<Scalar, Camera> fuser(camera);
  return fuser.fuse(views, T_base_views, settings);
}

}  // namespace binpick
