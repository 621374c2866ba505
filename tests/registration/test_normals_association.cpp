// Normals (organized and kNN) against analytic planes; kd-tree and projective association against
// brute force.
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include "binpick/registration.hpp"
#include "scene.hpp"
#include "test_support.hpp"

using namespace binpick;
using namespace binpick::test;

namespace {

template <typename Scalar>
double normal_tolerance() {
  return std::is_same<Scalar, float>::value ? 2e-3 : 1e-6;
}

template <typename Scalar>
void check_organized_normals_on_plane() {
  AnalyticScene scene;
  PlaneSurface plane;
  plane.normal = random_rotation(40 * M_PI / 180) * Eigen::Vector3d(0, 0, -1);
  plane.point = Eigen::Vector3d(uniform(-0.05, 0.05), uniform(-0.05, 0.05), uniform(0.2, 1.0));
  scene.planes.push_back(plane);
  const auto cam = test_camera<Scalar>();
  const DepthImage<Scalar> depth = scene.render(cam, Eigen::Isometry3d::Identity());
  OrganizedCloud<Scalar> cloud = backproject_organized(depth.view(), cam);
  OrganizedNormalSettings<Scalar> s;
  s.pixel_offset = *rc::gen::inRange(1, 4);
  estimate_organized_normals(cloud, s);
  RC_ASSERT(cloud.has_normals());
  std::size_t checked = 0;
  for (int v = 0; v < cloud.height; ++v)
    for (int u = 0; u < cloud.width; ++u) {
      if (!cloud.valid(u, v)) {
        RC_ASSERT(cloud.normals[cloud.index(u, v)].isZero());
        continue;
      }
      const Eigen::Vector3d n = cloud.normals[cloud.index(u, v)].template cast<double>();
      const int k = s.pixel_offset;
      const bool interior = u >= k && v >= k && u + k < cloud.width && v + k < cloud.height &&
                            cloud.valid(u - k, v) && cloud.valid(u + k, v) && cloud.valid(u, v - k) &&
                            cloud.valid(u, v + k);
      if (!interior) {
        RC_ASSERT(n.isZero());  // a neighbour is missing: no one-sided guess by default
        continue;
      }
      RC_ASSERT((n - plane.normal).norm() < normal_tolerance<Scalar>());
      ++checked;
    }
  RC_ASSERT(checked > 0u);
}

template <typename Scalar>
void check_knn_normals_on_plane() {
  // Points scattered on a random plane; normals must point toward the viewpoint.
  const Eigen::Vector3d n_true = random_rotation(M_PI) * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d origin(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1));
  const Eigen::Vector3d a = n_true.unitOrthogonal(), b = n_true.cross(a);
  std::vector<Vector3<Scalar>> pts;
  const int n = *rc::gen::inRange(20, 300);
  std::mt19937 rng(*rc::gen::arbitrary<unsigned>());  // bulk positions: shrinking them adds nothing
  std::uniform_real_distribution<double> in(-0.1, 0.1);
  for (int i = 0; i < n; ++i) {
    const double sb = in(rng), sa = in(rng);  // one draw per declarator: the same points on every compiler
    pts.push_back((origin + sa * a + sb * b).cast<Scalar>());
  }
  pts.push_back(Vector3<Scalar>::Constant(std::numeric_limits<Scalar>::quiet_NaN()));
  KnnNormalSettings<Scalar> s;
  s.viewpoint = (origin + 0.5 * n_true).cast<Scalar>();
  s.num_threads = *rc::gen::inRange(0, 3);
  const auto normals = estimate_knn_normals(pts, s);
  RC_ASSERT(normals.size() == pts.size());
  RC_ASSERT(normals.back().isZero());  // the NaN point gets none
  for (int i = 0; i < n; ++i) RC_ASSERT((normals[std::size_t(i)].template cast<double>() - n_true).norm() < 10 * normal_tolerance<Scalar>());
}

