// binpick_fuse: fuses recorded depth views into the first one (or into a virtual view) and prints a
// one-line JSON summary. Poses are camera-to-world (or camera-to-base) 4x4 row-major text files.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "binpick/fusion.hpp"
#include "sim_instances.hpp"  // the simulated cell's templates, compiled once
#include "io.hpp"

namespace {

const char* kUsage = R"(usage: binpick_fuse --intrinsics fx,fy,cx,cy,width,height --depth-scale S
                    --view depth1.png pose1.txt [--view depth2.png pose2.txt ...]
                    --out fused.png [--votes votes.png] [--min-votes K]
                    [--accuracy A] [--delta D] [--target-pose P] [--threads N]
                    [--register on|off]

Fuses the depth views into ONE depth image of view 1 (paper Alg. 1): every other view is reprojected
into view 1 and each pixel keeps the depth most views agree on (within D).
  --intrinsics   pinhole intrinsics of the depth camera [px]
  --depth-scale  S: a PNG value v means v / S metres (1000 for millimetres)
  --view         a 16-bit single-channel PNG and its pose file; the first --view is the target
  pose files     16 numbers, a 4x4 row-major CAMERA-TO-WORLD (camera-to-base) transform, metres:
                 p_world = T * p_camera
  --out          fused depth, 16-bit PNG in the input's depth scale (0 = no measurement)
  --votes        votes per pixel, 8-bit PNG (a confidence map)
  --min-votes    fewer votes -> no measurement (default 1)
  --accuracy     sensor accuracy A in metres (default 0.001)
  --delta        voting threshold D in metres (default 2A)
  --target-pose  fuse all views into a virtual camera at this pose (camera-to-world file) that has no
                 depth of its own, e.g. to check a fusion against a frame left out of it
  --threads      threads (default 1, 0 = all cores)
  --register     on (default): register views 2..n to view 1 with point-to-plane ICP starting from
                 their poses, keeping a pose when ICP fails or corrects it by more than 3 cm / 5 deg
Prints one JSON line: valid pixels per view, per-view pose source and ICP status, RMSE [m] and
correction (translation [m], rotation [deg]), valid pixels after fusion, time.
)";

struct Args {
  std::string intrinsics, out, votes, target_pose;
  double depth_scale = 0, accuracy = 0.001, delta = 0;
  int min_votes = 1, threads = 1;
  bool register_views = true;
  std::vector<std::pair<std::string, std::string>> views;
};

[[noreturn]] void usage_error(const std::string& msg) {
  std::fprintf(stderr, "binpick_fuse: %s\n(run with --help for usage)\n", msg.c_str());
  std::exit(2);
}

