// binpick_calibrate: the offline determination of the sensing path parameters (paper §III.D.2) in the
// simulated cell, for each part type:
//  - a fresh pile per repeat; the sensor is swept by the robot along a random great-circle path on the
//    upper part of a 1/8 sphere around the pile (radius = the best working distance, always facing
//    the centre; the octant's part below 45° elevation is left out: from there the walls hide the
//    pile), at each candidate speed v, capturing every 10 ms with late kinematic reads;
//  - "t is fixed to 10 ms since its data can propagate to 20…80 ms": the views for interval t and n
//    views are the captures 0, t/10, 2t/10, … — each (v, t, n) is fused (ICP + voting) and estimated;
//  - the recognized count is the criterion; active_vision::select_path_parameters applies steps
//    <1>–<3> and converts the chosen (v, t, n) to (α, β).
// Writes one line per type to --out FILE ("TYPE n t_ms v_percent alpha_deg beta_deg seconds"), read by
// binpick_sim --params, and prints a JSON object per type with the time it took. The default grid is
// reduced to finish in minutes; --paper runs the paper's (v ≤ 80 % every 10 %, t ≤ 80 ms every 10 ms,
// n ≤ 10, 10 repeats, 50 captures).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "binpick/active_vision.hpp"
#include "binpick/cycle.hpp"
#include "binpick/sim.hpp"
#include "binpick/sim/reference_estimator.hpp"
#include "binpick/sim/detail/random.hpp"
#include "sim_cell.hpp"  // the simulated cell (its templates compiled once) and the option helpers
#include "io.hpp"

using namespace binpick;
using binpick::tools::json_number;
using binpick::tools::json_string;

namespace {

int usage(const char* argv0) {
  std::fprintf(stderr,
               "usage: %s [--types all|NAME,...] [--out FILE] [--repeats R] [--speeds 40,60,80] [--intervals 30,60]\n"
               "          [--max-views N] [--parts P] [--seed S] [--paper] [--resolution 640x512|1280x1024]\n"
               "  Determines (n, t, v) and (alpha, beta) per part type in the simulated cell (paper III.D.2).\n",
               argv0);
  return 2;
}

std::vector<double> numbers(const std::string& s) {
  std::vector<double> v;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) v.push_back(std::stod(item));
  return v;
}

