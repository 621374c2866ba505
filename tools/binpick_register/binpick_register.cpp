// binpick_register: registers a source point cloud to a target with ICP and prints one JSON line.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>

#include "binpick/registration.hpp"
#include "cloud_io.hpp"
#include "io.hpp"

namespace {

const char* kUsage =
    "usage: binpick_register SOURCE TARGET [options]\n"
    "  Registers SOURCE to TARGET (PLY or PCD; ascii or binary; x y z, optional normals; metres) with\n"
    "  ICP and prints one JSON line: the 4x4 row-major T_target_source (maps source points into the\n"
    "  target frame), status, rmse [m], inliers, iterations, time_ms (normals + association + ICP,\n"
    "  file reading excluded).\n"
    "options:\n"
    "  --init FILE          initial T_target_source, 16 numbers row-major (default identity)\n"
    "  --method M           point-to-plane (default) | point-to-point\n"
    "  --max-distance D     maximum correspondence distance [m] (default 0.02)\n"
    "  --iterations K       maximum iterations (default 30)\n"
    "  --association A      knn (default) | projective\n"
    "  --intrinsics F       fx,fy,cx,cy of the target camera [px]; required by projective, which also\n"
    "                       needs an organized target (a PCD with HEIGHT > 1, points in that camera's\n"
    "                       frame); unorganized targets are refused with an error\n"
    "  --kernel K           tukey (default) | huber | none\n"
    "  --kernel-scale S     robust kernel scale [m] (default 0.01)\n"
    "  --max-normal-angle A [deg] with source normals in the file, reject pairs whose normals differ\n"
    "                       more (default 14.3; 180 disables: needed when the initial pose is far off)\n"
    "  --stride S           use every S-th source point (default 1)\n"
    "  --threads N          threads (default 0 = all cores)\n"
    "exit status: 0 converged or degenerate (pose usable), 3 other ICP statuses (the JSON line is still\n"
    "printed), 1 unreadable/malformed input, 2 bad command line.\n";

[[noreturn]] void usage_error(const std::string& msg) {
  std::fprintf(stderr, "binpick_register: %s\n%s", msg.c_str(), kUsage);
  std::exit(2);
}

int parse_int(const std::string& text, const std::string& name, int lo, int hi) {
  const double v = binpick::tools::parse_number(text, name);
  if (!(v >= lo && v <= hi) || v != double(long(v)))
    throw std::runtime_error("'" + name + "' must be an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  return int(v);
}

binpick::PointCloud<double> to_cloud(const binpick::tools::CloudFile& f) {
  binpick::PointCloud<double> c;
  c.points = f.points;
  if (!f.normals.empty()) {
    c.normals = f.normals;
    for (auto& n : c.normals) {  // file normals: unit, or zero when unusable
      const double len = n.norm();
      n = (std::isfinite(len) && len > 1e-9) ? Eigen::Vector3d(n / len) : Eigen::Vector3d::Zero();
    }
  }
  return c;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace binpick;
  std::vector<std::string> positional;
  std::string init_path, method = "point-to-plane", association = "knn", intrinsics;
  std::string max_distance_text, iterations_text, stride_text, threads_text, kernel = "tukey", kernel_scale_text,
      normal_angle_text;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) usage_error("missing value after " + a);
      return argv[++i];
    };
    if (a == "--help" || a == "-h") {
      std::printf("%s", kUsage);
      return 0;
    } else if (a == "--init") init_path = value();
    else if (a == "--method") method = value();
    else if (a == "--max-distance") max_distance_text = value();
    else if (a == "--iterations") iterations_text = value();
    else if (a == "--association") association = value();
    else if (a == "--intrinsics") intrinsics = value();
    else if (a == "--stride") stride_text = value();
    else if (a == "--kernel") kernel = value();
    else if (a == "--kernel-scale") kernel_scale_text = value();
    else if (a == "--max-normal-angle") normal_angle_text = value();
    else if (a == "--threads") threads_text = value();
    else if (!a.empty() && a[0] == '-') usage_error("unknown option " + a);
    else positional.push_back(a);
  }
  if (positional.size() != 2) usage_error("expected SOURCE and TARGET");
  if (method != "point-to-plane" && method != "point-to-point") usage_error("--method must be point-to-plane or point-to-point");
  if (association != "knn" && association != "projective") usage_error("--association must be knn or projective");
  if (kernel != "tukey" && kernel != "huber" && kernel != "none") usage_error("--kernel must be tukey, huber or none");

  try {
    IcpSettings<double> s;
    s.method = method == "point-to-plane" ? IcpMethod::point_to_plane : IcpMethod::point_to_point;
    if (!max_distance_text.empty()) {
      s.max_correspondence_distance = tools::parse_number(max_distance_text, "--max-distance");
      if (!(s.max_correspondence_distance > 0)) throw std::runtime_error("'--max-distance' must be > 0");
    }
    s.kernel = kernel == "tukey" ? RobustKernel::tukey : kernel == "huber" ? RobustKernel::huber : RobustKernel::none;
    if (!kernel_scale_text.empty()) {
      s.kernel_scale = tools::parse_number(kernel_scale_text, "--kernel-scale");
      if (!(s.kernel_scale > 0)) throw std::runtime_error("'--kernel-scale' must be > 0");
    }
    if (!normal_angle_text.empty()) {
      const double deg = tools::parse_number(normal_angle_text, "--max-normal-angle");
      if (!(deg > 0 && deg <= 180)) throw std::runtime_error("'--max-normal-angle' must be in (0, 180]");
      s.max_normal_angle = deg * M_PI / 180;
    }
    if (!iterations_text.empty()) s.max_iterations = parse_int(iterations_text, "--iterations", 1, 100000);
    if (!stride_text.empty()) s.stride = parse_int(stride_text, "--stride", 1, 1 << 20);
    if (!threads_text.empty()) s.num_threads = parse_int(threads_text, "--threads", 0, 1024);
    const Eigen::Isometry3d init = init_path.empty() ? Eigen::Isometry3d::Identity() : tools::read_pose_file(init_path);

    const tools::CloudFile source_file = tools::read_cloud(positional[0]);
    const tools::CloudFile target_file = tools::read_cloud(positional[1]);
    const PointCloud<double> source = to_cloud(source_file);
    const bool plane = s.method == IcpMethod::point_to_plane;

    const auto t0 = std::chrono::steady_clock::now();
    IcpResult<double> r;
    if (association == "knn") {
      PointCloud<double> target = to_cloud(target_file);
      if (plane && !target.has_normals()) {
        KnnNormalSettings<double> ns;  // toward the origin: the sensor of a camera-frame cloud
        ns.num_threads = s.num_threads;
        target.normals = estimate_knn_normals(target.points, ns);
      }
      const KnnAssociation<double> knn(std::move(target));
      r = icp(source, knn, init, s);
    } else {
      if (intrinsics.empty()) throw std::runtime_error("projective association needs --intrinsics fx,fy,cx,cy");
      if (!target_file.organized())
        throw std::runtime_error("'" + positional[1] + "': projective association needs an organized target (PCD with HEIGHT > 1)");
      const tools::Intrinsics k = tools::parse_intrinsics(intrinsics + "," + std::to_string(target_file.width) + "," +
                                                          std::to_string(target_file.height));
      const PinholeCamera<double> camera(k.fx, k.fy, k.cx, k.cy, k.width, k.height);
      OrganizedCloud<double> org;
      org.width = target_file.width;
      org.height = target_file.height;
      org.points = target_file.points;
      for (auto& p : org.points)
        if (!p.allFinite() || !(p.z() > 0)) p.setZero();  // no measurement
      OrganizedNormalSettings<double> ns;
      ns.num_threads = s.num_threads;
      estimate_organized_normals(org, ns);
      const ProjectiveAssociation<double, PinholeCamera<double>> proj(std::move(org), camera);
      r = icp(source, proj, init, s);
    }
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();

    std::string m;
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) m += (m.empty() ? "" : ", ") + tools::json_number(r.T_target_source.matrix()(i, j));
    std::printf("{\"T_target_source\": [%s], \"status\": %s, \"rmse\": %s, \"inliers\": %zu, \"iterations\": %d, "
                "\"degenerate_directions\": %d, \"time_ms\": %s}\n",
                m.c_str(), tools::json_string(to_string(r.status)).c_str(), tools::json_number(r.rmse).c_str(), r.inliers,
                r.iterations, r.degenerate_directions, tools::json_number(ms).c_str());
    return r.ok() ? 0 : 3;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "binpick_register: error: %s\n", e.what());
    return 1;
  }
}
