// The bad-input matrix (see matrix.hpp): every public entry point through empty inputs, mismatched
// sizes, NaN / ±inf / denormal / huge values, non-orthonormal rotations, zero and negative focal
// lengths and radii, duplicate points and all-invalid images. Each case states its answer.
#include <cstdint>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "binpick/active_vision.hpp"
#include "binpick/core.hpp"
#include "binpick/fusion.hpp"
#include "binpick/geometry.hpp"
#include "matrix.hpp"

#if __has_include("binpick/registration/icp.hpp")
#include "binpick/registration.hpp"
#include "sim_instances.hpp"  // the simulated cell's templates, compiled once
#define BINPICK_RELIABILITY_REGISTRATION 1
#endif

#ifdef BINPICK_HAVE_TOOLS_IO
#include "io.hpp"
#endif

namespace binpick::reliability {

// Also used by other files of this executable.
void add_registration_cases(std::vector<Case>& out);
void add_cycle_cases(std::vector<Case>& out);

namespace {

template <typename Scalar>
using V3 = Vector3<Scalar>;

template <typename Scalar>
Isometry3<Scalar> pose(Scalar angle, const V3<Scalar>& t) {
  Isometry3<Scalar> T = Isometry3<Scalar>::Identity();
  T.linear() = Eigen::AngleAxis<Scalar>(angle, V3<Scalar>(1, 2, 3).normalized()).toRotationMatrix();
  T.translation() = t;
  return T;
}

/// The broken poses of the matrix, each refused by require_valid_pose.
template <typename Scalar>
std::vector<std::pair<std::string, Isometry3<Scalar>>> bad_poses() {
  std::vector<std::pair<std::string, Isometry3<Scalar>>> out;
  const Isometry3<Scalar> good = pose<Scalar>(Scalar(0.3), V3<Scalar>(0.1, 0.2, 0.3));
  for (const auto& [name, value] : Bad<Scalar>::non_finite()) {
    Isometry3<Scalar> T = good;
    T.translation().y() = value;
    out.emplace_back("translation " + name, T);
    T = good;
    T.linear()(1, 2) = value;
    out.emplace_back("rotation " + name, T);
  }
  Isometry3<Scalar> T = good;
  T.linear() *= Scalar(1.01);
  out.emplace_back("scaled rotation", T);
  T = good;
  T.linear().col(0) = -T.linear().col(0);
  out.emplace_back("reflection", T);
  T = good;
  T.linear()(0, 1) += Scalar(0.05);
  out.emplace_back("sheared rotation", T);
  T = good;
  T.linear().setZero();
  out.emplace_back("zero rotation", T);
  T = good;
  T.matrix()(3, 0) = Scalar(0.5);
  out.emplace_back("last row", T);
  return out;
}

template <typename Scalar>
PinholeCamera<Scalar> small_camera() {
  return PinholeCamera<Scalar>(Scalar(40), Scalar(40), Scalar(15.5), Scalar(11.5), 32, 24);
}

// A tilted plane 0.5..0.6 m in front of the small camera.
template <typename Scalar>
std::vector<Scalar> plane_depth(int w = 32, int h = 24) {
  std::vector<Scalar> d(std::size_t(w) * std::size_t(h));
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) d[std::size_t(v) * w + u] = Scalar(0.5) + Scalar(0.1) * Scalar(u) / Scalar(w);
  return d;
}

template <typename Scalar>
Outcome image_outcome(const DepthImage<Scalar>& img, const std::string& status_if_empty = "empty") {
  Outcome o;
  o.add_all(img.storage());
  o.status = img.valid_count() == 0 ? status_if_empty : "ok";
  return o;
}

// ---- core: camera models, depth views, poses --------------------------------------------------------
template <typename Scalar>
void camera_cases(Matrix& m) {
  using B = Bad<Scalar>;
  for (const auto& [name, v] : B::non_positive()) {
    m.throws("pinhole fx " + name, "fx", [v = v] { PinholeCamera<Scalar>(v, 40, 15, 11, 32, 24); return Outcome{}; });
    m.throws("pinhole fy " + name, "fy", [v = v] { PinholeCamera<Scalar>(40, v, 15, 11, 32, 24); return Outcome{}; });
    m.throws("brown-conrady fx " + name, "fx", [v = v] {
      BrownConradyCamera<Scalar>(v, 40, 15, 11, 32, 24, {});
      return Outcome{};
    });
  }
  for (const auto& [name, v] : B::non_finite()) {
    m.throws("pinhole cx " + name, "cx", [v = v] { PinholeCamera<Scalar>(40, 40, v, 11, 32, 24); return Outcome{}; });
    m.throws("pinhole cy " + name, "cy", [v = v] { PinholeCamera<Scalar>(40, 40, 15, v, 32, 24); return Outcome{}; });
    for (const char* coef : {"k1", "k2", "p1", "p2", "k3"})
      m.throws(std::string("brown-conrady ") + coef + " " + name, coef, [v = v, coef = std::string(coef)] {
        BrownConradyDistortion<Scalar> d;
        (coef == "k1" ? d.k1 : coef == "k2" ? d.k2 : coef == "p1" ? d.p1 : coef == "p2" ? d.p2 : d.k3) = v;
        BrownConradyCamera<Scalar>(40, 40, 15, 11, 32, 24, d);
        return Outcome{};
      });
  }
  for (int size : {0, -1, std::numeric_limits<int>::min()}) {
    m.throws("pinhole width " + std::to_string(size), "width",
             [size] { PinholeCamera<Scalar>(40, 40, 15, 11, size, 24); return Outcome{}; });
    m.throws("pinhole height " + std::to_string(size), "height",
             [size] { PinholeCamera<Scalar>(40, 40, 15, 11, 32, size); return Outcome{}; });
  }
  // Documented fallback: project() of a point it cannot map is std::nullopt, never a NaN pixel.
  std::vector<std::pair<std::string, V3<Scalar>>> points;
  for (const auto& [name, v] : B::depths()) {
    points.emplace_back("z " + name, V3<Scalar>(0.01f, 0.02f, v));
    points.emplace_back("x " + name, V3<Scalar>(v, 0.0f, 0.5f));
  }
  points.emplace_back("behind", V3<Scalar>(0, 0, -0.5f));
  points.emplace_back("at the centre", V3<Scalar>(0, 0, 0));
  // Cameras with extreme but valid intrinsics: denormal and huge focal lengths, huge distortion.
  std::vector<std::pair<std::string, std::function<std::optional<Vector2<Scalar>>(const V3<Scalar>&)>>> cams;
  const PinholeCamera<Scalar> normal_cam = small_camera<Scalar>();
  const PinholeCamera<Scalar> denormal_f(B::denormal(), B::denormal(), 15, 11, 32, 24);
  const PinholeCamera<Scalar> huge_f(B::huge(), B::huge(), 15, 11, 32, 24);
  BrownConradyDistortion<Scalar> wild;
  wild.k1 = B::huge();
  wild.k2 = -B::huge();
  wild.p1 = B::denormal();
  const BrownConradyCamera<Scalar> wild_bc(40, 40, 15, 11, 32, 24, wild);
  cams.emplace_back("pinhole", [normal_cam](const V3<Scalar>& p) { return normal_cam.project(p); });
  cams.emplace_back("pinhole denormal f", [denormal_f](const V3<Scalar>& p) { return denormal_f.project(p); });
  cams.emplace_back("pinhole 1e30 f", [huge_f](const V3<Scalar>& p) { return huge_f.project(p); });
  cams.emplace_back("brown-conrady k1=1e30", [wild_bc](const V3<Scalar>& p) { return wild_bc.project(p); });
  for (const auto& [cname, project] : cams)
    for (const auto& [pname, p] : points) {
      // The answer follows from the contract: a pixel inside the image or nothing.
      m.gives(cname + " project " + pname, "ok", [project = project, p = p] {
        Outcome o;
        if (const auto px = project(p)) {
          o.add(*px);
          if (!((*px).x() >= -0.5 && (*px).x() < 31.5 && (*px).y() >= -0.5 && (*px).y() < 23.5)) o.status = "outside";
        }
        return o;
      });
    }
  // Backprojection under wild distortion stays finite (undistortion falls back on divergence).
  for (const auto& [name, px] : std::vector<std::pair<std::string, Vector2<Scalar>>>{
           {"centre", {15, 11}}, {"corner", {0, 0}}, {"far outside", {1e6f, -1e6f}}})
    m.gives("brown-conrady k1=1e30 backproject " + name, "ok", [wild_bc, px = px] {
      return Outcome{}.add(wild_bc.backproject(px.x(), px.y(), Scalar(0.5)));
    });
}

template <typename Scalar>
void depth_view_cases(Matrix& m) {
  static const std::vector<float> buf(64, 0.5f);
  static const std::vector<std::uint16_t> buf16(64, 500);
  m.throws("view width -1", "width", [] { DepthImageView<Scalar>(buf.data(), -1, 4); return Outcome{}; });
  m.throws("view height -1", "height", [] { DepthImageView<Scalar>(buf.data(), 4, -1); return Outcome{}; });
  m.throws("view null data", "data", [] { DepthImageView<Scalar>(static_cast<const float*>(nullptr), 4, 4); return Outcome{}; });
  m.throws("view stride < row", "row_stride_bytes", [] {
    DepthImageView<Scalar>(buf.data(), 8, 4, 8 * sizeof(float) - 1);
    return Outcome{};
  });
  m.throws("view negative stride", "row_stride_bytes", [] {
    DepthImageView<Scalar>(buf.data(), 8, 4, -32);
    return Outcome{};
  });
  for (const auto& [name, v] : Bad<Scalar>::non_positive())
    m.throws("view metres_per_unit " + name, "metres_per_unit", [v = v] {
      DepthImageView<Scalar>(buf16.data(), 8, 8, 0, v);
      return Outcome{};
    });
  m.gives("view null data, empty", "empty", [] {
    DepthImageView<Scalar> view(static_cast<const float*>(nullptr), 0, 0);
    Outcome o;
    o.status = view.empty() ? "empty" : "ok";
    return o;
  });
  m.throws("image resize -1", "width", [] { DepthImage<Scalar>(-1, 3); return Outcome{}; });
  m.throws("image resize h -1", "height", [] { DepthImage<Scalar>(3, -1); return Outcome{}; });
  // Stored values decode to a finite depth or to 0 (= no measurement).
  for (const auto& [name, v] : Bad<Scalar>::depths()) {
    const std::string status = (v > Scalar(0) && v < Bad<Scalar>::inf()) ? "valid" : "invalid";
    m.gives("view decode " + name, status, [v = v] {
      const Scalar d = DepthImageView<Scalar>::decode(v, Scalar(1));
      Outcome o;
      o.add(d);
      o.status = d > Scalar(0) ? "valid" : "invalid";
      return o;
    });
  }
  // A huge scale can overflow a 16-bit value to inf: decoded as no measurement, not as inf.
  m.gives("view decode 65535 * max scale", "invalid", [] {
    const Scalar d = DepthImageView<Scalar>::decode(std::uint16_t(65535), std::numeric_limits<Scalar>::max());
    Outcome o;
    o.add(d);
    o.status = d > Scalar(0) ? "valid" : "invalid";
    return o;
  });
}

template <typename Scalar>
void pose_cases(Matrix& m) {
  for (const auto& [name, T] : bad_poses<Scalar>())
    m.throws("require_valid_pose " + name, "T_x", [T = T] {
      require_valid_pose(T, "T_x");
      return Outcome{};
    });
  // Valid but extreme: a 1e30 m translation, a denormal rotation offset.
  m.gives("relative_pose 1e30 translation", "ok", [] {
    const auto T = relative_pose(pose<Scalar>(Scalar(0.2), V3<Scalar>::Constant(Scalar(1e30))),
                                 pose<Scalar>(Scalar(-0.1), V3<Scalar>::Constant(Scalar(-1e30))));
    return Outcome{}.add(T.matrix()).add(rotation_angle(T));
  });
  m.gives("rotation_angle of a denormal rotation", "ok", [] {
    return Outcome{}.add(rotation_angle(pose<Scalar>(Bad<Scalar>::denormal(), V3<Scalar>::Zero())));
  });
}

// ---- fusion ------------------------------------------------------------------------------------------
template <typename Scalar>
void reproject_cases(Matrix& m) {
  const auto cam = small_camera<Scalar>();
  m.throws("reproject size mismatch", "source", [cam] {
    static const std::vector<Scalar> d = plane_depth<Scalar>(31, 24);
    reproject(DepthImageView<Scalar>(d.data(), 31, 24), cam, Isometry3<Scalar>::Identity(), cam);
    return Outcome{};
  });
  m.throws("reproject empty source", "source", [cam] {
    reproject(DepthImageView<Scalar>(), cam, Isometry3<Scalar>::Identity(), cam);
    return Outcome{};
  });
  for (const auto& [name, T] : bad_poses<Scalar>())
    m.throws("reproject pose " + name, "T_target_source", [cam, T = T] {
      static const std::vector<Scalar> d = plane_depth<Scalar>();
      reproject(DepthImageView<Scalar>(d.data(), 32, 24), cam, T, cam);
      return Outcome{};
    });
  // Every depth sample kind, as a whole image: invalid ones give an empty result, extreme valid ones
  // land outside or give a finite depth.
  for (const auto& [name, v] : Bad<Scalar>::depths()) {
    const bool valid = v > Scalar(0) && v < Bad<Scalar>::inf();
    // Denormal depths and 1e30 / max depths all project to the principal point region or beyond; the
    // answer we write down: valid samples produce finite depths somewhere or nothing, never NaN.
    m.gives("reproject all " + name, valid ? "any" : "empty", [cam, v = v, valid] {
      const std::vector<Scalar> d(32 * 24, v);
      Outcome o = image_outcome(reproject(DepthImageView<Scalar>(d.data(), 32, 24), cam,
                                          pose<Scalar>(Scalar(0.05), V3<Scalar>(0.01, 0, 0)), cam));
      if (valid) o.status = "any";
      return o;
    });
  }
  m.gives("reproject 1e30 translation", "empty", [cam] {
    const std::vector<Scalar> d = plane_depth<Scalar>();
    return image_outcome(reproject(DepthImageView<Scalar>(d.data(), 32, 24), cam,
                                   pose<Scalar>(Scalar(0), V3<Scalar>(Scalar(1e30), 0, 0)), cam));
  });
  m.gives("reproject mixed bad samples", "ok", [cam] {
    std::vector<Scalar> d = plane_depth<Scalar>();
    const auto bad = Bad<Scalar>::depths();
    for (std::size_t i = 0; i < d.size(); i += 3) d[i] = bad[(i / 3) % bad.size()].second;
    return image_outcome(reproject(DepthImageView<Scalar>(d.data(), 32, 24), cam, Isometry3<Scalar>::Identity(), cam));
  });
  m.gives("reproject uint16 all zero", "empty", [cam] {
    const std::vector<std::uint16_t> d(32 * 24, 0);
    return image_outcome(reproject(DepthImageView<Scalar>(d.data(), 32, 24, 0, Scalar(0.001)), cam,
                                   Isometry3<Scalar>::Identity(), cam));
  });
  m.gives("reproject uint16 max * 1e30 scale", "empty", [cam] {
    const std::vector<std::uint16_t> d(32 * 24, 65535);
    return image_outcome(reproject(DepthImageView<Scalar>(d.data(), 32, 24, 0, std::numeric_limits<Scalar>::max()), cam,
                                   Isometry3<Scalar>::Identity(), cam));
  });
}

template <typename Scalar>
void vote_cases(Matrix& m) {
  const VotingSettings<Scalar> ok_settings;
  m.throws("vote no planes", "planes", [ok_settings] {
    Scalar out[4];
    vote<Scalar>({}, 2, 2, ok_settings, out);
    return Outcome{};
  });
  m.throws("vote 65 planes", "planes", [ok_settings] {
    static const std::vector<Scalar> p(4, Scalar(1));
    Scalar out[4];
    vote<Scalar>(std::vector<const Scalar*>(65, p.data()), 2, 2, ok_settings, out);
    return Outcome{};
  });
  m.throws("vote null plane", "planes", [ok_settings] {
    Scalar out[4];
    vote<Scalar>({nullptr}, 2, 2, ok_settings, out);
    return Outcome{};
  });
  m.throws("vote negative size", "width", [ok_settings] {
    static const std::vector<Scalar> p(4, Scalar(1));
    Scalar out[4];
    vote<Scalar>({p.data()}, -2, 2, ok_settings, out);
    return Outcome{};
  });
  for (const auto& [name, v] : Bad<Scalar>::non_positive())
    m.throws("vote delta " + name, "delta", [v = v] {
      static const std::vector<Scalar> p(4, Scalar(1));
      VotingSettings<Scalar> s;
      s.delta = v;
      Scalar out[4];
      vote<Scalar>({p.data()}, 2, 2, s, out);
      return Outcome{};
    });
  for (int mv : {0, -1})
    m.throws("vote min_votes " + std::to_string(mv), "min_votes", [mv] {
      static const std::vector<Scalar> p(4, Scalar(1));
      VotingSettings<Scalar> s;
      s.min_votes = mv;
      Scalar out[4];
      vote<Scalar>({p.data()}, 2, 2, s, out);
      return Outcome{};
    });
  m.gives("vote empty image", "empty", [ok_settings] {
    vote<Scalar>({nullptr, nullptr}, 0, 0, ok_settings, nullptr);
    Outcome o;
    o.status = "empty";
    return o;
  });
  // Every view count path (1..9: the fixed kernels 2..8 and the block kernel), all sample kinds mixed,
  // duplicates (the same plane n times) and the largest finite depth.
  for (int n : {1, 2, 3, 5, 7, 8, 9, 64}) {
    m.gives("vote " + std::to_string(n) + " planes of bad samples", "ok", [n] {
      const auto bad = Bad<Scalar>::depths();
      const std::size_t npix = 67;  // not a multiple of any pack or block
      std::vector<std::vector<Scalar>> planes(static_cast<std::size_t>(n), std::vector<Scalar>(npix));
      for (int k = 0; k < n; ++k)
        for (std::size_t i = 0; i < npix; ++i) planes[std::size_t(k)][i] = bad[(i * 7 + std::size_t(k) * 3) % bad.size()].second;
      std::vector<const Scalar*> ptrs;
      for (const auto& p : planes) ptrs.push_back(p.data());
      std::vector<Scalar> out(npix, Scalar(-7));
      VoteMap votes;
      vote<Scalar>(ptrs, int(npix), 1, VotingSettings<Scalar>{}, out.data(), &votes);
      Outcome o;
      o.add_all(out).add_all(votes.votes);
      for (Scalar d : out)
        if (d < Scalar(0)) o.status = "negative depth";
      for (auto c : votes.votes)
        if (int(c) > n) o.status = "more votes than views";
      return o;
    });
    m.gives("vote " + std::to_string(n) + " duplicate planes at max", "ok", [n] {
      const std::vector<Scalar> p(19, std::numeric_limits<Scalar>::max());
      std::vector<Scalar> out(19);
      VoteMap votes;
      vote<Scalar>(std::vector<const Scalar*>(std::size_t(n), p.data()), 19, 1, VotingSettings<Scalar>{}, out.data(), &votes);
      Outcome o;
      o.add_all(out);
      for (std::size_t i = 0; i < out.size(); ++i)
        if (out[i] != std::numeric_limits<Scalar>::max() || votes.votes[i] != std::min(n, 255)) o.status = "not the input";
      return o;
    });
  }
}

template <typename Scalar>
void fusion_cases(Matrix& m) {
  using Fz = Fuser<Scalar, PinholeCamera<Scalar>>;
  const auto cam = small_camera<Scalar>();
  static const std::vector<Scalar> d = plane_depth<Scalar>();
  const DepthImageView<Scalar> view(d.data(), 32, 24);
  const Isometry3<Scalar> I = Isometry3<Scalar>::Identity();
  FusionSettings<Scalar> plain;
#ifdef BINPICK_RELIABILITY_REGISTRATION
  plain.register_views = false;
#endif
  m.throws("fuse no views", "views", [cam, plain] { Fz(cam).fuse({}, {}, plain); return Outcome{}; });
  m.throws("fuse pose count mismatch", "T_base_views", [cam, view, I, plain] {
    Fz(cam).fuse({view, view}, {I}, plain);
    return Outcome{};
  });
  m.throws("fuse view size mismatch", "views", [cam, I, plain] {
    static const std::vector<Scalar> small(16, Scalar(0.5));
    Fz(cam).fuse({DepthImageView<Scalar>(small.data(), 4, 4)}, {I}, plain);
    return Outcome{};
  });
  m.throws("fuse empty view", "views", [cam, I, plain] {
    Fz(cam).fuse({DepthImageView<Scalar>()}, {I}, plain);
    return Outcome{};
  });
  m.throws("fuse 65 views", "views", [cam, view, I, plain] {
    Fz(cam).fuse(std::vector<DepthImageView<Scalar>>(65, view), std::vector<Isometry3<Scalar>>(65, I), plain);
    return Outcome{};
  });
  for (const auto& [name, T] : bad_poses<Scalar>()) {
    m.throws("fuse pose " + name, "T_base_views", [cam, view, I, T = T, plain] {
      Fz(cam).fuse({view, view}, {I, T}, plain);
      return Outcome{};
    });
    m.throws("fuse_virtual target " + name, "T_base_target", [cam, view, I, T = T, plain] {
      Fz(cam).fuse_virtual(T, {view}, {I}, plain);
      return Outcome{};
    });
  }
  for (const auto& [name, v] : Bad<Scalar>::non_positive())
    m.throws("fuse sensor_accuracy " + name, "sensor_accuracy", [cam, view, I, v = v, plain] {
      FusionSettings<Scalar> s = plain;
      s.sensor_accuracy = v;
      Fz(cam).fuse({view}, {I}, s);
      return Outcome{};
    });
  for (const auto& [name, v] : Bad<Scalar>::non_finite())
    m.throws("fuse delta " + name, "delta", [cam, view, I, v = v, plain] {
      FusionSettings<Scalar> s = plain;
      s.delta = v;
      Fz(cam).fuse({view}, {I}, s);
      return Outcome{};
    });
  m.throws("fuse delta -1", "delta", [cam, view, I, plain] {
    FusionSettings<Scalar> s = plain;
    s.delta = Scalar(-1);
    Fz(cam).fuse({view}, {I}, s);
    return Outcome{};
  });
  m.throws("fuse min_votes 0", "min_votes", [cam, view, I, plain] {
    FusionSettings<Scalar> s = plain;
    s.min_votes = 0;
    Fz(cam).fuse({view}, {I}, s);
    return Outcome{};
  });
  m.throws("fuse num_threads -1", "num_threads", [cam, view, I, plain] {
    FusionSettings<Scalar> s = plain;
    s.num_threads = -1;
    Fz(cam).fuse({view}, {I}, s);
    return Outcome{};
  });
  // Images: all-invalid, every bad sample kind, duplicates; with and without registration.
  std::vector<std::pair<std::string, bool>> modes = {{"", false}};
#ifdef BINPICK_RELIABILITY_REGISTRATION
  modes.emplace_back(" registered", true);
#endif
  for (const auto& [mode, reg] : modes) {
    for (const auto& [name, v] : Bad<Scalar>::depths()) {
      const bool valid = v > Scalar(0) && v < Bad<Scalar>::inf();
      m.gives("fuse 3 views all " + name + mode, valid ? "any" : "empty", [cam, v = v, valid, reg = reg, plain] {
        const std::vector<Scalar> bad(32 * 24, v);
        const DepthImageView<Scalar> bv(bad.data(), 32, 24);
        FusionSettings<Scalar> s = plain;
        s.compute_votes = true;
#ifdef BINPICK_RELIABILITY_REGISTRATION
        s.register_views = reg;
#else
        (void)reg;
#endif
        const auto r = Fz(cam).fuse({bv, bv, bv},
                                    {Isometry3<Scalar>::Identity(), pose<Scalar>(Scalar(0.02), V3<Scalar>(0.005, 0, 0)),
                                     pose<Scalar>(Scalar(-0.02), V3<Scalar>(0, 0.005, 0))},
                                    s);
        Outcome o = image_outcome(r.depth);
        o.add(r.T_base_target.matrix());
        for (const auto& rep : r.views) o.add(rep.T_base_view.matrix());
        if (valid) o.status = "any";
        return o;
      });
    }
    m.gives("fuse duplicate views" + mode, "ok", [cam, reg = reg, plain] {
      const DepthImageView<Scalar> v(d.data(), 32, 24);
      FusionSettings<Scalar> s = plain;
#ifdef BINPICK_RELIABILITY_REGISTRATION
      s.register_views = reg;
#else
      (void)reg;
#endif
      const auto r = Fz(cam).fuse({v, v, v, v}, std::vector<Isometry3<Scalar>>(4, Isometry3<Scalar>::Identity()), s);
      Outcome o = image_outcome(r.depth);
      for (const auto& rep : r.views) o.add(rep.T_base_view.matrix());
      // Identical views fuse to the view itself.
      for (std::size_t i = 0; i < d.size(); ++i)
        if (std::abs(r.depth.storage()[i] - d[i]) > Scalar(1e-6)) o.status = "changed";
      return o;
    });
  }
  m.gives("fuse one-shot all-invalid uint16", "empty", [cam, plain] {
    const std::vector<std::uint16_t> z(32 * 24, 0);
    const DepthImageView<Scalar> v(z.data(), 32, 24, 0, Scalar(0.001));
    return image_outcome(fuse(std::vector<DepthImageView<Scalar>>{v, v}, std::vector<Isometry3<Scalar>>(2, Isometry3<Scalar>::Identity()),
                              cam, plain).depth);
  });
}

// ---- geometry ----------------------------------------------------------------------------------------
template <typename Scalar>
void geometry_cases(Matrix& m) {
  using namespace geometry;
  const V3<Scalar> o = V3<Scalar>::Zero(), ez = V3<Scalar>::UnitZ();
  for (const auto& [name, v] : Bad<Scalar>::non_finite()) {
    m.throws("plane point " + name, "point", [o, ez, v = v] { Plane<Scalar>::from_point_normal(V3<Scalar>(v, 0, 0), ez); return Outcome{}; });
    m.throws("plane normal " + name, "normal", [o, v = v] { Plane<Scalar>::from_point_normal(o, V3<Scalar>(0, v, 1)); return Outcome{}; });
    m.throws("plane_through_points a " + name, "a", [o, ez, v = v] { plane_through_points<Scalar>(V3<Scalar>(v, 0, 0), o, ez); return Outcome{}; });
    m.throws("plane_through_points c " + name, "c", [o, ez, v = v] { plane_through_points<Scalar>(o, ez, V3<Scalar>(0, v, 0)); return Outcome{}; });
    m.throws("line from " + name, "from", [ez, v = v] { Line3<Scalar>::through(V3<Scalar>(0, 0, v), ez); return Outcome{}; });
    m.throws("sphere center " + name, "center", [v = v] { Sphere<Scalar>::make(V3<Scalar>(v, 0, 0), 1); return Outcome{}; });
  }
  for (const auto& [name, v] : Bad<Scalar>::non_positive())
    m.throws("sphere radius " + name, "radius", [o, v = v] { Sphere<Scalar>::make(o, v); return Outcome{}; });
  m.throws("plane zero normal", "normal", [o] { Plane<Scalar>::from_point_normal(o, V3<Scalar>::Zero()); return Outcome{}; });
  // A normal whose length underflows to 0 is refused like a zero normal.
  m.throws("plane denormal normal", "normal", [o] {
    Plane<Scalar>::from_point_normal(o, V3<Scalar>(0, 0, Bad<Scalar>::denormal()));
    return Outcome{};
  });
  m.throws("line duplicate points", "to", [ez] { Line3<Scalar>::through(ez, ez); return Outcome{}; });
  auto opt_plane = [](const std::optional<Plane<Scalar>>& p) {
    Outcome out;
    if (!p) out.status = "none";
    else out.add(p->normal).add(p->point);
    return out;
  };
  m.gives("plane_through_points duplicates", "none", [o, ez, opt_plane] { return opt_plane(plane_through_points<Scalar>(o, ez, ez)); });
  m.gives("plane_through_points all equal", "none", [o, opt_plane] { return opt_plane(plane_through_points<Scalar>(o, o, o)); });
  m.gives("plane_through_points collinear", "none", [o, ez, opt_plane] {
    return opt_plane(plane_through_points<Scalar>(o, ez, V3<Scalar>(0, 0, 2)));
  });
  // float: the product of the side lengths (1e60) overflows, and the points are reported as giving no
  // plane (a status, never a NaN normal); double has the range.
  m.gives("plane_through_points 1e30 apart", sizeof(Scalar) == 4 ? "none" : "ok", [o, opt_plane] {
    return opt_plane(plane_through_points<Scalar>(o, V3<Scalar>(Scalar(1e30), 0, 0), V3<Scalar>(0, Scalar(1e30), 0)));
  });
  m.gives("plane_through_points denormal apart", "none", [o, opt_plane] {
    const Scalar t = Bad<Scalar>::denormal();
    return opt_plane(plane_through_points<Scalar>(o, V3<Scalar>(t, 0, 0), V3<Scalar>(0, t, 0)));
  });
  // S ∩ P: a plane missing or touching the sphere gives nothing; a huge sphere a finite circle.
  auto opt_circle = [](const std::optional<Circle3<Scalar>>& c) {
    Outcome out;
    if (!c) out.status = "none";
    else out.add(c->center).add(c->normal).add(c->radius);
    return out;
  };
  m.gives("sphere ∩ plane missing", "none", [o, ez, opt_circle] {
    return opt_circle(intersect(Sphere<Scalar>::make(o, 1), Plane<Scalar>::from_point_normal(V3<Scalar>(0, 0, 2), ez)));
  });
  m.gives("sphere ∩ plane tangent", "none", [o, ez, opt_circle] {
    return opt_circle(intersect(Sphere<Scalar>::make(o, 1), Plane<Scalar>::from_point_normal(ez, ez)));
  });
  // float: R² overflows; reported as no circle.
  m.gives("sphere ∩ plane 1e30 radius", sizeof(Scalar) == 4 ? "none" : "ok", [o, ez, opt_circle] {
    return opt_circle(intersect(Sphere<Scalar>::make(o, Scalar(1e30)), Plane<Scalar>::from_point_normal(ez, ez)));
  });
  m.gives("sphere ∩ plane denormal radius", "none", [o, ez, opt_circle] {
    return opt_circle(intersect(Sphere<Scalar>::make(o, Bad<Scalar>::denormal()), Plane<Scalar>::from_point_normal(o, ez)));
  });
  // Line ∩ circle: perpendicular line, a line far away, a degenerate circle.
  const Circle3<Scalar> unit{o, ez, Scalar(1)};
  auto hits = [](const LineCircleHits<Scalar>& h) {
    Outcome out;
    out.status = std::to_string(h.count) + " hits";
    for (int i = 0; i < h.count; ++i) out.add(h.points[i]).add(h.t[i]);
    return out;
  };
  m.gives("line ∩ circle perpendicular", "0 hits", [unit, ez, hits] { return hits(intersect(Line3<Scalar>{V3<Scalar>::Zero(), ez}, unit)); });
  m.gives("line ∩ circle 1e30 away", "0 hits", [unit, hits] {
    return hits(intersect(Line3<Scalar>{V3<Scalar>(0, Scalar(1e30), 0), V3<Scalar>::UnitX()}, unit));
  });
  m.gives("line ∩ circle through centre", "2 hits", [unit, hits] {
    return hits(intersect(Line3<Scalar>{V3<Scalar>(-5, 0, 0), V3<Scalar>::UnitX()}, unit));
  });
  m.gives("line ∩ circle zero radius", "1 hits", [o, ez, hits] {
    return hits(intersect(Line3<Scalar>{V3<Scalar>(-5, 0, 0), V3<Scalar>::UnitX()}, Circle3<Scalar>{o, ez, Scalar(0)}));
  });
  m.gives("exit_point behind", "none", [unit] {
    const auto p = exit_point(Line3<Scalar>{V3<Scalar>(5, 0, 0), V3<Scalar>::UnitX()}, unit);
    Outcome out;
    if (!p) out.status = "none";
    else out.add(*p);
    return out;
  });
  m.gives("angle_between zero vectors", "ok", [o] { return Outcome{}.add(angle_between<Scalar>(o, o)); });
  m.gives("rotate_vector huge angle", "ok", [ez] {
    return Outcome{}.add(rotate_vector<Scalar>(V3<Scalar>::UnitX(), ez, Scalar(1e30)));
  });
}

// ---- active vision -----------------------------------------------------------------------------------
template <typename Scalar>
void target_center_cases(Matrix& m) {
  using active_vision::target_center;
  const V3<Scalar> fb(0.1, 0.2, 0.3);
  auto tc = [](const active_vision::TargetCenter<Scalar>& t) {
    Outcome o;
    o.add(t.point).add(t.total_confidence);
    o.status = t.status == active_vision::TargetCenterStatus::weighted             ? "weighted"
               : t.status == active_vision::TargetCenterStatus::fallback_no_objects ? "fallback_no_objects"
                                                                                    : "fallback_zero_confidence";
    return o;
  };
  m.throws("target_center size mismatch", "confidences", [fb] {
    target_center<Scalar>({fb, fb}, {Scalar(1)}, fb);
    return Outcome{};
  });
  m.throws("target_center grasped out of range", "grasped_index", [fb] {
    target_center<Scalar>({fb}, {Scalar(1)}, fb, 1);
    return Outcome{};
  });
  for (const auto& [name, v] : Bad<Scalar>::non_finite()) {
    m.throws("target_center position " + name, "positions", [fb, v = v] {
      target_center<Scalar>({fb, V3<Scalar>(0, v, 0)}, {Scalar(1), Scalar(1)}, fb);
      return Outcome{};
    });
    m.throws("target_center confidence " + name, "confidences", [fb, v = v] {
      target_center<Scalar>({fb, fb}, {Scalar(1), v}, fb);
      return Outcome{};
    });
    m.throws("target_center fallback " + name, "fallback", [fb, v = v] {
      target_center<Scalar>({fb}, {Scalar(1)}, V3<Scalar>(v, 0, 0));
      return Outcome{};
    });
  }
  m.throws("target_center confidence -1", "confidences", [fb] {
    target_center<Scalar>({fb}, {Scalar(-1)}, fb);
    return Outcome{};
  });
  m.gives("target_center empty", "fallback_no_objects", [fb, tc] { return tc(target_center<Scalar>({}, {}, fb)); });
  m.gives("target_center only the grasped one", "fallback_no_objects", [fb, tc] {
    return tc(target_center<Scalar>({fb}, {Scalar(1)}, fb, 0));
  });
  m.gives("target_center zero confidences", "fallback_zero_confidence", [fb, tc] {
    return tc(target_center<Scalar>({fb, fb}, {Scalar(0), Scalar(0)}, fb));
  });
  m.gives("target_center denormal confidences", "weighted", [fb, tc] {
    const Scalar t = Bad<Scalar>::denormal();
    return tc(target_center<Scalar>({fb, V3<Scalar>(1, 1, 1)}, {t, t}, fb));
  });
  m.gives("target_center 1e30 positions", "weighted", [fb, tc] {
    const Scalar h = Bad<Scalar>::huge();
    return tc(target_center<Scalar>({V3<Scalar>(h, h, h), V3<Scalar>(-h, -h, -h)}, {Scalar(1), Scalar(1)}, fb));
  });
  m.gives("target_center 1e30 confidences", "weighted", [fb, tc] {
    const Scalar h = Bad<Scalar>::huge();
    return tc(target_center<Scalar>({fb, V3<Scalar>(1, 1, 1), fb}, {h, h, h}, fb));
  });
  m.gives("target_center duplicate points", "weighted", [fb, tc] {
    return tc(target_center<Scalar>(std::vector<V3<Scalar>>(50, fb), std::vector<Scalar>(50, Scalar(0.5)), fb));
  });
}

template <typename Scalar>
void sensing_path_cases(Matrix& m) {
  using namespace active_vision;
  SensingPathRequest<Scalar> good;
  good.target = V3<Scalar>(0.05, 0.02, 0.0);
  good.grasp = V3<Scalar>(0, 0, 0);
  good.lift = V3<Scalar>(0, 0, 0.1);
  good.drop = V3<Scalar>(0.5, 0, 0.1);
  auto path = [](const SensingPath<Scalar>& p) {
    Outcome o;
    o.status = p.ok() ? "ok" : to_string(p.status);
    o.add(p.start).add(p.end).add(p.length_bmnc).add(p.length_bc).add(p.central_angle).add(p.coverage_angle);
    for (const auto& T : p.T_base_captures) o.add(T.matrix());
    if (p.ok() && p.T_base_captures.empty()) o.status = "ok without captures";
    return o;
  };
  m.gives("sensing path good", "ok", [good, path] { return path(plan_sensing_path(good)); });
  for (const auto& [name, v] : Bad<Scalar>::non_finite()) {
    for (const char* field : {"target", "grasp", "lift", "drop"})
      m.throws(std::string("sensing path ") + field + " " + name, field, [good, v = v, f = std::string(field)] {
        auto r = good;
        (f == "target" ? r.target : f == "grasp" ? r.grasp : f == "lift" ? r.lift : r.drop).y() = v;
        plan_sensing_path(r);
        return Outcome{};
      });
    m.throws("sensing path gamma " + name, "gamma", [good, v = v] { auto r = good; r.gamma = v; plan_sensing_path(r); return Outcome{}; });
    m.throws("sensing path beta " + name, "beta", [good, v = v] { auto r = good; r.beta = v; plan_sensing_path(r); return Outcome{}; });
    m.throws("sensing path min_elevation " + name, "min_elevation",
             [good, v = v] { auto r = good; r.min_elevation = v; plan_sensing_path(r); return Outcome{}; });
  }
  for (const auto& [name, v] : Bad<Scalar>::non_positive())
    m.throws("sensing path radius " + name, "radius", [good, v = v] { auto r = good; r.radius = v; plan_sensing_path(r); return Outcome{}; });
  m.throws("sensing path beta 0", "beta", [good] { auto r = good; r.beta = 0; plan_sensing_path(r); return Outcome{}; });
  m.throws("sensing path gamma -0.1", "gamma", [good] { auto r = good; r.gamma = Scalar(-0.1); plan_sensing_path(r); return Outcome{}; });
  for (int n : {1, 0, -5, 100001})
    m.throws("sensing path num_views " + std::to_string(n), "num_views",
             [good, n] { auto r = good; r.num_views = n; plan_sensing_path(r); return Outcome{}; });
  m.throws("sensing path lift == grasp", "lift", [good] { auto r = good; r.lift = r.grasp; plan_sensing_path(r); return Outcome{}; });
  m.gives("sensing path lift == drop", "grasp, lift and drop points are collinear: no plane P", [good, path] {
    auto r = good;
    r.drop = r.lift;
    return path(plan_sensing_path(r));
  });
  m.gives("sensing path collinear", "grasp, lift and drop points are collinear: no plane P", [good, path] {
    auto r = good;
    r.drop = r.grasp + Scalar(2) * (r.lift - r.grasp);
    return path(plan_sensing_path(r));
  });
  m.gives("sensing path target 1e30 away", "the sphere S(T, r) does not meet the plane P", [good, path] {
    auto r = good;
    r.target = V3<Scalar>(0, 0, 0) + V3<Scalar>(Scalar(1e30), Scalar(1e30), Scalar(1e30));
    return path(plan_sensing_path(r));
  });
  // double: a path 1e30 m long, finite; float: r² overflows and the sphere is reported as missing P.
  m.gives("sensing path 1e30 radius", sizeof(Scalar) == 4 ? "the sphere S(T, r) does not meet the plane P" : "ok",
          [good, path] {
    auto r = good;
    r.radius = Bad<Scalar>::huge();
    return path(plan_sensing_path(r));
  });
  m.gives("sensing path denormal radius", "the sphere S(T, r) does not meet the plane P", [good, path] {
    auto r = good;
    r.radius = Bad<Scalar>::denormal();
    return path(plan_sensing_path(r));
  });
  m.gives("sensing path beta pi", "the coverage angle beta is larger than the arc L offers", [good, path] {
    auto r = good;
    r.beta = Scalar(3.14159265358979323846);
    return path(plan_sensing_path(r));
  });
  m.gives("sensing path 100000 views", "ok", [good, path] {
    auto r = good;
    r.num_views = 100000;
    const auto p = plan_sensing_path(r);
    Outcome o = path(p);
    if (p.T_base_captures.size() != 100000) o.status = "wrong capture count";
    return o;
  });
}

template <typename Scalar>
void parameter_cases(Matrix& m) {
  using namespace active_vision;
  const MotionParameters<Scalar> good{Scalar(0.5), Scalar(0.05), 5};
  for (const auto& [name, v] : Bad<Scalar>::non_positive()) {
    m.throws("path_angles speed " + name, "motion.speed", [good, v = v] { auto g = good; g.speed = v; path_angles_from_motion(g, Scalar(0.3)); return Outcome{}; });
    m.throws("path_angles interval " + name, "motion.interval", [good, v = v] { auto g = good; g.interval = v; path_angles_from_motion(g, Scalar(0.3)); return Outcome{}; });
    m.throws("path_angles sphere_radius " + name, "sphere_radius", [good, v = v] { path_angles_from_motion(good, v, Scalar(0.3)); return Outcome{}; });
    m.throws("path_angles arc_radius " + name, "arc_radius", [good, v = v] { path_angles_from_motion(good, Scalar(0.3), v); return Outcome{}; });
    m.throws("motion_from_path_angles interval " + name, "interval",
             [v = v] { motion_from_path_angles(PathAngles<Scalar>{Scalar(0.1), Scalar(0.4)}, v, Scalar(0.3)); return Outcome{}; });
    m.throws("motion_from_path_angles alpha " + name, "angles.alpha",
             [v = v] { motion_from_path_angles(PathAngles<Scalar>{v, Scalar(0.4)}, Scalar(0.05), Scalar(0.3)); return Outcome{}; });
    m.throws("max_target_angle sphere_radius " + name, "sphere_radius", [v = v] { max_target_angle(v, Scalar(0.1)); return Outcome{}; });
  }
  m.throws("path_angles num_views 1", "motion.num_views", [good] { auto g = good; g.num_views = 1; path_angles_from_motion(g, Scalar(0.3)); return Outcome{}; });
  m.throws("path_angles arc_radius > sphere_radius", "arc_radius", [good] { path_angles_from_motion(good, Scalar(0.3), Scalar(0.4)); return Outcome{}; });
  m.throws("path_angles longer than half the arc", "motion", [good] {
    auto g = good;
    g.num_views = 1000;
    path_angles_from_motion(g, Scalar(0.3));
    return Outcome{};
  });
  m.throws("path_angles 1e30 speed", "motion", [good] { auto g = good; g.speed = Bad<Scalar>::huge(); path_angles_from_motion(g, Scalar(0.3)); return Outcome{}; });
  m.gives("path_angles denormal speed", "ok", [good] {
    auto g = good;
    g.speed = Bad<Scalar>::denormal();
    const auto a = path_angles_from_motion(g, Scalar(0.3));
    return Outcome{}.add(a.alpha).add(a.beta);
  });
  m.throws("motion_from_path_angles beta < alpha", "angles.beta",
           [] { motion_from_path_angles(PathAngles<Scalar>{Scalar(0.4), Scalar(0.1)}, Scalar(0.05), Scalar(0.3)); return Outcome{}; });
  m.throws("motion_from_path_angles denormal alpha", "angles.alpha",
           [] { motion_from_path_angles(PathAngles<Scalar>{Bad<Scalar>::denormal(), Scalar(0.4)}, Scalar(0.05), Scalar(0.3)); return Outcome{}; });
  m.throws("central_to_target_angle -0.1", "central_angle", [] { central_to_target_angle(Scalar(-0.1), Scalar(0.3), Scalar(0.3)); return Outcome{}; });
  m.throws("target_to_central_angle nan", "target_angle", [] { target_to_central_angle(Bad<Scalar>::nan(), Scalar(0.3), Scalar(0.3)); return Outcome{}; });
  // Offline selection.
  std::vector<ParameterTrial<Scalar>> trials;
  for (int i = 0; i < 12; ++i)
    trials.push_back({Scalar(0.2 + 0.05 * (i % 4)), Scalar(0.04), 3 + i % 3, Scalar(5 + i % 5)});
  auto sel = [](const ParameterSelection<Scalar>& s) {
    Outcome o;
    o.status = s.ok() ? "ok" : s.status == ParameterSelectionStatus::empty_band ? "empty_band" : "arc_too_long";
    o.add(s.motion.speed).add(s.motion.interval).add(s.angles.alpha).add(s.angles.beta).add(s.mean).add(s.sigma);
    return o;
  };
  m.gives("select_path_parameters good", "ok", [trials, sel] { return sel(select_path_parameters(trials, Scalar(0.3), Scalar(0.3))); });
  m.throws("select_path_parameters empty", "trials", [] { select_path_parameters<Scalar>({}, Scalar(0.3), Scalar(0.3)); return Outcome{}; });
  m.throws("select_path_parameters min_trials 1", "settings.min_trials", [trials] {
    ParameterSelectionSettings<Scalar> s;
    s.min_trials = 1;
    select_path_parameters(trials, Scalar(0.3), Scalar(0.3), s);
    return Outcome{};
  });
  for (const auto& [name, v] : Bad<Scalar>::non_finite()) {
    m.throws("select_path_parameters recognized " + name, "trials", [trials, v = v] {
      auto t = trials;
      t[3].recognized = v;
      select_path_parameters(t, Scalar(0.3), Scalar(0.3));
      return Outcome{};
    });
    m.throws("select_path_parameters band " + name, "settings", [trials, v = v] {
      ParameterSelectionSettings<Scalar> s;
      s.band_high_sigma = v;
      select_path_parameters(trials, Scalar(0.3), Scalar(0.3), s);
      return Outcome{};
    });
  }
  m.throws("select_path_parameters speed 0", "trials", [trials] {
    auto t = trials;
    t[0].speed = 0;
    select_path_parameters(t, Scalar(0.3), Scalar(0.3));
    return Outcome{};
  });
  m.gives("select_path_parameters duplicate trials", "ok", [trials, sel] {
    return sel(select_path_parameters(std::vector<ParameterTrial<Scalar>>(20, trials[0]), Scalar(0.3), Scalar(0.3)));
  });
  m.gives("select_path_parameters 1e30 counts", "ok", [trials, sel] {
    auto t = trials;
    for (auto& x : t) x.recognized *= Bad<Scalar>::huge();
    return sel(select_path_parameters(t, Scalar(0.3), Scalar(0.3)));
  });
}

// ---- tools readers -----------------------------------------------------------------------------------
void tools_cases(Matrix& m) {
#ifdef BINPICK_HAVE_TOOLS_IO
  namespace t = binpick::tools;
  const std::vector<std::pair<std::string, std::string>> bad_pose_texts = {
      {"empty", ""},
      {"15 numbers", "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0"},
      {"17 numbers", "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1 1"},
      {"nan", "nan 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1"},
      {"inf", "1 0 0 inf 0 1 0 0 0 0 1 0 0 0 0 1"},
      {"1e400", "1 0 0 1e400 0 1 0 0 0 0 1 0 0 0 0 1"},
      {"scaled", "2 0 0 0 0 2 0 0 0 0 2 0 0 0 0 1"},
      {"reflection", "-1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1"},
      {"1e300 rotation", "1e300 0 0 0 0 1e300 0 0 0 0 1e300 0 0 0 0 1"},
      {"last row", "1 0 0 0 0 1 0 0 0 0 1 0 0.5 0 0 1"},
      {"words", "one 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1"},
  };
  for (const auto& [name, text] : bad_pose_texts)
    m.throws_io("parse_pose " + name, "pose.txt", [text = text] { t::parse_pose(text, "pose.txt"); return Outcome{}; });
  m.gives("parse_pose 1e30 translation", "ok", [] {
    return Outcome{}.add(t::parse_pose("1 0 0 1e30 0 1 0 0 0 0 1 0 0 0 0 1", "pose.txt").matrix());
  });
  m.gives("parse_pose denormal rotation noise", "ok", [] {
    return Outcome{}.add(t::parse_pose("1 4.9e-324 0 0 0 1 0 0 0 0 1 0 0 0 0 1", "pose.txt").matrix());
  });
  const std::vector<std::pair<std::string, std::string>> bad_intrinsics = {
      {"empty", ""},          {"5 numbers", "1,1,1,1,1"},   {"fx 0", "0,1,1,1,8,8"},
      {"fy -1", "1,-1,1,1,8,8"}, {"fx nan", "nan,1,1,1,8,8"}, {"width 1e30", "1,1,1,1,1e30,8"},
      {"height -1e30", "1,1,1,1,8,-1e30"}, {"width 0.5", "1,1,1,1,0.5,8"}, {"height 0", "1,1,1,1,8,0"},
      {"width 1e5+1", "1,1,1,1,100001,8"},
  };
  for (const auto& [name, text] : bad_intrinsics)
    m.throws_io("parse_intrinsics " + name, "--intrinsics", [text = text] { t::parse_intrinsics(text); return Outcome{}; });
  m.gives("parse_intrinsics denormal focal", "ok", [] {
    const auto k = t::parse_intrinsics("4.9e-324,4.9e-324,0,0,1,1");
    return Outcome{}.add(k.fx).add(k.fy).add(k.cx).add(k.cy);
  });
  const std::vector<std::pair<std::string, std::string>> bad_pngs = {
      {"empty", ""},
      {"signature only", std::string("\x89PNG\r\n\x1a\n", 8)},
      {"text", "P5 2 2 255"},
      {"chunk longer than file", std::string("\x89PNG\r\n\x1a\n\x7f\xff\xff\xffIHDR", 16)},
  };
  for (const auto& [name, bytes] : bad_pngs)
    m.throws_io("decode_png16 " + name, "depth.png", [bytes = bytes] {
      t::decode_png16(reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size(), "depth.png");
      return Outcome{};
    });
#else
  (void)m;
#endif
}

template <typename Scalar>
void add_library_cases(std::vector<Case>& out) {
  Matrix m(std::string(scalar_name<Scalar>()) + ": ");
  camera_cases<Scalar>(m);
  depth_view_cases<Scalar>(m);
  pose_cases<Scalar>(m);
  reproject_cases<Scalar>(m);
  vote_cases<Scalar>(m);
  fusion_cases<Scalar>(m);
  geometry_cases<Scalar>(m);
  target_center_cases<Scalar>(m);
  sensing_path_cases<Scalar>(m);
  parameter_cases<Scalar>(m);
  for (auto& c : m.cases()) out.push_back(std::move(c));
}

}  // namespace

TEST(BadInputMatrix, EveryCaseGivesItsWrittenDownAnswer) {
  std::vector<Case> cases;
  add_library_cases<float>(cases);
  add_library_cases<double>(cases);
  {
    Matrix m("tools: ");
    tools_cases(m);
    for (auto& c : m.cases()) cases.push_back(std::move(c));
  }
  add_registration_cases(cases);
  add_cycle_cases(cases);
  std::size_t failed = 0, throws = 0;
  for (const Case& c : cases) {
    const std::string why = check(c);
    if (c.expect != Expect::status) ++throws;
    if (!why.empty()) {
      ++failed;
      ADD_FAILURE() << c.name << ": " << why;
    }
  }
  std::printf("bad-input matrix: %zu cases (%zu expect an exception, %zu a status or fallback), %zu failed\n",
              cases.size(), throws, cases.size() - throws, failed);
  EXPECT_GT(cases.size(), 300u);  // the matrix must not silently shrink to nothing
}

}  // namespace binpick::reliability