Isometry3f look_at(const Eigen::Vector3f& eye, const Eigen::Vector3f& target, const Eigen::Vector3f& x_hint) {
  const Eigen::Vector3f z = (target - eye).normalized();
  Eigen::Vector3f x = x_hint - x_hint.dot(z) * z;
  if (x.norm() < 1e-4f) x = z.unitOrthogonal();
  x.normalize();
  Isometry3f T = Isometry3f::Identity();
  T.linear().col(0) = x;
  T.linear().col(1) = z.cross(x);
  T.linear().col(2) = z;
  T.translation() = eye;
  return T;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<sim::PartType> types;
  std::string types_arg = "all", out;
  int repeats = 2, max_views = 5, parts = 20, width = 640, height = 512;
  std::vector<double> speeds{40, 60, 80}, intervals{30, 60};
  std::uint64_t seed = 1;
  try {
    for (tools::Args args(argc, argv); args.next();) {
      const std::string& a = args.flag();
      auto next = [&] { return args.value(); };
      if (a == "--types") types_arg = next();
      else if (a == "--out") out = next();
      else if (a == "--repeats") repeats = std::stoi(next());
      else if (a == "--speeds") speeds = numbers(next());
      else if (a == "--intervals") intervals = numbers(next());
      else if (a == "--max-views") max_views = std::stoi(next());
      else if (a == "--parts") parts = std::stoi(next());
      else if (a == "--seed") seed = std::stoull(next());
      else if (a == "--paper") {
        repeats = 10, max_views = 10, speeds = {10, 20, 30, 40, 50, 60, 70, 80}, intervals = {10, 20, 30, 40, 50, 60, 70, 80};
      } else if (a == "--resolution") {
        const std::string r = next();
        if (r == "640x512") width = 640, height = 512;
        else if (r == "1280x1024") width = 1280, height = 1024;
        else throw std::invalid_argument("--resolution must be 640x512 or 1280x1024");
      } else if (a == "--help" || a == "-h") return usage(argv[0]);
      else throw std::invalid_argument("unknown option " + a);
    }
    types = simcell::part_types(types_arg);
    if (repeats < 1 || max_views < 1 || max_views > 10 || speeds.empty() || intervals.empty()) throw std::invalid_argument("bad grid");
    for (double t : intervals)
      if (t < 10 || std::fmod(t, 10) != 0) throw std::invalid_argument("intervals must be multiples of 10 ms");
    for (double v : speeds)
      if (!(v > 0 && v <= 100)) throw std::invalid_argument("speeds must be in (0, 100]");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "binpick_calibrate: %s\n", e.what());
    return usage(argv[0]);
  }
  const float r = 0.30f;
  const double t_max = *std::max_element(intervals.begin(), intervals.end());
  const int captures = std::min(50, int(std::lround((max_views - 1) * t_max / 10)) + 1);  // the paper: 50 captures
  std::ofstream file;
  if (!out.empty()) {
    file.open(out);
    if (!file) {
      std::fprintf(stderr, "binpick_calibrate: cannot write '%s'\n", out.c_str());
      return 1;
    }
    file << "# type n t_ms v_percent alpha_deg beta_deg seconds  (binpick_calibrate, paper III.D.2, simulated cell)\n";
  }
  // A failure (e.g. too few trials for step <1>'s statistics with a tiny grid) ends the run with a
  // message and exit code 1, never an uncaught exception.
  try {
    for (const auto type : types) {
      const auto t_start = std::chrono::steady_clock::now();
      std::vector<active_vision::ParameterTrial<float>> trials;
      cycle::PipelineSettings<float> ps;
      const Isometry3f Tfc_inv = ps.T_flange_camera.inverse(Eigen::Isometry);
      for (int rep = 0; rep < repeats; ++rep) {
        sim::SceneSettings<float> ss;
        ss.part_type = type;
        ss.num_parts = parts;
        const std::uint64_t s = seed * 7919ULL + std::uint64_t(rep) * 104729ULL + std::uint64_t(int(type));
        const auto scene = sim::Scene<float>::generate(ss, s);
        const Eigen::Vector3f T(0, 0, 0.01f);
        // Random path on the octant: start at polar angle <= 45° and azimuth in [0, 90°], random heading.
        sim::detail::Rng rng(sim::detail::hash_keys(s, 0xca11bULL));
        const float pol = float(rng.uniform(0, M_PI / 4)), az = float(rng.uniform(0, M_PI / 2)), head = float(rng.uniform(0, 2 * M_PI));
        const Eigen::Vector3f dir0(std::sin(pol) * std::cos(az), std::sin(pol) * std::sin(az), std::cos(pol));
        const Eigen::Vector3f e1 = dir0.unitOrthogonal(), e2 = dir0.cross(e1);
        const Eigen::Vector3f tangent = std::cos(head) * e1 + std::sin(head) * e2;
        const Eigen::Vector3f axis = dir0.cross(tangent).normalized();
        sim::ReferenceEstimatorSettings<float> es;
        sim::ReferenceEstimator<float, PinholeCamera<float>> estimator(scene.model(type), es);
        for (double v : speeds) {
          sim::SimClock clock;
          sim::FakeRobotSettings<float> rs;
          rs.seed = s;
          auto pose_at = [&](double arc_len) {
            const Eigen::Vector3f d = Eigen::AngleAxisf(float(arc_len / r), axis) * dir0;
            return look_at(T + r * d, T, tangent);
          };
          sim::FakeRobot<float> robot(clock, pose_at(0) * Tfc_inv, rs);
          sim::StereoSensorSettings<float> st;
          st.width = width;
          st.height = height;
          st.seed = s;
          sim::FakeSensor<float> sensor(scene, robot, clock, ps.T_flange_camera, st);
          const double speed = v / 100.0;  // 100 % ≈ 1 m/s
          std::vector<Isometry3f> path;
          for (int k = 1; k < captures; ++k) path.push_back(pose_at(speed * 0.010 * k) * Tfc_inv);
          std::vector<Isometry3f> read;
          sensor.trigger();  // at rest
          read.push_back(robot.read_flange_pose().T_base_flange * ps.T_flange_camera);
          const double t0 = clock.now();
          if (!path.empty()) robot.move_along(path, float(v));
          for (int k = 1; k < captures; ++k) {
            clock.sleep_until(t0 + 0.010 * k);
            sensor.trigger();
            read.push_back(robot.read_flange_pose().T_base_flange * ps.T_flange_camera);
          }
          const auto frames = sensor.read_frames();
          Fuser<float, PinholeCamera<float>> fuser(sensor.camera());
          FusionSettings<float> fs = ps.fusion;
          fs.sensor_accuracy = sensor.accuracy();
          for (double t : intervals) {
            const int stride = int(std::lround(t / 10));
            for (int n = 1; n <= max_views; ++n) {
              if ((n - 1) * stride >= captures) break;
              std::vector<DepthImageView<float>> views;
              std::vector<Isometry3f> poses;
              for (int i = 0; i < n; ++i) views.push_back(frames[std::size_t(i * stride)].depth.view()), poses.push_back(read[std::size_t(i * stride)]);
              const auto fused = fuser.fuse(views, poses, fs);
              cycle::EstimatorInput<float, PinholeCamera<float>> in;
              in.depth = fused.depth.view();
              in.votes = fused.votes.votes.empty() ? nullptr : fused.votes.votes.data();
              in.camera = &sensor.camera();
              const auto est = estimator.estimate(in);
              active_vision::ParameterTrial<float> trial;
              trial.speed = float(speed);
              trial.interval = float(t * 1e-3);
              trial.num_views = n;
              trial.recognized = float(est.objects.size());
              trials.push_back(trial);
            }
          }
          std::fprintf(stderr, "  %s repeat %d v %g%%: %zu trials so far\n", sim::part_type_name(type), rep, v, trials.size());
        }
      }
      // n = 1 has no path: select over n >= 2 (the table keeps them for the statistics of step <1>).
      std::vector<active_vision::ParameterTrial<float>> multi;
      for (const auto& tr : trials)
        if (tr.num_views >= 2) multi.push_back(tr);
      const auto sel = active_vision::select_path_parameters<float>(multi, r);
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
      const int n = sel.motion.num_views;
      const double t_ms = std::round(double(sel.motion.interval) * 1e3), v_pct = std::round(double(sel.motion.speed) * 1000) / 10;
      const double a_deg = std::round(double(sel.angles.alpha) * 180 / M_PI * 1000) / 1000,
                   b_deg = std::round(double(sel.angles.beta) * 180 / M_PI * 1000) / 1000;
      std::printf("{\"type\": %s, \"status\": %s, \"views\": %d, \"interval_ms\": %s, \"speed_percent\": %s, \"alpha_deg\": %s, "
                  "\"beta_deg\": %s, \"mean_recognized\": %s, \"sigma\": %s, \"trials\": %zu, \"trials_in_band\": %zu, \"seconds\": %s}\n",
                  json_string(sim::part_type_name(type)).c_str(), json_string(sel.ok() ? "ok" : "no_selection").c_str(), n,
                  json_number(t_ms).c_str(), json_number(v_pct).c_str(), json_number(a_deg).c_str(), json_number(b_deg).c_str(),
                  json_number(double(sel.mean)).c_str(), json_number(double(sel.sigma)).c_str(), trials.size(), sel.trials_in_band,
                  json_number(seconds).c_str());
      std::fflush(stdout);
      if (file && sel.ok())
        file << sim::part_type_name(type) << " " << n << " " << t_ms << " " << v_pct << " " << a_deg << " " << b_deg << " " << seconds << "\n";
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "binpick_calibrate: %s\n", e.what());
    return 1;
  }
  return 0;
}