template <typename Scalar>
void check_kdtree_exact() {
  const int n = *rc::gen::inRange(0, 400);
  std::vector<Vector3<Scalar>> pts;
  // A coarse lattice makes ties common; compare distances, not indices.
  const bool lattice = *rc::gen::arbitrary<bool>();
  for (int i = 0; i < n; ++i) {
    if (lattice) pts.emplace_back(Scalar(*rc::gen::inRange(0, 4)), Scalar(*rc::gen::inRange(0, 4)), Scalar(*rc::gen::inRange(0, 4)));
    else pts.emplace_back(Scalar(uniform(-1, 1)), Scalar(uniform(-1, 1)), Scalar(uniform(-1, 1)));
  }
  if (n > 0 && *rc::gen::arbitrary<bool>()) pts[0] = Vector3<Scalar>::Constant(std::numeric_limits<Scalar>::quiet_NaN());
  const KdTree<Scalar> tree(pts);
  std::vector<Vector3<Scalar>> queries;
  for (int i = 0; i < 50; ++i) queries.emplace_back(Scalar(uniform(-1, 4)), Scalar(uniform(-1, 4)), Scalar(uniform(-1, 4)));
  const int k = *rc::gen::inRange(1, 5);
  std::vector<std::ptrdiff_t> idx;
  std::vector<Scalar> d2;
  tree.knn(queries.front().data(), queries.size(), k, 2, idx, d2);
  for (std::size_t q = 0; q < queries.size(); ++q) {
    std::vector<double> brute;
    for (const auto& p : pts)
      if (p.allFinite()) brute.push_back(double((p - queries[q]).squaredNorm()));
    std::sort(brute.begin(), brute.end());
    for (int j = 0; j < k; ++j) {
      const std::size_t e = q * std::size_t(k) + std::size_t(j);
      if (std::size_t(j) >= brute.size()) {
        RC_ASSERT(idx[e] == -1);
        continue;
      }
      RC_ASSERT(idx[e] >= 0);
      RC_ASSERT(pts[std::size_t(idx[e])].allFinite());
      RC_ASSERT(std::abs(double(d2[e]) - brute[std::size_t(j)]) <= 1e-5 * (1 + brute[std::size_t(j)]));
      RC_ASSERT(std::abs(double((pts[std::size_t(idx[e])] - queries[q]).squaredNorm()) - double(d2[e])) <= 1e-5 * (1 + double(d2[e])));
    }
  }
  // The bounded one-query search: the nearest point strictly inside the bound, or none.
  const Scalar bound = Scalar(uniform(0, 4));
  for (const auto& q : queries) {
    double best = std::numeric_limits<double>::infinity();
    for (const auto& p : pts)
      if (p.allFinite()) best = std::min(best, double((p - q).squaredNorm()));
    Scalar d = Scalar(-1);
    const std::ptrdiff_t j = tree.nearest(q.data(), bound, d);
    const double tol = 1e-5 * (1 + best);
    if (best < double(bound) - tol) {
      RC_ASSERT(j >= 0);
      RC_ASSERT(std::abs(double(d) - best) <= tol);
      RC_ASSERT(std::abs(double((pts[std::size_t(j)] - q).squaredNorm()) - best) <= tol);
    } else if (best > double(bound) + tol) {
      RC_ASSERT(j == -1);
    }
  }
  // The association's point-wise partner and its batch agree (the batch is made of the point-wise).
  if (!pts.empty()) {
    PointCloud<Scalar> cloud;
    cloud.points = pts;
    const KnnAssociation<Scalar> assoc(cloud);
    const Scalar max_distance = Scalar(uniform(0, 2));
    std::vector<std::ptrdiff_t> partners;
    assoc.associate(queries, max_distance, 2, partners);
    RC_ASSERT(partners.size() == queries.size());
    for (std::size_t i = 0; i < queries.size(); ++i) {
      RC_ASSERT(partners[i] == assoc.partner(queries[i], max_distance));
      double best = std::numeric_limits<double>::infinity();
      for (const auto& p : pts)
        if (p.allFinite()) best = std::min(best, double((p - queries[i]).squaredNorm()));
      const double r2 = double(max_distance) * double(max_distance), tol = 1e-5 * (1 + best);
      if (best < r2 - tol) RC_ASSERT(partners[i] >= 0);
      if (best > r2 + tol) RC_ASSERT(partners[i] == -1);
    }
  }
}

}  // namespace