Args parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) usage_error("missing value after " + k);
      return argv[++i];
    };
    if (k == "--help" || k == "-h") {
      std::fputs(kUsage, stdout);
      std::exit(0);
    } else if (k == "--intrinsics") a.intrinsics = value();
    else if (k == "--depth-scale") a.depth_scale = binpick::tools::parse_number(value(), "--depth-scale");
    else if (k == "--view") {
      const std::string depth = value();
      a.views.emplace_back(depth, value());
    } else if (k == "--out") a.out = value();
    else if (k == "--votes") a.votes = value();
    else if (k == "--min-votes") a.min_votes = int(binpick::tools::parse_number(value(), "--min-votes"));
    else if (k == "--accuracy") a.accuracy = binpick::tools::parse_number(value(), "--accuracy");
    else if (k == "--delta") a.delta = binpick::tools::parse_number(value(), "--delta");
    else if (k == "--target-pose") a.target_pose = value();
    else if (k == "--register") {
      const std::string v = value();
      if (v != "on" && v != "off") usage_error("--register takes on or off");
      a.register_views = v == "on";
    } else if (k == "--threads") a.threads = int(binpick::tools::parse_number(value(), "--threads"));
    else usage_error("unknown argument '" + k + "'");
  }
  if (a.intrinsics.empty()) usage_error("--intrinsics is required");
  if (!(a.depth_scale > 0)) usage_error("--depth-scale must be given and > 0");
  if (a.views.empty()) usage_error("at least one --view is required");
  if (a.out.empty()) usage_error("--out is required");
  if (!(a.accuracy > 0)) usage_error("--accuracy must be > 0");
  if (a.delta < 0) usage_error("--delta must be >= 0");
  if (a.min_votes < 1) usage_error("--min-votes must be >= 1");
  if (a.threads < 0) usage_error("--threads must be >= 0");
  return a;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace binpick;
  const Args args = parse(argc, argv);
  try {
    const tools::Intrinsics k = tools::parse_intrinsics(args.intrinsics);
    const PinholeCamera<float> camera(float(k.fx), float(k.fy), float(k.cx), float(k.cy), k.width, k.height);
    std::vector<tools::Image16> images;
    std::vector<DepthImageView<float>> views;
    std::vector<Isometry3f> T_world_views;
    for (const auto& [png, pose] : args.views) {
      images.push_back(tools::read_png16(png));
      const tools::Image16& im = images.back();
      if (im.width != k.width || im.height != k.height)
        throw std::runtime_error("'" + png + "' is " + std::to_string(im.width) + "x" + std::to_string(im.height) +
                                 " but --intrinsics say " + std::to_string(k.width) + "x" + std::to_string(k.height));
      T_world_views.push_back(tools::read_pose_file(pose).cast<float>());
    }
    for (const auto& im : images) views.emplace_back(im.pixels.data(), im.width, im.height, 0, float(1.0 / args.depth_scale));

    FusionSettings<float> s;
    s.sensor_accuracy = float(args.accuracy);
    s.delta = float(args.delta);
    s.min_votes = args.min_votes;
    s.compute_votes = !args.votes.empty();
    s.num_threads = args.threads;
    s.register_views = args.register_views;
    Fuser<float, PinholeCamera<float>> fuser(camera);
    const auto t0 = std::chrono::steady_clock::now();
    const FusionResult<float> r = args.target_pose.empty()
                                      ? fuser.fuse(views, T_world_views, s)
                                      : fuser.fuse_virtual(tools::read_pose_file(args.target_pose).cast<float>(), views,
                                                           T_world_views, s);
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();

    tools::Image16 out;
    out.width = k.width;
    out.height = k.height;
    out.pixels.resize(r.depth.storage().size());
    for (std::size_t i = 0; i < out.pixels.size(); ++i)
      out.pixels[i] = std::uint16_t(std::min(65535.0, std::round(double(r.depth.storage()[i]) * args.depth_scale)));
    tools::write_png16(args.out, out);
    if (!args.votes.empty()) tools::write_png8(args.votes, k.width, k.height, r.votes.votes);

    std::string json = "{\"tool\": \"binpick_fuse\", \"width\": " + std::to_string(k.width) +
                       ", \"height\": " + std::to_string(k.height) + ", \"views\": [";
    for (std::size_t i = 0; i < r.views.size(); ++i)
      json += std::string(i ? ", " : "") + "{\"depth\": " + tools::json_string(args.views[i].first) +
              ", \"valid_pixels\": " + std::to_string(r.views[i].valid_pixels) +
              ", \"pose\": " + tools::json_string(to_string(r.views[i].pose)) +
              (r.views[i].pose == ViewPose::reference || r.views[i].pose == ViewPose::kinematic
                   ? std::string()
                   : ", \"icp_status\": " + tools::json_string(to_string(r.views[i].icp_status)) +
                         ", \"icp_rmse_m\": " + tools::json_number(r.views[i].icp_rmse) +
                         ", \"icp_inliers\": " + std::to_string(r.views[i].icp_inliers) +
                         ", \"correction_m\": " + tools::json_number(r.views[i].correction_translation) +
                         ", \"correction_deg\": " + tools::json_number(r.views[i].correction_rotation * 180.0 / M_PI)) +
              "}";
    json += "], \"target\": " + std::string(args.target_pose.empty() ? "\"view1\"" : tools::json_string(args.target_pose));
    json += ", \"delta_m\": " + tools::json_number(s.effective_delta()) + ", \"min_votes\": " + std::to_string(s.min_votes);
    json += ", \"valid_pixels_fused\": " + std::to_string(r.valid_pixels) + ", \"time_ms\": " + tools::json_number(ms) + "}";
    std::puts(json.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "binpick_fuse: %s\n", e.what());
    return 1;
  }
  return 0;
}
