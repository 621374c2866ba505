// binpick_demo: renders a small synthetic scene from 4 poses on a short sensing arc, corrupts the views
// the way one-shot stereo fails on metal (dropouts, ghosts, noise), fuses them into view 1 and prints
// what it did. Usage: binpick_demo [--out DIR] [--seed N]
#include <chrono>
#include <cstdio>
#include <random>
#include <string>

#include "binpick/fusion.hpp"
#include "binpick/sim/box_scene.hpp"
#include "io.hpp"

using namespace binpick;

int main(int argc, char** argv) {
  std::string out_dir;
  unsigned seed = 1;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--out" && i + 1 < argc) out_dir = argv[++i];
    else if (a == "--seed" && i + 1 < argc) seed = unsigned(std::stoul(argv[++i]));
    else {
      std::fprintf(stderr, "usage: binpick_demo [--out DIR] [--seed N]\n");
      return 2;
    }
  }
  const int w = 640, h = 512;
  const PinholeCamera<float> camera(256.f, 256.f, (w - 1) * 0.5f, (h - 1) * 0.5f, w, h);  // ~75 x 50 cm at 0.3 m
  const sim::BoxScene scene = sim::boxes_scene();
  const auto poses = sim::arc_poses(4);
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.f, 0.0005f);
  std::uniform_real_distribution<float> unit(0.f, 1.f);

  std::vector<DepthImage<float>> truth, views;
  std::vector<Isometry3f> T_base_views;
  std::printf("binpick demo: %dx%d camera, 4 views on a %.0f mm arc 0.3 m above a floor with 3 boxes\n", w, h,
              0.3 * 0.12 * 1000);
  for (std::size_t i = 0; i < poses.size(); ++i) {
    truth.push_back(scene.render<float>(camera, poses[i]));
    DepthImage<float> v = truth.back();
    // View-dependent failures: a dropout blob and a ghost patch that move between views.
    const int cx = 200 + int(i) * 60, cy = 200 + int(i) * 20;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        float& d = v.at(x, y);
        if (d <= 0) continue;
        if ((x - cx) * (x - cx) + (y - cy) * (y - cy) < 50 * 50) d = 0;                 // specular dropout
        else if (std::abs(x - (420 - int(i) * 50)) < 15 && std::abs(y - 300) < 40) d -= 0.03f;  // ghost
        else if (unit(rng) < 0.05f) d = 0;                                                      // speckle
        else d += noise(rng);
      }
    std::printf("  view %zu: %zu of %d pixels valid\n", i + 1, v.valid_count(), w * h);
    views.push_back(std::move(v));
    T_base_views.push_back(poses[i].cast<float>());
  }
  std::vector<DepthImageView<float>> vv;
  for (const auto& v : views) vv.push_back(v.view());
  FusionSettings<float> s;
  s.sensor_accuracy = 0.001f;
  s.compute_votes = true;
  Fuser<float, PinholeCamera<float>> fuser(camera);
  const auto t0 = std::chrono::steady_clock::now();
  const auto r = fuser.fuse(vv, T_base_views, s);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();

  // Compare view 1 alone and the fusion against the true depth of view 1.
  auto score = [&](const DepthImage<float>& d, std::size_t& valid, std::size_t& wrong) {
    valid = wrong = 0;
    for (std::size_t k = 0; k < d.storage().size(); ++k) {
      const float x = d.storage()[k], t = truth[0].storage()[k];
      if (x <= 0 || t <= 0) continue;
      ++valid;
      wrong += std::abs(x - t) > 0.005f;
    }
  };
  std::size_t v1, w1, vf, wf;
  score(views[0], v1, w1);
  score(r.depth, vf, wf);
  std::printf("  view 1 alone : %zu valid pixels, %zu more than 5 mm off the truth\n", v1, w1);
  std::printf("  fused (Alg.1): %zu valid pixels, %zu more than 5 mm off the truth, %.1f ms\n", vf, wf, ms);
  if (!out_dir.empty()) {
    tools::Image16 png{w, h, std::vector<std::uint16_t>(std::size_t(w) * h)};
    for (std::size_t k = 0; k < png.pixels.size(); ++k) png.pixels[k] = std::uint16_t(std::lround(r.depth.storage()[k] * 1000.f));
    tools::write_png16(out_dir + "/demo_fused_mm.png", png);
    std::vector<std::uint8_t> votes(r.votes.votes.size());
    for (std::size_t k = 0; k < votes.size(); ++k) votes[k] = std::uint8_t(r.votes.votes[k] * 60);
    tools::write_png8(out_dir + "/demo_votes.png", w, h, votes);
    std::printf("  wrote %s/demo_fused_mm.png and %s/demo_votes.png\n", out_dir.c_str(), out_dir.c_str());
  }
  std::printf("{\"demo\": \"fusion\", \"views\": 4, \"valid_view1\": %zu, \"wrong_view1\": %zu, \"valid_fused\": %zu, "
              "\"wrong_fused\": %zu, \"fusion_ms\": %.3f}\n", v1, w1, vf, wf, ms);
  return 0;
}