namespace {

// The interior fast path of estimate_organized_normals against the general per-pixel rule
// (organized_normal_at) on random bumpy surfaces with holes and depth jumps, for random settings.
// The fast path compares the crease and parallel-tangent tests in squares, so a pixel exactly at a
// threshold may flip; such flips must stay rare, and normals that both give must agree.
template <typename Scalar>
void check_organized_normals_match_reference() {
  // Up to 70 columns: several packs a row at every level (2 to 8 lanes a pack).
  const int w = *rc::gen::inRange(3, 70), h = *rc::gen::inRange(3, 30);
  OrganizedCloud<Scalar> cloud;
  cloud.width = w;
  cloud.height = h;
  cloud.points.assign(std::size_t(w) * std::size_t(h), Vector3<Scalar>::Zero());
  const double z0 = uniform(0.2, 1.0), bump = uniform(0.0, 0.02), f = 200;
  std::mt19937 rng(*rc::gen::arbitrary<std::uint32_t>());  // per-pixel draws (see below)
  std::bernoulli_distribution hole(uniform(0.0, 0.3)), jump(uniform(0.0, 0.2));
  std::uniform_real_distribution<double> unit(-1, 1);
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      if (hole(rng)) continue;
      double z = z0 + bump * std::sin(0.7 * u) * std::cos(0.5 * v) + unit(rng) * 1e-3;
      if (jump(rng)) z += 0.1 * unit(rng);
      if (u > w / 2) z += 0.01 * (u - w / 2);  // a crease
      cloud.points[cloud.index(u, v)] = Vector3<double>((u - w / 2.0) / f * z, (v - h / 2.0) / f * z, z).cast<Scalar>();
    }
  OrganizedNormalSettings<Scalar> s;
  s.pixel_offset = *rc::gen::inRange(1, 4);
  s.max_crease_angle = Scalar(uniform(0.1, 3.3));
  s.one_sided_at_edges = *rc::gen::arbitrary<bool>();
  const Scalar cc = registration_detail::cos_crease(s);
  // The vectorized pass at every SIMD level gives organized_normal's bits at every pixel (the pack
  // kernel repeats the scalar operations lane by lane; a build with FMA may contract them apart).
  for (const SimdLevel level : available_simd_levels()) {
    const SimdCap cap(level);
    estimate_organized_normals(cloud, s);
    for (int v = 0; v < h; ++v)
      for (int u = 0; u < w; ++u) {
        const Vector3<Scalar> one = registration_detail::organized_normal(cloud, u, v, s, cc);
        const Vector3<Scalar>& got = cloud.normals[cloud.index(u, v)];
#if defined(__FMA__)
        RC_ASSERT((got - one).norm() <= 1e-5);
#else
        RC_ASSERT(got == one);
#endif
      }
  }
  // Rows on two threads (from 9 rows on): the same normals.
  OrganizedCloud<Scalar> two = cloud;
  OrganizedNormalSettings<Scalar> s2 = s;
  s2.num_threads = 2;
  estimate_organized_normals(two, s2);
  RC_ASSERT(two.normals == cloud.normals);
  std::size_t flips = 0;
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      const Vector3<Scalar> ref = registration_detail::organized_normal_at(cloud, u, v, s, cc);
      const Vector3<Scalar>& got = cloud.normals[cloud.index(u, v)];
      RC_ASSERT(got.allFinite());
      if (ref.isZero() != got.isZero()) {
        ++flips;
        continue;
      }
      RC_ASSERT((got - ref).norm() <= 1e-5);
    }
  RC_ASSERT(flips <= 1u);
}

