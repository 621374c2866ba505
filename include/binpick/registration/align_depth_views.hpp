#pragma once
/// \file align_depth_views.hpp
/// The entry point for registering one depth view to another (paper §III.B.2: views 2..n are refined
/// against view 1 with point-to-plane ICP, starting from their kinematic poses):
/// \code
///   // once per reference view
///   auto target = binpick::make_projective_target(depth1, camera);          // normals from the image
///   // per view i
///   IcpResult<float> r = binpick::align_depth_view(depth_i, camera, target, T_1_i_kinematic, settings);
///   // (in a camera loop, pass normal settings and an AlignWorkspace kept across frames)
///   if (r.ok()) T_1_i = r.T_target_source;                                  // else keep the prior
/// \endcode
/// or, in one call, `align_depth_views(source, source_camera, target, target_camera, T_init, settings)`.
/// The one call allocates about 15 MB at 640 x 480; where page faults are expensive (virtual
/// machines) it costs several times the registration itself even with the huge pages the library asks
/// for (README, "host" line of the benchmarks: 24 ms against 5.6 ms kept on one such host), so loops
/// keep the target's cloud and an AlignWorkspace across frames.
/// The source is every `settings.stride`-th row and column of the source image (stride 4 = 1/16 of the
/// pixels); association is projective into the target image (window `ProjectiveAssociationSettings`),
/// target normals come from the organized image (`OrganizedNormalSettings`).
/// `T_target_source` maps points of the source camera frame into the target camera frame.

#include "binpick/core/camera_model.hpp"
#include "binpick/core/depth_image.hpp"
#include "binpick/core/pose.hpp"
#include "binpick/registration/icp.hpp"
#include "binpick/registration/normals.hpp"
#include "binpick/registration/point_cloud.hpp"
#include "binpick/registration/projective_association.hpp"

namespace binpick {

/// The projective association of a target depth view: its organized cloud with normals, built in the
/// memory of `storage` (pass the cloud of last frame's association, `release_target()`, to reuse it).
template <typename Scalar, typename Camera>
ProjectiveAssociation<Scalar, Camera> make_projective_target(const DepthImageView<Scalar>& target_depth,
                                                             const Camera& target_camera,
                                                             const ProjectiveAssociationSettings& association = {},
                                                             const OrganizedNormalSettings<Scalar>& normals = {},
                                                             OrganizedCloud<Scalar> storage = {}) {
  OrganizedCloud<Scalar> cloud = std::move(storage);
  backproject_organized(target_depth, target_camera, 1, cloud, normals.num_threads);
  estimate_organized_normals(cloud, normals);
  return ProjectiveAssociation<Scalar, Camera>(std::move(cloud), target_camera, association);
}

/// The memory align_depth_view reuses across frames: the source cloud and ICP's scratch. Keep one
/// per thread of a camera loop and only the first frame allocates.
template <typename Scalar>
struct AlignWorkspace {
  PointCloud<Scalar> source;  ///< the last source view's cloud (with normals, unless aligned by its points)
  IcpWorkspace<Scalar> icp;
};

/// Registers a source depth view to a prepared target (any association strategy). The stride of
/// `settings` subsamples the source image's rows and columns; the source normals (used to reject
/// pairs across creases and occlusion edges, `IcpSettings::max_normal_angle`) are estimated at full
/// resolution at the kept pixels. The source cloud and ICP's scratch live in `workspace`.
template <typename Scalar, typename SourceCamera, typename Association>
IcpResult<Scalar> align_depth_view(const DepthImageView<Scalar>& source_depth, const SourceCamera& source_camera,
                                   const Association& target, const Isometry3<Scalar>& T_target_source_init,
                                   const IcpSettings<Scalar>& settings, const OrganizedNormalSettings<Scalar>& source_normals,
                                   AlignWorkspace<Scalar>& workspace) {
  require(settings.stride >= 1, "stride", "must be >= 1");
  IcpSettings<Scalar> s = settings;
  s.stride = 1;  // applied to the image grid here
  subsample_with_normals(source_depth, source_camera, settings.stride, source_normals, workspace.source);
  return icp(workspace.source, target, T_target_source_init, s, workspace.icp);
}

/// align_depth_view with the source's points alone: no source normals, so no pair filter on the
/// normals' angle (IcpSettings::max_normal_angle is ignored) and no normal estimation to pay for — the
/// robust kernel alone handles partners across creases and occlusion edges. What OpenCV's
/// rgbd::ICPOdometry does (normals of the destination only), and what the fusion does on single-shot
/// depth of shiny metal, whose source normals are noisy enough that their filter biases the pose
/// (FusionSettings::source_normals).
template <typename Scalar, typename SourceCamera, typename Association>
IcpResult<Scalar> align_depth_view_points(const DepthImageView<Scalar>& source_depth, const SourceCamera& source_camera,
                                          const Association& target, const Isometry3<Scalar>& T_target_source_init,
                                          const IcpSettings<Scalar>& settings, AlignWorkspace<Scalar>& workspace) {
  IcpSettings<Scalar> s = settings;
  s.stride = 1;  // applied to the image grid here
  backproject_points(source_depth, source_camera, settings.stride, workspace.source);  // checks the stride
  return icp(workspace.source, target, T_target_source_init, s, workspace.icp);
}

/// align_depth_view in fresh memory.
template <typename Scalar, typename SourceCamera, typename Association>
IcpResult<Scalar> align_depth_view(const DepthImageView<Scalar>& source_depth, const SourceCamera& source_camera,
                                   const Association& target, const Isometry3<Scalar>& T_target_source_init,
                                   const IcpSettings<Scalar>& settings = {},
                                   const OrganizedNormalSettings<Scalar>& source_normals = {}) {
  AlignWorkspace<Scalar> workspace;
  return align_depth_view(source_depth, source_camera, target, T_target_source_init, settings, source_normals, workspace);
}

/// One call: builds the projective target from `target_depth` and registers `source_depth` to it.
template <typename Scalar, typename SourceCamera, typename TargetCamera>
IcpResult<Scalar> align_depth_views(const DepthImageView<Scalar>& source_depth, const SourceCamera& source_camera,
                                    const DepthImageView<Scalar>& target_depth, const TargetCamera& target_camera,
                                    const Isometry3<Scalar>& T_target_source_init,
                                    const IcpSettings<Scalar>& settings = {},
                                    const ProjectiveAssociationSettings& association = {},
                                    const OrganizedNormalSettings<Scalar>& normals = {}) {
  const auto target = make_projective_target(target_depth, target_camera, association, normals);
  return align_depth_view(source_depth, source_camera, target, T_target_source_init, settings, normals);
}

}  // namespace binpick
