// bench_cycle: the measured part of the data processing phase of one cycle (paper Table I: 3D fusion
// and path planning; estimation excluded) for n = 4 views at 1280x1024 and 640x512: fusion with ICP
// registration of views 2..4 and voting, then Eq. 1 over 20 objects and Alg. 2 for the next path.
// At 1280x1024 also with the registration strides unscaled (FusionSettings::stride_width = 0), for
// the time and pose error the default scaling trades (pose errors against the simulation's truth).
// The four views are rendered once by the simulated sensor along a sensing arc swept at 80 % with
// late kinematic poses (the fake robot's read lag), as the cycle captures them. Also the Table I model.
// Each case runs at every SIMD level of this host ("isa", see bench_fusion.cpp).
#include "bench.hpp"

#include "binpick/active_vision.hpp"
#include "binpick/cycle.hpp"
#include "binpick/sim.hpp"

using namespace binpick;

int main(int argc, char** argv) {
  auto opt = bench::parse_options(argc, argv);
  {
    const double m = cycle::sensing_scheme_total(4, 0.030) * 1e3;
    bench::JsonLine("takt_model_eq2").num("threads", 1).num("views", 4).num("interval_ms", 30).num("median", m).num("min", m).num("max", m).str("unit", "ms").print();
  }
  sim::SceneSettings<float> ss;
  ss.part_type = sim::PartType::mirror_nut;
  const auto scene = sim::Scene<float>::generate(ss, 1);
  const int sizes[2][2] = {{1280, 1024}, {640, 512}};
  for (const auto& wh : sizes) {
    if (opt.quick && wh[0] == 1280) continue;
    sim::SimClock clock;
    cycle::PipelineSettings<float> ps;
    sim::FakeRobot<float> robot(clock, ps.T_base_drop);
    sim::StereoSensorSettings<float> st;
    st.width = wh[0];
    st.height = wh[1];
    st.num_threads = 2;
    sim::FakeSensor<float> sensor(scene, robot, clock, ps.T_flange_camera, st);
    // The arc: Alg. 2 aimed at the bin centre from a pull-up point above it, swept at 80 % every 30 ms.
    const Vector3<float> T(0, 0, 0.01f), A(0.02f, 0.01f, 0.0f);
    Isometry3f B = Isometry3f::Identity();
    B.linear() = Eigen::AngleAxisf(float(M_PI), Eigen::Vector3f::UnitX()).toRotationMatrix();
    B.translation() = Eigen::Vector3f(0.02f, 0.01f, 0.15f);
    const Vector3<float> d = (B * ps.T_flange_camera).translation() - B.translation();
    const float beta = 0.8f * 0.030f * 3 / 0.30f;
    const auto path = active_vision::plan_sensing_path<float>(T, 0.30f, A + d, B.translation() + d,
                                                              ps.T_base_drop.translation() + d, ps.gamma, beta, 4);
    if (!path.ok()) return 1;
    const Isometry3f Tfc_inv = ps.T_flange_camera.inverse(Eigen::Isometry);
    clock.sleep_until(robot.move_along({path.T_base_captures[0] * Tfc_inv}, 80));
    std::vector<Isometry3f> arc;
    for (int i = 1; i < 4; ++i) arc.push_back(path.T_base_captures[std::size_t(i)] * Tfc_inv);
    std::vector<Isometry3f> poses;
    const double t0 = clock.now();
    robot.move_along(arc, 80);
    for (int i = 0; i < 4; ++i) {
      clock.sleep_until(t0 + 0.030 * i);
      sensor.trigger();
      poses.push_back(robot.read_flange_pose().T_base_flange * ps.T_flange_camera);
    }
    const auto frames = sensor.read_frames_with_truth();  // the truth only scores the registration
    std::vector<DepthImageView<float>> views;
    for (const auto& f : frames) views.push_back(f.depth.view());
    // Pose error of views 2..4 [mm, deg], worst over the views: kinematic (as read) and as fused.
    const auto worst_error = [&](const auto& pose_of) {
      double mm = 0, deg = 0;
      for (std::size_t i = 1; i < frames.size(); ++i) {
        const Isometry3f e = frames[i].T_base_camera.inverse(Eigen::Isometry) * pose_of(i);
        mm = std::max(mm, 1e3 * double(e.translation().norm()));
        deg = std::max(deg, double(rotation_angle(e)) * 180.0 / M_PI);
      }
      return std::make_pair(mm, deg);
    };
    const auto kinematic_error = worst_error([&](std::size_t i) { return poses[i]; });
    // 20 recognized objects for Eq. 1.
    std::vector<Vector3<float>> objects;
    std::vector<float> conf;
    for (const auto& p : scene.parts()) objects.push_back(p.T_base_part.translation()), conf.push_back(60.0f);
    for (const SimdLevel level : available_simd_levels())
    for (const int threads : opt.threads) {
      set_max_simd_level(level);
      const char* isa = to_string(simd_level());
      Fuser<float, PinholeCamera<float>> fuser(sensor.camera());
      FusionSettings<float> fs = ps.fusion;
      fs.sensor_accuracy = sensor.accuracy();
      fs.num_threads = threads;
      std::size_t valid = 0;
      bench::do_not_optimize(fuser.fuse(views, poses, fs).valid_pixels);  // the first fusion allocates the buffers
      // A new FusionResult per call (fresh pages for the output every time), for comparison.
      const auto sf_new = bench::measure([&] { bench::do_not_optimize(fuser.fuse(views, poses, fs).valid_pixels); },
                                         opt.warmup, opt.trials);
      // As the pipeline fuses: into a FusionResult kept across cycles (no image-sized allocation).
      FusionResult<float> kept;
      const auto sf = bench::measure([&] { fuser.fuse(views, poses, fs, kept); valid = kept.valid_pixels; }, opt.warmup, opt.trials);
      // ICP's work in the fusion: iterations and inliers summed over views 2..4.
      double icp_iterations = 0, icp_inliers = 0;
      for (const auto& v : kept.views) icp_iterations += v.icp_iterations, icp_inliers += double(v.icp_inliers);
      const auto sp = bench::measure(
          [&] {
            const auto c = active_vision::target_center<float>(objects, conf, T, 0);
            bench::do_not_optimize(active_vision::plan_sensing_path<float>(c.point, 0.30f, A + d, B.translation() + d,
                                                                           ps.T_base_drop.translation() + d, ps.gamma, beta, 4));
          },
          opt.warmup, opt.trials);
      const auto sall = bench::measure(
          [&] {
            fuser.fuse(views, poses, fs, kept);
            bench::do_not_optimize(kept.valid_pixels);
            const auto c = active_vision::target_center<float>(objects, conf, T, 0);
            bench::do_not_optimize(active_vision::plan_sensing_path<float>(c.point, 0.30f, A + d, B.translation() + d,
                                                                           ps.T_base_drop.translation() + d, ps.gamma, beta, 4));
          },
          opt.warmup, opt.trials);
      const auto fused_error = worst_error([&](std::size_t i) { return kept.views[i].T_base_view; });
      bench::JsonLine("cycle_fusion_icp").str("isa", isa).num("threads", threads).num("views", 4).num("width", wh[0]).num("height", wh[1])
          .str("output", "kept").str("strides", fs.stride_scale(wh[0]) > 1 ? "scaled" : "as_given").num("valid_fraction", double(valid) / (double(wh[0]) * wh[1]))
          .num("icp_iterations", icp_iterations).num("icp_inliers", icp_inliers)
          .num("kinematic_error_mm", kinematic_error.first).num("kinematic_error_deg", kinematic_error.second)
          .num("pose_error_mm", fused_error.first).num("pose_error_deg", fused_error.second)
          .num("last_registration_ms", kept.registration_ms).num("last_reprojection_ms", kept.reprojection_ms)
          .num("last_voting_ms", kept.voting_ms).stats(sf).print();
      bench::JsonLine("cycle_fusion_icp").str("isa", isa).num("threads", threads).num("views", 4).num("width", wh[0]).num("height", wh[1])
          .str("output", "new").stats(sf_new).print();
      if (fs.stride_scale(wh[0]) > 1) {  // the price of the strides scaled to the resolution: unscaled
        FusionSettings<float> full = fs;
        full.stride_width = 0;
        FusionResult<float> out;
        const auto sfull = bench::measure([&] { fuser.fuse(views, poses, full, out); }, opt.warmup, opt.trials);
        const auto full_error = worst_error([&](std::size_t i) { return out.views[i].T_base_view; });
        bench::JsonLine("cycle_fusion_icp").str("isa", isa).num("threads", threads).num("views", 4).num("width", wh[0]).num("height", wh[1])
            .str("output", "kept").str("strides", "as_given").num("pose_error_mm", full_error.first)
            .num("pose_error_deg", full_error.second).num("last_registration_ms", out.registration_ms).stats(sfull).print();
      }
      bench::JsonLine("cycle_planning").num("threads", threads).num("objects", double(objects.size())).stats(sp).print();
      bench::JsonLine("cycle_processing_without_estimation").str("isa", isa).num("threads", threads).num("views", 4).num("width", wh[0])
          .num("height", wh[1]).num("target_ms", 40).stats(sall).print();
    }
  }
  return 0;
}