// subsample_with_normals from a depth image (backprojecting only what it needs) gives exactly the
// points and normals of the organized route, on random scenes with holes.
template <typename Scalar>
void check_depth_subsample_matches_organized() {
  const AnalyticScene scene = random_scene();
  const auto cam = test_camera<Scalar>();
  DepthImage<Scalar> depth = scene.render(cam, Eigen::Isometry3d::Identity());
  // Per-pixel draws from a seeded engine: one generated value per pixel would make cases slow.
  std::mt19937 rng(*rc::gen::arbitrary<std::uint32_t>());
  std::bernoulli_distribution hole(uniform(0.0, 0.3));
  for (int v = 0; v < depth.height(); ++v)
    for (int u = 0; u < depth.width(); ++u)
      if (hole(rng)) depth.at(u, v) = Scalar(0);
  OrganizedNormalSettings<Scalar> s;
  s.pixel_offset = *rc::gen::inRange(1, 5);
  const int stride = *rc::gen::inRange(1, 7);
  const PointCloud<Scalar> direct = subsample_with_normals(depth.view(), cam, stride, s);
  const PointCloud<Scalar> organized = subsample_with_normals(backproject_organized(depth.view(), cam), stride, s);
  RC_ASSERT(direct.points == organized.points);
  RC_ASSERT(direct.normals == organized.normals);
  RC_ASSERT(!direct.empty());
  // Into a cloud kept from an earlier frame (another stride, so another size): the same result.
  PointCloud<Scalar> kept = subsample_with_normals(depth.view(), cam, *rc::gen::inRange(1, 7), s);
  subsample_with_normals(depth.view(), cam, stride, s, kept);
  RC_ASSERT(kept.points == organized.points);
  RC_ASSERT(kept.normals == organized.normals);
}

}  // namespace

// backproject_organized at stride 1 (a pinhole row a pack at a time) gives the per-pixel rule's bits
// at every SIMD level and for every encoding: valid depths, zeros, negatives, NaN, inf and values
// whose backprojection overflows become zero points; odd widths exercise the scalar tail. Rows split
// over two threads give the same cloud.
template <typename Scalar>
void check_backprojection_matches_per_pixel() {
  const int w = *rc::gen::inRange(1, 40), h = *rc::gen::inRange(1, 24);
  const Scalar f = Scalar(uniform(0.5, 600));
  const PinholeCamera<Scalar> cam(f, Scalar(uniform(0.5, 600)), Scalar(uniform(-5, w + 5)), Scalar(uniform(-5, h + 5)),
                                  w, h);
  std::mt19937 rng(*rc::gen::arbitrary<std::uint32_t>());
  std::uniform_real_distribution<double> unit(0, 1);
  const auto special = [&]() -> double {
    switch (int(unit(rng) * 8)) {
      case 0: return 0;
      case 1: return -unit(rng);
      case 2: return std::numeric_limits<double>::quiet_NaN();
      case 3: return std::numeric_limits<double>::infinity();
      case 4: return 0.9 * double(std::numeric_limits<Scalar>::max());
      default: return 0.2 + 2 * unit(rng);
    }
  };
  std::vector<std::uint16_t> raw16(std::size_t(w) * std::size_t(h));
  std::vector<float> raw32(raw16.size());
  std::vector<double> raw64(raw16.size());
  for (std::size_t i = 0; i < raw16.size(); ++i) {
    raw16[i] = std::uint16_t(unit(rng) < 0.2 ? 0 : unit(rng) * 65535);
    raw32[i] = float(special());
    raw64[i] = special();
  }
  const std::vector<DepthImageView<Scalar>> views{DepthImageView<Scalar>(raw16.data(), w, h, 0, Scalar(0.001)),
                                                  DepthImageView<Scalar>(raw32.data(), w, h),
                                                  DepthImageView<Scalar>(raw64.data(), w, h)};
  const registration_detail::PixelBackprojector<Scalar, PinholeCamera<Scalar>> point(cam);
  for (const DepthImageView<Scalar>& view : views)
    for (const SimdLevel level : available_simd_levels()) {
      const SimdCap cap(level);
      const OrganizedCloud<Scalar> cloud = backproject_organized(view, cam);
      RC_ASSERT(cloud.width == w && cloud.height == h);
      for (int v = 0; v < h; ++v)
        for (int u = 0; u < w; ++u) {
          const Vector3<Scalar> expected = point(u, v, view.depth(u, v));
          RC_ASSERT(cloud.points[cloud.index(u, v)] == expected);
          RC_ASSERT(cloud.points[cloud.index(u, v)].allFinite());
        }
      OrganizedCloud<Scalar> threaded;
      backproject_organized(view, cam, 1, threaded, 2);
      RC_ASSERT(threaded.width == w && threaded.height == h);
      RC_ASSERT(threaded.points == cloud.points);
    }
}

