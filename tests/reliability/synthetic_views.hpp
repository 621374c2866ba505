#pragma once
// A small synthetic multi-view scene for the determinism checks: a tilted floor with a few spheres on
// it, rendered (analytic ray casting) from `n` cameras on an arc looking at it, with seeded noise and
// dropouts, plus seeded late-pose errors on views 2..n — the shape of the cycle's views (§III.B).
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "binpick/core.hpp"

namespace binpick::reliability {

template <typename Scalar>
struct SyntheticViews {
  PinholeCamera<Scalar> camera{Scalar(160), Scalar(160), Scalar(79.5), Scalar(59.5), 160, 120};
  std::vector<std::vector<Scalar>> depth;        // metres, 0 = none, row-major
  std::vector<Isometry3<Scalar>> T_base_views;   // the (late) poses given to fusion
  std::vector<DepthImageView<Scalar>> views() const {
    std::vector<DepthImageView<Scalar>> v;
    for (const auto& d : depth) v.emplace_back(d.data(), camera.width(), camera.height());
    return v;
  }
};

template <typename Scalar>
SyntheticViews<Scalar> make_synthetic_views(int n, std::uint32_t seed) {
  SyntheticViews<Scalar> s;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  auto gauss = [&] {  // Box-Muller from uniforms: the same numbers with every standard library
    const double u1 = std::max(unit(rng), 1e-300), u2 = unit(rng);
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(6.283185307179586 * u2);
  };
  struct Ball { Eigen::Vector3d c; double r; };
  std::vector<Ball> balls;
  for (int i = 0; i < 6; ++i) {
    // One draw per declarator (a call's arguments are evaluated in no fixed order): the same balls
    // with every compiler.
    const double by = unit(rng), bx = unit(rng), br = unit(rng);
    balls.push_back({Eigen::Vector3d(-0.12 + 0.24 * bx, -0.08 + 0.16 * by, 0.02), 0.02 + 0.02 * br});
  }
  const Eigen::Vector3d floor_n = Eigen::Vector3d(0.05, -0.03, 1).normalized();
  const int w = s.camera.width(), h = s.camera.height();
  for (int k = 0; k < n; ++k) {
    const double a = -0.25 + 0.5 * k / std::max(1, n - 1);  // along an arc 0.45 m above the floor
    const Eigen::Vector3d eye(0.45 * std::sin(a), 0.05, 0.45 * std::cos(a));
    const Eigen::Vector3d z = (Eigen::Vector3d(0, 0, 0) - eye).normalized();
    const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitY()).normalized();
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear().col(0) = x;
    T.linear().col(1) = z.cross(x);
    T.linear().col(2) = z;
    T.translation() = eye;
    std::vector<Scalar> d(std::size_t(w) * std::size_t(h), Scalar(0));
    for (int v = 0; v < h; ++v)
      for (int u = 0; u < w; ++u) {
        const Eigen::Vector3d ray_c((u - 79.5) / 160.0, (v - 59.5) / 160.0, 1.0);
        const Eigen::Vector3d dir = T.linear() * ray_c;  // z component of ray_c is 1: t = camera depth
        double best = floor_n.dot(dir) < 0 ? -floor_n.dot(eye) / floor_n.dot(dir) : 1e9;
        for (const Ball& b : balls) {
          const Eigen::Vector3d oc = eye - b.c;
          const double A = dir.squaredNorm(), B = oc.dot(dir), C = oc.squaredNorm() - b.r * b.r;
          const double disc = B * B - A * C;
          if (disc > 0) best = std::min(best, (-B - std::sqrt(disc)) / A);
        }
        const bool drop = unit(rng) < 0.03;
        if (best < 5 && !drop) d[std::size_t(v) * w + u] = Scalar(best + 0.0008 * gauss());
      }
    s.depth.push_back(std::move(d));
    // Views after the first carry a late pose: a few mm and a fraction of a degree off.
    Eigen::Isometry3d late = T;
    if (k > 0) {
      late.translation() += Eigen::Vector3d(gauss(), gauss(), gauss()) * 0.002;
      late.linear() = late.linear() * Eigen::AngleAxisd(0.004 * gauss(), Eigen::Vector3d(gauss(), gauss(), gauss()).normalized())
                                          .toRotationMatrix();
    }
    s.T_base_views.push_back(late.cast<Scalar>());
  }
  return s;
}

/// FNV-1a over the bytes of a buffer: a fingerprint that changes with any bit of the output.
inline std::uint64_t fnv1a(const void* data, std::size_t bytes, std::uint64_t h = 1469598103934665603ull) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < bytes; ++i) h = (h ^ p[i]) * 1099511628211ull;
  return h;
}

}  // namespace binpick::reliability
