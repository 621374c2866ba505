// bench_fusion: the fusion of 4 float views (reproject + vote, Alg. 1) at 640x480 and 1280x1024, 1 and 2
// threads, with a memcpy of the same input bytes in the same run as the bandwidth floor. Every case
// runs at each SIMD level of this host ("isa": "baseline", "avx2"; "isa_choice": "run_time" when the
// level is chosen at run time, "build" when the build fixes it, as bench_fusion_avx2's
// -march=x86-64-v3 does).
#include <cstring>
#include <string>
#include <random>
#include <vector>

#include "bench.hpp"
#include "binpick/fusion.hpp"
#include "binpick/sim/box_scene.hpp"

using namespace binpick;

int main(int argc, char** argv) {
  const bench::Options opt = bench::parse_options(argc, argv);
#if defined(__x86_64__)
  if (std::string(BINPICK_BENCH_ISA) == "x86-64-v3" && !__builtin_cpu_supports("avx2")) {
    bench::JsonLine("skipped").str("isa", BINPICK_BENCH_ISA).str("reason", "CPU without AVX2").print();
    return 0;
  }
#endif
  const int n_views = 4;
  struct Size {
    int w, h;
  };
  std::vector<Size> sizes{{640, 480}, {1280, 1024}};
  if (opt.quick) sizes = {{640, 480}};
  for (const Size& sz : sizes) {
    // The sensor's field of view: about 75 x 50 cm at 0.3 m.
    const float fx = float(sz.w) * 0.3f / 0.75f, fy = fx;
    const PinholeCamera<float> cam(fx, fy, (sz.w - 1) * 0.5f, (sz.h - 1) * 0.5f, sz.w, sz.h);
    sim::BoxScene scene = sim::boxes_scene();
    const auto poses = sim::arc_poses(n_views);
    std::vector<DepthImage<float>> imgs;
    std::mt19937 rng(7);
    std::normal_distribution<float> noise(0.f, 0.0007f);
    std::uniform_int_distribution<int> pick(0, 99);
    for (const auto& T : poses) {
      DepthImage<float> img = scene.render<float>(cam, T);
      // Realistic input: sensor noise, 10 % dropouts, 2 % ghosts.
      for (float& d : img.storage()) {
        const int r = pick(rng);
        if (r < 10) d = 0;
        else if (r < 12) d += 0.02f;
        else d += noise(rng);
      }
      imgs.push_back(std::move(img));
    }
    std::vector<DepthImageView<float>> views;
    std::vector<Isometry3f> T_base_views;
    for (int i = 0; i < n_views; ++i) {
      views.push_back(imgs[std::size_t(i)].view());
      T_base_views.push_back(poses[std::size_t(i)].cast<float>());
    }

    // Bandwidth reference: copy the same bytes the fusion reads.
    const std::size_t bytes = std::size_t(sz.w) * sz.h * sizeof(float);
    std::vector<float> dst(std::size_t(sz.w) * sz.h);
    const bench::Stats mc = bench::measure(
        [&] {
          for (int i = 0; i < n_views; ++i) std::memcpy(dst.data(), imgs[std::size_t(i)].data(), bytes);
          bench::do_not_optimize(dst[0]);
        },
        opt.warmup, opt.trials);
    bench::JsonLine("memcpy_reference")
        .num("threads", 1).num("width", sz.w).num("height", sz.h).num("views", n_views)
        .stats(mc).num("ms_per_view", mc.median / n_views)
        .num("gb_per_s", double(bytes) * n_views / (mc.median * 1e-3) / 1e9).print();

    for (const SimdLevel level : available_simd_levels()) {
      set_max_simd_level(level);
      const std::string isa = BINPICK_SIMD_DISPATCH ? to_string(simd_level()) : BINPICK_BENCH_ISA;
      const char* isa_choice = BINPICK_SIMD_DISPATCH ? "run_time" : "build";
      // The two stages alone, 1 thread: reprojecting one view, and voting 4 planes.
      {
        const auto rays = detail::RayTable<float>::make(cam);
        const Isometry3f T = (T_base_views[0].inverse(Eigen::Isometry) * T_base_views[1]);
        std::vector<std::vector<float>> planes(std::size_t(n_views), std::vector<float>(std::size_t(sz.w) * sz.h));
        const bench::Stats rp = bench::measure(
            [&] { detail::reproject_to_plane(views[1], rays, T, cam, planes[1].data()); }, opt.warmup, opt.trials);
        bench::JsonLine("reproject_one_view")
            .str("impl", "binpick").str("isa", isa).str("isa_choice", isa_choice).num("threads", 1).num("width", sz.w).num("height", sz.h).num("views", 1)
            .stats(rp).num("ms_per_view", rp.median).print();
        for (int i = 0; i < n_views; ++i)
          detail::reproject_to_plane(views[std::size_t(i)], rays,
                                     Isometry3f(T_base_views[0].inverse(Eigen::Isometry) * T_base_views[std::size_t(i)]), cam,
                                     planes[std::size_t(i)].data());
        std::vector<const float*> ptrs;
        for (auto& p : planes) ptrs.push_back(p.data());
        std::vector<float> out(std::size_t(sz.w) * sz.h);
        const bench::Stats vt = bench::measure(
            [&] { vote<float>(ptrs, sz.w, sz.h, VotingSettings<float>{0.002f, 1}, out.data()); }, opt.warmup, opt.trials);
        std::size_t slow = 0;
        for (std::size_t i = 0; i < out.size(); ++i) {
          float lo = 1e9f, hi = 0;
          for (auto* p : ptrs)
            if (p[i] > 0 && p[i] < 1e9f) lo = std::min(lo, p[i]), hi = std::max(hi, p[i]);
          slow += hi > 0 && hi - lo >= 0.002f;
        }
        bench::JsonLine("vote_planes")
            .str("impl", "binpick").str("isa", isa).str("isa_choice", isa_choice).num("threads", 1).num("width", sz.w).num("height", sz.h).num("views", n_views)
            .stats(vt).num("ms_per_view", vt.median / n_views).num("disagreeing_pixel_fraction", double(slow) / out.size())
            .print();
      }

      Fuser<float, PinholeCamera<float>> fuser(cam);
      for (int threads : opt.threads) {
        FusionSettings<float> s;
        s.num_threads = threads;
        s.register_views = false;
        std::size_t valid = 0;
        const bench::Stats st = bench::measure(
            [&] {
              const auto r = fuser.fuse(views, T_base_views, s);
              valid = r.valid_pixels;
            },
            opt.warmup, opt.trials);
        bench::JsonLine("fuse")
            .str("impl", "binpick").str("isa", isa).str("isa_choice", isa_choice).num("threads", threads).num("width", sz.w).num("height", sz.h).num("views", n_views)
            .stats(st).num("ms_per_view", st.median / n_views).num("ratio_to_memcpy", st.median / mc.median)
            .num("valid_pixels_fused", double(valid)).num("valid_pixels_view1", double(imgs[0].valid_count()))
            .print();
      }
      // With registration (§III.B.2): views 2..4 start from kinematic poses read 20 ms late at 0.5 m/s.
      std::vector<Isometry3f> T_kinematic = T_base_views;
      for (int i = 1; i < n_views; ++i) {
        Isometry3f late = T_base_views[std::size_t(i)];
        late.translation().x() -= 0.01f;
        late.linear() = late.linear() * Eigen::AngleAxisf(0.03f, Eigen::Vector3f::UnitY()).toRotationMatrix();
        T_kinematic[std::size_t(i)] = late;
      }
      for (int threads : opt.threads) {
        FusionSettings<float> s;
        s.num_threads = threads;
        FusionResult<float> last;
        const bench::Stats st = bench::measure([&] { last = fuser.fuse(views, T_kinematic, s); }, opt.warmup, opt.trials);
        double rmse = 0, iters = 0, inliers = 0;
        for (int i = 1; i < n_views; ++i) {
          rmse += last.views[std::size_t(i)].icp_rmse / (n_views - 1);
          iters += last.views[std::size_t(i)].icp_iterations;
          inliers += double(last.views[std::size_t(i)].icp_inliers);
        }
        bench::JsonLine("fuse_with_registration")
            .str("impl", "binpick").str("isa", isa).str("isa_choice", isa_choice).num("threads", threads).num("width", sz.w).num("height", sz.h).num("views", n_views)
            .stats(st).num("ms_per_view", st.median / n_views).num("rmse", rmse).num("iterations", iters)
            .num("correspondences", inliers).num("valid_pixels_fused", double(last.valid_pixels)).print();
      }
    }  // SIMD levels
  }
  return 0;
}