RC_GTEST_PROP(Normals, OrganizedOnPlaneDouble, ()) { check_organized_normals_on_plane<double>(); }
RC_GTEST_PROP(Normals, OrganizedOnPlaneFloat, ()) { check_organized_normals_on_plane<float>(); }
RC_GTEST_PROP(Backprojection, OrganizedMatchesPerPixelDouble, ()) { check_backprojection_matches_per_pixel<double>(); }
RC_GTEST_PROP(Backprojection, OrganizedMatchesPerPixelFloat, ()) { check_backprojection_matches_per_pixel<float>(); }
RC_GTEST_PROP(Normals, OrganizedMatchesReferenceDouble, ()) { check_organized_normals_match_reference<double>(); }
RC_GTEST_PROP(Normals, OrganizedMatchesReferenceFloat, ()) { check_organized_normals_match_reference<float>(); }
RC_GTEST_PROP(Normals, DepthSubsampleMatchesOrganizedDouble, ()) { check_depth_subsample_matches_organized<double>(); }
RC_GTEST_PROP(Normals, DepthSubsampleMatchesOrganizedFloat, ()) { check_depth_subsample_matches_organized<float>(); }
RC_GTEST_PROP(Normals, KnnOnPlaneDouble, ()) { check_knn_normals_on_plane<double>(); }
RC_GTEST_PROP(Normals, KnnOnPlaneFloat, ()) { check_knn_normals_on_plane<float>(); }
RC_GTEST_PROP(KdTree, ExactAgainstBruteForceDouble, ()) { check_kdtree_exact<double>(); }
RC_GTEST_PROP(KdTree, ExactAgainstBruteForceFloat, ()) { check_kdtree_exact<float>(); }

TEST(Normals, DepthEdgesAndHolesGiveNoNormalAcrossThem) {
  // A 3×1 strip with a 0.5 m step: the middle pixel's horizontal neighbours are across the edge, so
  // it falls back to one side; a lone valid pixel gets no normal.
  OrganizedCloud<double> c;
  c.width = 3;
  c.height = 3;
  c.points.assign(9, Eigen::Vector3d::Zero());
  c.points[4] = Eigen::Vector3d(0, 0, 1);
  estimate_organized_normals(c);
  EXPECT_TRUE(c.normals[4].isZero());
  OrganizedNormalSettings<double> bad;
  bad.pixel_offset = 0;
  EXPECT_THROW(estimate_organized_normals(c, bad), std::invalid_argument);
}

TEST(ProjectiveAssociation, FindsThePixelAndRespectsTheDistance) {
  const auto cam = test_camera<double>();
  DepthImage<double> depth(cam.width(), cam.height(), 0.5);
  const auto target = make_projective_target(depth.view(), cam);
  std::vector<Eigen::Vector3d> q{cam.backproject(10, 20, 0.5), cam.backproject(10, 20, 0.6),
                                 Eigen::Vector3d(0, 0, -1), cam.backproject(64, 40, 0.503)};
  std::vector<std::ptrdiff_t> partners;
  target.associate(q, 0.01, 1, partners);
  ASSERT_EQ(partners.size(), 4u);
  EXPECT_EQ(partners[0], std::ptrdiff_t(20 * cam.width() + 10));
  EXPECT_EQ(partners[1], -1);  // 10 cm behind
  EXPECT_EQ(partners[2], -1);  // behind the camera
  EXPECT_GE(partners[3], 0);
  EXPECT_NEAR((target.target_point(partners[3]) - q[3]).norm(), 0.003, 1e-3);
}

