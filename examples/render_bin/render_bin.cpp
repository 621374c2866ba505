// render_bin: a simulated bin of shiny parts seen from 4 close views on a short arc, as the paper's
// sensing path captures them (§III.A, §III.C). Writes per view
//   depth_<k>.png    16-bit depth [mm], 0 = no measurement
//   pose_<k>.txt     T_base_camera: 4x4 row-major, camera-to-base, metres (the binpick_fuse format)
//   dropout_<k>.png  255 where a surface is in range but the sensor reports nothing
// plus intrinsics.txt ("fx,fy,cx,cy,width,height"), and prints the valid-pixel fraction of each view
// and of their union (all views' valid points reprojected into view 0). All figures are simulated.
//
//   render_bin --out DIR [--seed N] [--part small_screw|lan_connector|mirror_nut|pencil_coupler|circle_nut]
//              [--small] [--step-deg 4] [--threads N]
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <sys/stat.h>

#include "binpick/sim.hpp"
#include "io.hpp"

using namespace binpick;

namespace {

// Camera at `eye` looking at `target`, image x along base +x where possible (camera: x right,
// y down, z forward).
Isometry3f look_at(const Eigen::Vector3f& eye, const Eigen::Vector3f& target) {
  return camera_looking_at<float>(eye, target, Eigen::Vector3f::UnitY());
}

void write_pose(const std::string& path, const Isometry3f& T) {
  FILE* f = std::fopen(path.c_str(), "w");
  if (!f) throw std::runtime_error("cannot write '" + path + "'");
  std::fprintf(f, "# T_base_camera (camera-to-base), 4x4 row-major, metres\n");
  for (int r = 0; r < 4; ++r)
    std::fprintf(f, "%.9g %.9g %.9g %.9g\n", double(T.matrix()(r, 0)), double(T.matrix()(r, 1)), double(T.matrix()(r, 2)),
                 double(T.matrix()(r, 3)));
  std::fclose(f);
}

int usage(const char* argv0) {
  std::fprintf(stderr,
               "usage: %s --out DIR [--seed N] [--part NAME] [--small] [--step-deg DEG] [--threads N]\n"
               "  Renders a simulated bin of 20 shiny parts from 4 views on a 30 cm arc and writes depth_<k>.png\n"
               "  (16-bit mm), pose_<k>.txt (T_base_camera: camera-to-base, 4x4 row-major, metres), dropout_<k>.png\n"
               "  and intrinsics.txt. --small renders 640x512 instead of 1280x1024.\n",
               argv0);
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::string out;
  std::uint64_t seed = 1;
  std::string part = "mirror_nut";
  bool small = false;
  float step_deg = 4.0f;
  int threads = 1;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) std::exit(usage(argv[0]));
      return argv[++i];
    };
    if (a == "--out") out = next();
    else if (a == "--seed") seed = std::strtoull(next().c_str(), nullptr, 10);
    else if (a == "--part") part = next();
    else if (a == "--small") small = true;
    else if (a == "--step-deg") step_deg = std::strtof(next().c_str(), nullptr);
    else if (a == "--threads") threads = std::atoi(next().c_str());
    else return usage(argv[0]);
  }
  if (out.empty()) return usage(argv[0]);
  try {
    ::mkdir(out.c_str(), 0755);
    sim::SceneSettings<float> scene_settings;
    scene_settings.part_type = sim::part_type_from_name(part);
    const auto scene = sim::Scene<float>::generate(scene_settings, seed);

    sim::StereoSensorSettings<float> ss;
    if (small) ss.width = 640, ss.height = 512;
    ss.seed = seed;
    ss.num_threads = threads;
    ss.diagnostics = true;
    const sim::StereoSensor<float> sensor(ss);
    const auto geometry = sim::SceneGeometry<float>::build(scene, ss.errors.bin_material, ss.errors.table_material);
    const auto& cam = sensor.camera();
    {
      FILE* f = std::fopen((out + "/intrinsics.txt").c_str(), "w");
      if (!f) throw std::runtime_error("cannot write intrinsics.txt");
      std::fprintf(f, "%.9g,%.9g,%.9g,%.9g,%d,%d\n", double(cam.fx()), double(cam.fy()), double(cam.cx()), double(cam.cy()),
                   cam.width(), cam.height());
      std::fclose(f);
    }

    // 4 views on an arc of radius 0.30 m about the bin centre, in the x–z plane, step_deg apart.
    const Eigen::Vector3f target(0, 0, 0.01f);
    const int W = cam.width(), H = cam.height();
    std::vector<std::uint8_t> covered(std::size_t(W) * std::size_t(H), 0);
    std::vector<sim::StereoFrame<float>> frames;
    for (int k = 0; k < 4; ++k) {
      const float phi = float((-1.5f + float(k)) * step_deg * M_PI / 180.0);
      const Eigen::Vector3f eye = target + 0.30f * Eigen::Vector3f(std::sin(phi), 0, std::cos(phi));
      frames.push_back(sensor.render(geometry, look_at(eye, target), std::uint64_t(k)));
      const auto& fr = frames.back();
      tools::Image16 img;
      img.width = W;
      img.height = H;
      img.pixels.resize(std::size_t(W) * std::size_t(H));
      std::vector<std::uint8_t> dropout(img.pixels.size());
      for (std::size_t i = 0; i < img.pixels.size(); ++i) {
        const float z = fr.depth.data()[i];
        img.pixels[i] = z > 0 ? std::uint16_t(std::min(65535.0f, std::round(z * 1000.0f))) : 0;
        dropout[i] = (fr.true_depth.data()[i] > 0 && !(z > 0)) ? 255 : 0;
      }
      tools::write_png16(out + "/depth_" + std::to_string(k) + ".png", img);
      tools::write_png8(out + "/dropout_" + std::to_string(k) + ".png", W, H, dropout);
      write_pose(out + "/pose_" + std::to_string(k) + ".txt", fr.T_base_camera);
      std::size_t counts[16] = {0}, part_counts[16] = {0};
      for (std::size_t i = 0; i < fr.status.size(); ++i) {
        ++counts[int(fr.status[i])];
        if (fr.part_index[i] >= 0) ++part_counts[int(fr.status[i])];
      }
      std::size_t correct_part = 0;
      for (std::size_t i = 0; i < fr.status.size(); ++i)
        correct_part += fr.part_index[i] >= 0 && fr.depth.data()[i] > 0 &&
                        std::abs(fr.depth.data()[i] - fr.true_depth.data()[i]) < 0.003f;
      std::printf("view %d: valid %.3f of surface pixels, %.3f of part pixels (%.3f within 3 mm); ghosts %zu, "
                  "outliers (>2 mm) %zu\n",
                  k, double(fr.valid_pixels) / double(std::max<std::size_t>(1, fr.surface_pixels)),
                  double(fr.valid_part_pixels) / double(std::max<std::size_t>(1, fr.part_pixels)),
                  double(correct_part) / double(std::max<std::size_t>(1, fr.part_pixels)), fr.ghost_pixels,
                  fr.outlier_pixels);
      std::printf("  status:");
      const char* names[] = {"valid", "no_surface", "occluded_right", "outside_right", "shadowed", "saturated",
                             "bloom", "too_dark", "lr_mismatch", "ghost", "curved_reflection", "edge_fg", "edge_mix",
                             "edge_hole", "speckle_filtered"};
      for (int s = 0; s < 15; ++s)
        if (counts[s]) std::printf(" %s=%zu", names[s], counts[s]);
      std::printf("\n  on parts:");
      for (int s = 0; s < 15; ++s)
        if (part_counts[s]) std::printf(" %s=%zu", names[s], part_counts[s]);
      std::printf("\n");
    }

    // Union: every view's valid points reprojected into view 0; a view-0 surface pixel counts as covered
    // when some view measured a point within 3 mm of its true depth there.
    const Isometry3f T0_inv = frames[0].T_base_camera.inverse();
    std::size_t surface0 = 0, part0 = 0;
    std::vector<std::uint8_t> covered_by_one(covered.size(), 0);
    for (const auto& fr : frames) {
      const Isometry3f T_0_k = T0_inv * fr.T_base_camera;
      for (int v = 0; v < H; ++v)
        for (int u = 0; u < W; ++u) {
          const float z = fr.depth.at(u, v);
          if (!(z > 0)) continue;
          const Eigen::Vector3f p0 = T_0_k * cam.backproject(float(u), float(v), z);
          const auto px = cam.project(p0);
          if (!px) continue;
          const int u0 = int(std::lround(px->x())), v0 = int(std::lround(px->y()));
          const float zt = frames[0].true_depth.at(u0, v0);
          if (zt > 0 && std::abs(zt - p0.z()) < 0.003f) covered[std::size_t(v0) * std::size_t(W) + std::size_t(u0)] = 1;
        }
    }
    std::size_t cov = 0, cov_part = 0;
    for (std::size_t i = 0; i < covered.size(); ++i) {
      if (!(frames[0].true_depth.data()[i] > 0)) continue;
      ++surface0;
      cov += covered[i];
      if (frames[0].part_index[i] >= 0) {
        ++part0;
        cov_part += covered[i];
      }
    }
    std::printf("union of 4 views (in view 0, within 3 mm): valid %.3f of surface pixels, %.3f of part pixels (simulated)\n",
                double(cov) / double(std::max<std::size_t>(1, surface0)), double(cov_part) / double(std::max<std::size_t>(1, part0)));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "render_bin: %s\n", e.what());
    return 1;
  }
  return 0;
}
