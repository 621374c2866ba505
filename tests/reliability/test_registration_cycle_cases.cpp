// Bad-input cases of the modules later in the chain: registration (ICP, normals, associations,
// align_depth_view(s)) and the picking cycle's settings. Each part is compiled when its headers exist.
#include <limits>
#include <string>
#include <vector>

#include "binpick/core.hpp"
#include "matrix.hpp"
#include "synthetic_views.hpp"

#if __has_include("binpick/registration/icp.hpp")
#include "binpick/registration.hpp"
#define BINPICK_RELIABILITY_REGISTRATION 1
#endif
#if __has_include("binpick/cycle/pipeline.hpp")
#include "binpick/cycle/pipeline.hpp"
#include "binpick/sim/sim_clock.hpp"
#define BINPICK_RELIABILITY_CYCLE 1
#endif

namespace binpick::reliability {

#ifdef BINPICK_RELIABILITY_REGISTRATION
namespace {

template <typename Scalar>
Outcome icp_outcome(const IcpResult<Scalar>& r) {
  Outcome o;
  o.status = to_string(r.status);
  o.add(r.T_target_source.matrix()).add(r.rmse);
  return o;
}

template <typename Scalar>
void registration_cases(Matrix& m) {
  using V3 = Vector3<Scalar>;
  const auto s = make_synthetic_views<Scalar>(2, 3);
  const auto cam = s.camera;
  const std::vector<Scalar> d0 = s.depth[0], d1 = s.depth[1];
  const Isometry3<Scalar> prior = s.T_base_views[0].inverse(Eigen::Isometry) * s.T_base_views[1];
  const int w = cam.width(), h = cam.height();
  IcpSettings<Scalar> base;
  base.num_threads = 1;
  auto align = [=](const std::vector<Scalar>& src, const std::vector<Scalar>& tgt, const Isometry3<Scalar>& init,
                   const IcpSettings<Scalar>& st) {
    return align_depth_views(DepthImageView<Scalar>(src.data(), w, h), cam, DepthImageView<Scalar>(tgt.data(), w, h), cam, init, st);
  };
  // Good input: a usable result (converged, or the last iterate after max_iterations).
  m.gives("align_depth_views good", "usable", [=] {
    Outcome o = icp_outcome(align(d1, d0, prior, base));
    if (o.status == "converged" || o.status == "max_iterations") o.status = "usable";
    return o;
  });
  m.throws("align_depth_views size mismatch", "depth", [=] {
    const std::vector<Scalar> small(16, Scalar(0.5));
    align_depth_views(DepthImageView<Scalar>(small.data(), 4, 4), cam, DepthImageView<Scalar>(d0.data(), w, h), cam, prior, base);
    return Outcome{};
  });
  for (const auto& [name, v] : Bad<Scalar>::depths()) {
    if (v > Scalar(0) && v < Bad<Scalar>::inf()) continue;
    m.gives("align_depth_views source all " + name, "too_few_correspondences", [=, v = v] {
      return icp_outcome(align(std::vector<Scalar>(d1.size(), v), d0, prior, base));
    });
    m.gives("align_depth_views target all " + name, "too_few_correspondences", [=, v = v] {
      return icp_outcome(align(d1, std::vector<Scalar>(d0.size(), v), prior, base));
    });
  }
  m.gives("align_depth_views source 1e30 m away", "too_few_correspondences", [=] {
    return icp_outcome(align(std::vector<Scalar>(d1.size(), Bad<Scalar>::huge()), d0, prior, base));
  });
  m.gives("align_depth_views identical views", "converged", [=] {
    return icp_outcome(align(d0, d0, Isometry3<Scalar>::Identity(), base));
  });
  for (const auto& [name, T] : std::vector<std::pair<std::string, Isometry3<Scalar>>>{
           {"nan", [] { Isometry3<Scalar> T = Isometry3<Scalar>::Identity(); T(0, 3) = Bad<Scalar>::nan(); return T; }()},
           {"scaled", [] { Isometry3<Scalar> T = Isometry3<Scalar>::Identity(); T.linear() *= Scalar(1.1); return T; }()}})
    m.throws("align_depth_views init " + name, "T_target_source_init", [=, T = T] { align(d1, d0, T, base); return Outcome{}; });
  m.gives("align_depth_views init 1e30 away", "too_few_correspondences", [=] {
    Isometry3<Scalar> T = prior;
    T.translation().x() += Bad<Scalar>::huge();
    return icp_outcome(align(d1, d0, T, base));
  });
  struct SettingCase { std::string arg; std::function<void(IcpSettings<Scalar>&, Scalar)> set; };
  const std::vector<SettingCase> settings = {
      {"max_correspondence_distance", [](IcpSettings<Scalar>& st, Scalar v) { st.max_correspondence_distance = v; }},
      {"kernel_scale", [](IcpSettings<Scalar>& st, Scalar v) { st.kernel_scale = v; }},
      {"max_normal_angle", [](IcpSettings<Scalar>& st, Scalar v) { st.max_normal_angle = v; }},
  };
  for (const auto& sc : settings)
    for (const auto& [name, v] : Bad<Scalar>::non_positive())
      m.throws("icp " + sc.arg + " " + name, sc.arg, [=, v = v] {
        IcpSettings<Scalar> st = base;
        sc.set(st, v);
        align(d1, d0, prior, st);
        return Outcome{};
      });
  for (const auto& [name, v] : Bad<Scalar>::non_finite())
    m.throws("icp rotation_epsilon " + name, "rotation_epsilon", [=, v = v] {
      IcpSettings<Scalar> st = base;
      st.rotation_epsilon = v;
      align(d1, d0, prior, st);
      return Outcome{};
    });
  m.throws("icp max_iterations 0", "max_iterations", [=] { IcpSettings<Scalar> st = base; st.max_iterations = 0; align(d1, d0, prior, st); return Outcome{}; });
  m.throws("icp stride 0", "stride", [=] { IcpSettings<Scalar> st = base; st.stride = 0; align(d1, d0, prior, st); return Outcome{}; });
  m.throws("icp num_threads -1", "num_threads", [=] { IcpSettings<Scalar> st = base; st.num_threads = -1; align(d1, d0, prior, st); return Outcome{}; });
  m.throws("icp degeneracy_threshold 1", "degeneracy_threshold",
           [=] { IcpSettings<Scalar> st = base; st.degeneracy_threshold = 1; align(d1, d0, prior, st); return Outcome{}; });
  // Point clouds through the kNN association.
  const PointCloud<Scalar> target = backproject_points(DepthImageView<Scalar>(d0.data(), w, h), cam, 2);
  auto knn_icp = [=](const std::vector<V3>& src, IcpMethod method) {
    PointCloud<Scalar> t = target;
    t.normals = estimate_knn_normals(t.points, KnnNormalSettings<Scalar>{});
    KnnAssociation<Scalar> assoc(t);
    IcpSettings<Scalar> st = base;
    st.method = method;
    return icp_outcome(icp(src, assoc, Isometry3<Scalar>::Identity(), st));
  };
  for (IcpMethod method : {IcpMethod::point_to_plane, IcpMethod::point_to_point}) {
    const std::string mn = method == IcpMethod::point_to_plane ? " (plane)" : " (point)";
    m.gives("icp empty source" + mn, "too_few_correspondences", [=] { return knn_icp({}, method); });
    m.gives("icp 5 points" + mn, "too_few_correspondences", [=] {
      return knn_icp(std::vector<V3>(target.points.begin(), target.points.begin() + 5), method);
    });
    m.gives("icp all-NaN source" + mn, "too_few_correspondences", [=] {
      return knn_icp(std::vector<V3>(100, V3::Constant(Bad<Scalar>::nan())), method);
    });
    m.gives("icp 1e30 source" + mn, "too_few_correspondences", [=] {
      return knn_icp(std::vector<V3>(100, V3::Constant(Bad<Scalar>::huge())), method);
    });
    // Both methods detect the unobservable directions (icp.hpp): one plane of normals for
    // point-to-plane, every rotation about coincident points for point-to-point.
    m.gives("icp one point repeated" + mn, "degenerate", [=] {
      return knn_icp(std::vector<V3>(100, target.points[target.points.size() / 2]), method);
    });
  }
  m.throws("icp plane without target normals", "association", [=] {
    KnnAssociation<Scalar> assoc(target);
    icp(target.points, assoc, Isometry3<Scalar>::Identity(), base);
    return Outcome{};
  });
  m.throws("knn association normals mismatch", "target", [=] {
    PointCloud<Scalar> t = target;
    t.normals.resize(3);
    KnnAssociation<Scalar> assoc(t);
    return Outcome{};
  });
  m.throws("knn normals k 2", "k", [=] { KnnNormalSettings<Scalar> ks; ks.k = 2; estimate_knn_normals(target.points, ks); return Outcome{}; });
  m.gives("knn normals with NaN, 1e30 and duplicate points", "ok", [=] {
    std::vector<V3> pts(target.points.begin(), target.points.begin() + 200);
    pts[3] = V3::Constant(Bad<Scalar>::nan());
    pts[4] = V3::Constant(Bad<Scalar>::huge());
    for (int i = 10; i < 40; ++i) pts[std::size_t(i)] = pts[9];
    Outcome o;
    for (const auto& n : estimate_knn_normals(pts, KnnNormalSettings<Scalar>{})) o.add(n);
    return o;
  });
  m.gives("knn normals of 2 points", "ok", [] {
    Outcome o;
    for (const auto& n : estimate_knn_normals(std::vector<V3>{V3::Zero(), V3::UnitX()}, KnnNormalSettings<Scalar>{})) o.add(n);
    return o;
  });
  m.throws("organized normals pixel_offset 0", "pixel_offset", [=] {
    OrganizedCloud<Scalar> c = backproject_organized(DepthImageView<Scalar>(d0.data(), w, h), cam);
    OrganizedNormalSettings<Scalar> ns;
    ns.pixel_offset = 0;
    estimate_organized_normals(c, ns);
    return Outcome{};
  });
  m.gives("organized normals of all-invalid depth", "ok", [=] {
    const std::vector<Scalar> z(d0.size(), Bad<Scalar>::nan());
    OrganizedCloud<Scalar> c = backproject_organized(DepthImageView<Scalar>(z.data(), w, h), cam);
    estimate_organized_normals(c, OrganizedNormalSettings<Scalar>{});
    Outcome o;
    for (const auto& n : c.normals) o.add(n);
    return o;
  });
  m.throws("backproject stride 0", "stride", [=] { backproject_points(DepthImageView<Scalar>(d0.data(), w, h), cam, 0); return Outcome{}; });
}

}  // namespace
#endif

void add_registration_cases(std::vector<Case>& out) {
#ifdef BINPICK_RELIABILITY_REGISTRATION
  Matrix f("float: "), d("double: ");
  registration_cases<float>(f);
  registration_cases<double>(d);
  for (Matrix* m : {&f, &d})
    for (auto& c : m->cases()) out.push_back(std::move(c));
#else
  (void)out;
#endif
}

#ifdef BINPICK_RELIABILITY_CYCLE
namespace {
// Minimal drivers with switchable misbehaviour, enough to construct and run the pipeline.
struct StubRobot {
  using Scalar = float;
  sim::SimClock* clock;
  double arrival = 0;
  bool nan_pose = false;
  double move_along(const std::vector<Isometry3<float>>& path, float) {
    require(!path.empty(), "T_base_flange_path", "is empty");
    arrival = clock->now() + 0.1;
    at = path.back();
    return arrival;
  }
  bool is_moving() const { return clock->now() < arrival; }
  cycle::StampedPose<float> read_flange_pose() {
    cycle::StampedPose<float> r{at, clock->now()};
    if (nan_pose) r.T_base_flange(0, 3) = Bad<float>::nan();
    return r;
  }
  Isometry3<float> at = Isometry3<float>::Identity();
};
struct StubSensor {
  using Scalar = float;
  using Camera = PinholeCamera<float>;
  sim::SimClock* clock;
  float fill = 0.5f;
  bool throw_on_trigger = false;
  Camera cam{40, 40, 15.5f, 11.5f, 32, 24};
  std::vector<cycle::DepthFrame<float>> memory{};  // {}: aggregate-initialized with the clock alone
  const Camera& camera() const { return cam; }
  float accuracy() const { return 0.001f; }
  double trigger() {
    if (throw_on_trigger) throw std::runtime_error("stub: trigger failed");
    cycle::DepthFrame<float> f;
    f.depth = DepthImage<float>(32, 24, fill);
    f.trigger_time = clock->now();
    memory.push_back(std::move(f));
    return clock->now();
  }
  std::size_t frames_in_memory() const { return memory.size(); }
  std::vector<cycle::DepthFrame<float>> read_frames() { return std::move(memory); }
};
struct StubEstimator {
  using Scalar = float;
  using Camera = PinholeCamera<float>;
  bool nan_object = false;
  cycle::EstimationResult<float> estimate(const cycle::EstimatorInput<float, Camera>&) {
    cycle::EstimationResult<float> r;
    if (nan_object) {
      r.status = cycle::EstimationStatus::ok;
      cycle::RecognizedObject<float> o;
      o.T_camera_object(1, 3) = Bad<float>::nan();
      o.T_camera_grasp(2, 3) = Bad<float>::inf();
      o.confidence_percent = Bad<float>::nan();
      r.objects.push_back(o);
    }
    return r;
  }
};
struct StubGripper {
  using Scalar = float;
  bool grip(const Isometry3<float>&, cycle::GripperKind) { return false; }
  void release() {}
};
using StubPipeline = cycle::PickingPipeline<StubRobot, StubSensor, StubEstimator, sim::SimClock, StubGripper>;

struct StubCell {
  sim::SimClock clock;
  StubRobot robot{&clock};
  StubSensor sensor{&clock};
  StubEstimator estimator;
  StubGripper gripper;
};

Outcome run_stub_cycles(StubCell& c, const cycle::PipelineSettings<float>& s, int cycles) {
  StubPipeline p(c.robot, c.sensor, c.estimator, c.clock, c.gripper, s);
  Outcome o;
  for (int i = 0; i < cycles; ++i) {
    const auto r = p.run_cycle();
    o.status = cycle::to_string(r.status);
    o.add(r.takt.cycle_time).add(r.target);
    for (const auto& T : r.T_base_captures_read) o.add(T.matrix());
  }
  return o;
}

void cycle_cases(Matrix& m) {
  using PS = cycle::PipelineSettings<float>;
  auto construct = [](PS s) {
    StubCell c;
    StubPipeline p(c.robot, c.sensor, c.estimator, c.clock, c.gripper, s);
    return Outcome{};
  };
  struct Setting { std::string arg; std::function<void(PS&, float)> set; std::vector<float> bad; };
  const float nan = Bad<float>::nan(), inf = Bad<float>::inf();
  const std::vector<Setting> settings = {
      {"interval", [](PS& s, float v) { s.interval = v; }, {0, -1, nan, inf}},
      {"speed_percent", [](PS& s, float v) { s.sensing_speed_percent = v; }, {0, -1, 101, nan, inf}},
      {"speed_percent", [](PS& s, float v) { s.motion_speed_percent = v; }, {0, 1e30f, nan}},
      {"full_speed", [](PS& s, float v) { s.full_speed = v; }, {0, -1, nan, inf}},
      {"working_distance", [](PS& s, float v) { s.working_distance = v; }, {0, -1, nan, inf}},
      {"search_beta_factor", [](PS& s, float v) { s.search_beta_factor = v; }, {0.5f, nan}},
      {"stop_time", [](PS& s, float v) { s.stop_time = v; }, {-1, nan}},
      {"lift_clearance", [](PS& s, float v) { s.lift_clearance = v; }, {-1, nan}},
      {"bin_length", [](PS& s, float v) { s.bin_length = v; }, {0, -1, nan}},
      {"bin_center", [](PS& s, float v) { s.bin_center.y() = v; }, {nan, inf}},
      {"max_stamp_offset", [](PS& s, float v) { s.max_stamp_offset = v; }, {0, -1, nan}},
  };
  for (const auto& st : settings)
    for (float v : st.bad)
      m.throws("pipeline " + st.arg + " " + std::to_string(v), st.arg, [=] {
        PS s;
        st.set(s, v);
        return construct(s);
      });
  for (int n : {0, -1, 65})
    m.throws("pipeline num_views " + std::to_string(n), "num_views", [=] { PS s; s.num_views = n; return construct(s); });
  for (const char* which : {"T_flange_camera", "T_base_drop"}) {
    m.throws(std::string("pipeline ") + which + " nan", which, [=] {
      PS s;
      (std::string(which) == "T_flange_camera" ? s.T_flange_camera : s.T_base_drop)(0, 3) = nan;
      return construct(s);
    });
    m.throws(std::string("pipeline ") + which + " scaled", which, [=] {
      PS s;
      (std::string(which) == "T_flange_camera" ? s.T_flange_camera : s.T_base_drop).linear() *= 1.1f;
      return construct(s);
    });
  }
  // Misbehaving drivers: each ends the cycle with its status, never an exception or a NaN.
  m.gives("pipeline all-NaN frames", "nothing_recognized", [] { StubCell c; c.sensor.fill = Bad<float>::nan(); return run_stub_cycles(c, PS{}, 3); });
  m.gives("pipeline all-zero frames", "nothing_recognized", [] { StubCell c; c.sensor.fill = 0; return run_stub_cycles(c, PS{}, 3); });
  m.gives("pipeline NaN pose reads", "robot_failure", [] { StubCell c; c.robot.nan_pose = true; return run_stub_cycles(c, PS{}, 2); });
  m.gives("pipeline trigger throws", "sensor_failure", [] { StubCell c; c.sensor.throw_on_trigger = true; return run_stub_cycles(c, PS{}, 2); });
  m.gives("pipeline NaN object from the estimator", "nothing_recognized", [] {
    StubCell c;
    c.estimator.nan_object = true;
    return run_stub_cycles(c, PS{}, 2);
  });
}
}  // namespace
#endif

void add_cycle_cases(std::vector<Case>& out) {
#ifdef BINPICK_RELIABILITY_CYCLE
  Matrix m("cycle: ");
  cycle_cases(m);
  for (auto& c : m.cases()) out.push_back(std::move(c));
#else
  (void)out;
#endif
}

}  // namespace binpick::reliability
