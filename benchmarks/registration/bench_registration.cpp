// bench_registration: point-to-plane ICP with kNN (FLANN) and projective association on a synthetic
// bin scene (floor + tilted boxes, ~0.3 m away) rendered analytically at 640×480 and 1280×1024;
// source stride 1 and 4; 1 and 2 threads. The source view is displaced by 1.5° and 4 mm from the
// truth. `"scope": "prepare+icp"` times cover target preparation (normals, kd-tree or organized cloud)
// + source normals + ICP, from fresh memory (`"prepare+icp kept"`: the same in memory kept across
// frames, as a camera loop runs it; projective only); `"scope": "icp"` times the ICP call alone on prepared
// clouds (what a caller that keeps its target across frames pays per registration).
// `organized_normals` times the target's per-frame preprocessing alone (backprojection + normals), in
// fresh memory and in a cloud kept across frames (`"memory"`). `"icp_isa"`: the variant of ICP's
// vectorized pass that ran (detail::fused_isa()).
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "bench.hpp"
#include "binpick/registration.hpp"

#include "analytic_bin.hpp"

using namespace binpick;

int main(int argc, char** argv) {
  const bench::Options opt = bench::parse_options(argc, argv);
  struct Size { int w, h; };
  std::vector<Size> sizes{{640, 480}, {1280, 1024}};
  if (opt.quick) sizes = {{640, 480}};
  Eigen::Isometry3d T_true = Eigen::Isometry3d::Identity();
  T_true.linear() = Eigen::AngleAxisd(0.03, Eigen::Vector3d(1, 2, 0.5).normalized()).toRotationMatrix();
  T_true.translation() = Eigen::Vector3d(0.008, -0.004, 0.003);
  Eigen::Isometry3d P = Eigen::Isometry3d::Identity();
  P.linear() = Eigen::AngleAxisd(1.5 * M_PI / 180, Eigen::Vector3d(-1, 1, 0.3).normalized()).toRotationMatrix();
  P.translation() = Eigen::Vector3d(0.002, 0.003, -0.002);
  const Isometry3<float> init = (P * T_true).cast<float>();

  for (const Size& sz : sizes) {
    const float f = 0.9f * float(sz.w);  // ~58° horizontal field of view
    const PinholeCamera<float> cam(f, f, 0.5f * (sz.w - 1), 0.5f * (sz.h - 1), sz.w, sz.h);
    const DepthImage<float> target = bench::render_analytic_bin(cam, Eigen::Isometry3d::Identity());
    const DepthImage<float> source = bench::render_analytic_bin(cam, T_true);
    // The per-frame preprocessing of a projective target alone: backprojection + organized normals.
    for (int threads : opt.threads) {
      for (const bool kept : {false, true}) {
        OrganizedNormalSettings<float> ns;
        ns.num_threads = threads;
        std::size_t with_normal = 0;
        OrganizedCloud<float> kept_cloud;
        const bench::Stats st = bench::measure(
            [&] {
              OrganizedCloud<float> fresh;
              OrganizedCloud<float>& org = kept ? kept_cloud : fresh;
              backproject_organized(target.view(), cam, 1, org);
              estimate_organized_normals(org, ns);
              with_normal = 0;
              for (const auto& nv : org.normals) with_normal += nv.squaredNorm() > 0.5f;
              bench::do_not_optimize(org);
            },
            opt.warmup, opt.trials);
        bench::JsonLine("organized_normals")
            .str("impl", "binpick")
            .str("memory", kept ? "kept" : "fresh")
            .num("width", sz.w)
            .num("height", sz.h)
            .num("threads", threads)
            .stats(st)
            .num("pixels_with_normal", double(with_normal))
            .print();
      }
    }
    for (const char* assoc : {"projective", "knn"}) {
      for (int stride : {1, 4}) {
        for (int threads : opt.threads) {
          IcpSettings<float> s;
          s.stride = stride;
          s.num_threads = threads;
          OrganizedNormalSettings<float> ns;
          ns.num_threads = threads;
          IcpResult<float> r;
          const auto run = [&]() {
            if (std::string(assoc) == "projective") {
              const auto tgt = make_projective_target(target.view(), cam, ProjectiveAssociationSettings{}, ns);
              r = align_depth_view(source.view(), cam, tgt, init, s, ns);
            } else {
              OrganizedCloud<float> org = backproject_organized(target.view(), cam);
              estimate_organized_normals(org, ns);
              const KnnAssociation<float> tgt(valid_points(org));
              r = align_depth_view(source.view(), cam, tgt, init, s, ns);
            }
            bench::do_not_optimize(r);
          };
          const bool heavy = std::string(assoc) == "knn" && stride == 1 && sz.w > 640;
          const int warmup = heavy ? 1 : opt.warmup, trials = heavy ? std::min(opt.trials, 3) : opt.trials;
          // The source as align_depth_view makes it: every stride-th row and column, normals at full
          // resolution (`source_points` counts its points; ICP uses those with a normal).
          const PointCloud<float> src = subsample_with_normals(source.view(), cam, stride, ns);
          const std::size_t source_points = src.size();
          const auto print = [&](const char* scope, const bench::Stats& st) {
            const Eigen::Isometry3d E = r.T_target_source.cast<double>() * T_true.inverse();
            bench::JsonLine("icp_point_to_plane")
                .str("impl", "binpick")
                .str("icp_isa", detail::fused_isa())
                .str("association", assoc)
                .str("scope", scope)
                .num("width", sz.w)
                .num("height", sz.h)
                .num("stride", stride)
                .num("threads", threads)
                .stats(st)
                .str("status", to_string(r.status))
                .num("rmse", r.rmse)
                .num("iterations", r.iterations)
                .num("correspondences", double(r.inliers))
                .num("source_points", double(source_points))
                .num("error_mm", E.translation().norm() * 1e3)
                .num("error_deg", rotation_angle<double>(E) * 180 / M_PI)
                .print();
          };
          print("prepare+icp", bench::measure(run, warmup, trials));
          if (std::string(assoc) == "projective") {
            // The same per-frame work in a camera loop: the target's cloud and the AlignWorkspace are
            // kept across frames (align_depth_views.hpp), so only the first frame allocates.
            OrganizedCloud<float> storage;
            AlignWorkspace<float> workspace;
            const auto run_kept = [&]() {
              auto tgt = make_projective_target(target.view(), cam, ProjectiveAssociationSettings{}, ns, std::move(storage));
              r = align_depth_view(source.view(), cam, tgt, init, s, ns, workspace);
              storage = std::move(tgt).release_target();
              bench::do_not_optimize(r);
            };
            print("prepare+icp kept", bench::measure(run_kept, warmup, trials));
          }
          // The ICP call alone: target and source prepared once outside the timing.
          IcpSettings<float> s1 = s;
          s1.stride = 1;  // already applied to the image grid
          bench::Stats st;
          if (std::string(assoc) == "projective") {
            const auto tgt = make_projective_target(target.view(), cam, ProjectiveAssociationSettings{}, ns);
            st = bench::measure([&] { r = icp(src, tgt, init, s1); bench::do_not_optimize(r); }, warmup, trials);
          } else {
            OrganizedCloud<float> org = backproject_organized(target.view(), cam);
            estimate_organized_normals(org, ns);
            const KnnAssociation<float> tgt(valid_points(org));
            st = bench::measure([&] { r = icp(src, tgt, init, s1); bench::do_not_optimize(r); }, warmup, trials);
          }
          print("icp", st);
        }
      }
    }
  }
  return 0;
}