namespace {

// project_queries() + the rest of the single-pixel rule (valid target point, a normal, within the
// distance) gives partner() for every query, at every SIMD level: random queries near the surface,
// far from it, behind the camera, outside the image, on the pixel borders, and not finite.
template <typename Scalar>
void check_projected_queries_match_partner() {
  const auto cam = test_camera<Scalar>();
  const AnalyticScene scene = random_scene();
  DepthImage<Scalar> depth = scene.render(cam, Eigen::Isometry3d::Identity());
  for (Scalar& d : depth.storage())  // holes
    if (*rc::gen::inRange(0, 10) == 0) d = Scalar(0);
  const auto target = make_projective_target(depth.view(), cam);
  RC_ASSERT(target.pixel_partner());
  const Scalar max_distance = Scalar(uniform(0.001, 0.02));
  const int count = *rc::gen::inRange(1, 300);
  std::vector<Scalar> x, y, z;
  const Scalar nan = std::numeric_limits<Scalar>::quiet_NaN(), inf = std::numeric_limits<Scalar>::infinity();
  for (int i = 0; i < count; ++i) {
    const int kind = *rc::gen::inRange(0, 8);
    Scalar u = Scalar(uniform(-3, cam.width() + 2)), v = Scalar(uniform(-3, cam.height() + 2));
    if (kind == 1) u = Scalar(-0.5);  // pixel borders
    if (kind == 2) u = Scalar(cam.width()) - Scalar(0.5);
    if (kind == 3) v = Scalar(*rc::gen::inRange(0, cam.height())) + Scalar(0.5);
    Scalar zz = Scalar(uniform(0.2, 0.6));
    const int iu = int(std::lround(double(u))), iv = int(std::lround(double(v)));
    if (kind == 4 && iu >= 0 && iv >= 0 && iu < cam.width() && iv < cam.height() && depth.at(iu, iv) > 0)
      zz = depth.at(iu, iv) + Scalar(uniform(-0.01, 0.01));  // near the surface
    Vector3<Scalar> q = cam.backproject(u, v, zz);
    if (kind == 5) q.z() = -q.z();  // behind
    if (kind == 6) q(*rc::gen::inRange(0, 3)) = *rc::gen::inRange(0, 2) ? nan : inf;
    if (kind == 7) q.z() = Scalar(0);
    x.push_back(q.x());
    y.push_back(q.y());
    z.push_back(q.z());
  }
  for (const SimdLevel level : available_simd_levels()) {
    const SimdCap cap(level);
    std::vector<std::ptrdiff_t> index;
    detail::simd_call([&](auto bytes) BINPICK_SIMD_INLINE_LAMBDA {
      constexpr int L = detail::Pack<Scalar, decltype(bytes)::value>::size;
      const int padded = (count + L - 1) / L * L;
      std::vector<Scalar> px(x), py(y), pz(z);
      px.resize(std::size_t(padded));
      py.resize(std::size_t(padded));
      pz.resize(std::size_t(padded));
      index.assign(std::size_t(padded), 0);
      target.template project_queries<decltype(bytes)::value>(px.data(), py.data(), pz.data(), padded, index.data());
    });
    for (int i = 0; i < count; ++i) {
      const Vector3<Scalar> q(x[std::size_t(i)], y[std::size_t(i)], z[std::size_t(i)]);
      const std::ptrdiff_t j = index[std::size_t(i)];
      const auto px = cam.project(q);  // the pixel partner() rounds to
      const int u0 = px ? int(px->x() + Scalar(0.5)) : -1, v0 = px ? int(px->y() + Scalar(0.5)) : -1;
      const bool inside = px && u0 < cam.width() && v0 < cam.height();
      RC_ASSERT(j == (inside ? std::ptrdiff_t(v0) * cam.width() + u0 : std::ptrdiff_t(-1)));
      const bool rule = j >= 0 && target.target_point(j).z() > 0 && target.target_normal(j).squaredNorm() > 0 &&
                        (target.target_point(j) - q).squaredNorm() <= max_distance * max_distance;
      RC_ASSERT(target.partner(q, max_distance) == (rule ? j : std::ptrdiff_t(-1)));
    }
  }
}

}  // namespace

RC_GTEST_PROP(ProjectiveAssociation, ProjectedQueriesMatchPartnerDouble, ()) { check_projected_queries_match_partner<double>(); }
RC_GTEST_PROP(ProjectiveAssociation, ProjectedQueriesMatchPartnerFloat, ()) { check_projected_queries_match_partner<float>(); }
