// bench_sim: time to render one simulated stereo frame of a bin of 20 shiny parts (ray casting over
// the scene's BVH plus the metal error model), at 1280x1024 and 640x512, 1 and 2 threads; also the
// exact-depth render (error model off) as a baseline of the ray caster alone, and the scene build.
#include <ctime>

#include "bench.hpp"

#include "binpick/sim.hpp"

using namespace binpick;

int main(int argc, char** argv) {
  auto opt = bench::parse_options(argc, argv);
  if (opt.trials > 7 && !opt.quick) opt.trials = 7;  // a frame takes a fraction of a second
  sim::SceneSettings<float> ss;
  ss.part_type = sim::PartType::mirror_nut;
  const auto scene = sim::Scene<float>::generate(ss, 1);
  {
    const auto s = bench::measure([&] { bench::do_not_optimize(sim::Scene<float>::generate(ss, 1)); }, 1, opt.trials);
    bench::JsonLine("sim_scene_generate").num("threads", 1).num("parts", 20).stats(s).print();
  }
  Isometry3f T = Isometry3f::Identity();
  T.linear() = Eigen::AngleAxisf(float(M_PI), Eigen::Vector3f::UnitX()).toRotationMatrix();  // looking down
  T.translation() = Eigen::Vector3f(0, 0, 0.30f);
  const int sizes[2][2] = {{1280, 1024}, {640, 512}};
  for (const auto& wh : sizes) {
    if (opt.quick && wh[0] == 1280) continue;
    for (const bool errors : {true, false}) {
      for (const int threads : opt.threads) {
        sim::StereoSensorSettings<float> s;
        s.width = wh[0];
        s.height = wh[1];
        s.num_threads = threads;
        s.errors.enabled = errors;
        const sim::StereoSensor<float> sensor(s);
        const auto geo = sim::SceneGeometry<float>::build(scene, s.errors.bin_material, s.errors.table_material);
        std::size_t valid = 0;
        // Process CPU time per frame as well: on a shared machine wall time also counts other jobs.
        const std::clock_t c0 = std::clock();
        const auto st = bench::measure([&] { valid = sensor.render(geo, T, 0).valid_pixels; }, opt.warmup > 0 ? 1 : 0, opt.trials);
        const double cpu_ms = 1000.0 * double(std::clock() - c0) / CLOCKS_PER_SEC / double(opt.trials + (opt.warmup > 0 ? 1 : 0));
        bench::JsonLine(errors ? "sim_render_frame" : "sim_render_exact_depth")
            .num("threads", threads)
            .num("width", wh[0])
            .num("height", wh[1])
            .num("triangles", double(geo.mesh.size()))
            .num("valid_fraction", double(valid) / (double(wh[0]) * wh[1]))
            .num("cpu_ms_per_frame", cpu_ms)
            .stats(st)
            .print();
      }
    }
  }
  return 0;
}
