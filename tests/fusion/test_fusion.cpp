#include <algorithm>
#include <cstdint>
#include <numeric>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include "binpick/fusion.hpp"
#include "binpick/sim/box_scene.hpp"
#include "sim_instances.hpp"  // Fuser<float / double, pinhole>, compiled once
#include "test_support.hpp"

using namespace binpick;
using binpick::test::uniform;

namespace {

template <typename Scalar>
PinholeCamera<Scalar> small_camera() {
  // 160 x 128 pixels with the sensor's field of view (about 75 x 50 cm at 0.3 m is wider; tests only
  // need a plausible one).
  return PinholeCamera<Scalar>(Scalar(200), Scalar(200), Scalar(79.5), Scalar(63.5), 160, 128);
}

template <typename Scalar>
std::vector<DepthImageView<Scalar>> views_of(const std::vector<DepthImage<Scalar>>& images) {
  std::vector<DepthImageView<Scalar>> v;
  for (const auto& im : images) v.push_back(im.view());
  return v;
}

template <typename Scalar>
std::vector<Isometry3<Scalar>> cast_poses(const std::vector<Isometry3<double>>& poses) {
  std::vector<Isometry3<Scalar>> out;
  for (const auto& p : poses) out.push_back(p.cast<Scalar>());
  return out;
}

// Pixels whose 3x3 neighbourhood of true depth is smooth (no depth edge), valid in truth.
template <typename Scalar>
bool smooth(const DepthImage<Scalar>& truth, int u, int v) {
  if (u < 1 || v < 1 || u >= truth.width() - 1 || v >= truth.height() - 1) return false;
  Scalar lo = truth.at(u, v), hi = lo;
  for (int dv = -1; dv <= 1; ++dv)
    for (int du = -1; du <= 1; ++du) {
      lo = std::min(lo, truth.at(u + du, v + dv));
      hi = std::max(hi, truth.at(u + du, v + dv));
    }
  return lo > 0 && hi - lo < Scalar(0.004);
}

// Alg. 1 written naively: per pixel a growable candidate list, each depth compared with every
// candidate (nearest one within delta wins), depths taken in the given order. The most votes win;
// ties go to a candidate that took a depth equal to `reference` (the reference view's), else to the
// nearest.
template <typename Scalar>
void naive_vote(const std::vector<Scalar>& depths, Scalar reference, Scalar delta, int min_votes, Scalar& out,
                int& out_votes) {
  struct Candidate {
    Scalar mean;
    int votes;
    bool has_reference;
  };
  std::vector<Candidate> c;
  for (Scalar d : depths) {
    if (!(d > 0 && std::isfinite(d))) continue;
    int best = -1;
    for (int k = 0; k < int(c.size()); ++k)
      if (std::abs(d - c[k].mean) < delta && (best < 0 || std::abs(d - c[k].mean) < std::abs(d - c[best].mean))) best = k;
    if (best >= 0) {
      c[best].votes++;
      c[best].mean += (d - c[best].mean) / Scalar(c[best].votes);
      c[best].has_reference = c[best].has_reference || d == reference;
    } else {
      c.push_back({d, 1, d == reference});
    }
  }
  const Candidate* win = nullptr;
  for (const auto& k : c)
    if (!win || k.votes > win->votes ||
        (k.votes == win->votes && (k.has_reference > win->has_reference ||
                                   (k.has_reference == win->has_reference && k.mean < win->mean))))
      win = &k;
  out_votes = win ? win->votes : 0;
  out = win && out_votes >= min_votes ? win->mean : Scalar(0);
}

template <typename Scalar>
void identical_copies_return_the_view() {
  const auto cam = small_camera<Scalar>();
  const auto scene = sim::boxes_scene();
  const auto T = sim::arc_poses(1)[0];
  const DepthImage<Scalar> img = scene.render<Scalar>(cam, T);
  const int n = *rc::gen::inRange(1, 7);
  std::vector<DepthImage<Scalar>> imgs(std::size_t(n), img);
  std::vector<Isometry3<double>> poses(std::size_t(n), T);
  FusionSettings<Scalar> s;
  s.compute_votes = true;
  s.num_threads = *rc::gen::inRange(1, 3);
  const auto r = fuse(views_of(imgs), cast_poses<Scalar>(poses), cam, s);
  for (int v = 0; v < cam.height(); ++v)
    for (int u = 0; u < cam.width(); ++u) {
      const Scalar d = img.at(u, v);
      RC_ASSERT(std::abs(r.depth.at(u, v) - d) <= Scalar(1e-6) * d);
      RC_ASSERT(int(r.votes.at(u, v)) == (d > 0 ? n : 0));
    }
}

}  // namespace

RC_GTEST_PROP(Fusion, IdenticalCopiesReturnTheViewDouble, ()) { identical_copies_return_the_view<double>(); }
RC_GTEST_PROP(Fusion, IdenticalCopiesReturnTheViewFloat, ()) { identical_copies_return_the_view<float>(); }

TEST(Fusion, SingleViewPassesThroughUnchanged) {
  const auto cam = small_camera<float>();
  DepthImage<float> img = sim::boxes_scene().render<float>(cam, sim::arc_poses(1)[0]);
  img.at(3, 3) = NAN;
  img.at(4, 3) = -1.0f;
  const auto r = fuse<float>({img.view()}, {Isometry3f::Identity()}, cam);
  for (int v = 0; v < cam.height(); ++v)
    for (int u = 0; u < cam.width(); ++u) {
      const float d = img.at(u, v);
      EXPECT_EQ(r.depth.at(u, v), (d > 0 && std::isfinite(d)) ? d : 0.0f) << u << "," << v;
    }
  EXPECT_EQ(r.views[0].valid_pixels, r.valid_pixels);
}

// Views 2..n in any order give a bit-identical result (voting sorts each pixel's depths).
RC_GTEST_PROP(Fusion, IndependentOfTheOrderOfViews2ToN, ()) {
  const auto cam = small_camera<float>();
  const auto scene = sim::boxes_scene();
  const auto poses = sim::arc_poses(5);
  std::mt19937 rng(*rc::gen::arbitrary<std::uint32_t>());
  std::normal_distribution<float> noise(0.0f, 0.0015f);
  std::vector<DepthImage<float>> imgs;
  for (const auto& T : poses) {
    DepthImage<float> img = scene.render<float>(cam, T);
    for (float& d : img.storage())
      if (d > 0) d += (rng() % 50 == 0) ? 0.03f : noise(rng);  // noise and a few ghosts
    imgs.push_back(img);
  }
  FusionSettings<float> s;
  s.compute_votes = true;
  const auto a = fuse(views_of(imgs), cast_poses<float>(poses), cam, s);
  std::vector<std::size_t> order{1, 2, 3, 4};
  std::shuffle(order.begin(), order.end(), rng);
  std::vector<DepthImage<float>> imgs2{imgs[0]};
  std::vector<Isometry3<double>> poses2{poses[0]};
  for (std::size_t i : order) imgs2.push_back(imgs[i]), poses2.push_back(poses[i]);
  s.num_threads = 2;
  const auto b = fuse(views_of(imgs2), cast_poses<float>(poses2), cam, s);
  const bool same_depth = a.depth.storage() == b.depth.storage();
  const bool same_votes = a.votes.votes == b.votes.votes;
  RC_ASSERT(same_depth);
  RC_ASSERT(same_votes);
}

class FusionScene : public ::testing::Test {
 protected:
  void SetUp() override {
    poses = sim::arc_poses(4);
    for (const auto& T : poses) truth.push_back(scene.render<double>(cam, T));
  }
  PinholeCamera<double> cam = small_camera<double>();
  sim::BoxScene scene = sim::boxes_scene();
  std::vector<Isometry3<double>> poses;
  std::vector<DepthImage<double>> truth;
};

TEST_F(FusionScene, FusedDepthEqualsTruthWhereTwoViewsSawTheSurface) {
  FusionSettings<double> s;
  s.compute_votes = true;
  const auto r = fuse(views_of(truth), poses, cam, s);
  int checked = 0;
  for (int v = 0; v < cam.height(); ++v)
    for (int u = 0; u < cam.width(); ++u) {
      if (r.votes.at(u, v) < 2 || !smooth(truth[0], u, v)) continue;
      // A reprojected point lands up to half a pixel from a pixel centre: on the tilted floor and box
      // tops that is well under a millimetre of depth.
      EXPECT_NEAR(r.depth.at(u, v), truth[0].at(u, v), 1e-3) << u << "," << v;
      ++checked;
    }
  EXPECT_GT(checked, cam.width() * cam.height() / 2);
  EXPECT_TRUE(r.T_base_target.isApprox(poses[0]));
}

TEST_F(FusionScene, InjectedWrongDepthIsVotedOutWithMinVotes2) {
  auto views = truth;
  for (int v = 40; v < 60; ++v)
    for (int u = 60; u < 90; ++u) views[2].at(u, v) -= 0.012;  // a ghost 12 mm in front of the surface
  const auto ghost_pixels = reproject(views[2].view(), cam, relative_pose(poses[0], poses[2]), cam);
  FusionSettings<double> s;
  s.min_votes = 2;
  const auto r = fuse(views_of(views), poses, cam, s);
  int ghost_seen = 0, ghost_landed = 0;
  for (int v = 0; v < cam.height(); ++v)
    for (int u = 0; u < cam.width(); ++u) {
      const double g = ghost_pixels.at(u, v);
      if (g > 0 && smooth(truth[0], u, v) && std::abs(g - truth[0].at(u, v)) > 0.008) {
        ++ghost_landed;
        ghost_seen += std::abs(r.depth.at(u, v) - g) < 0.01;
      }
    }
  EXPECT_GT(ghost_landed, 200);  // the ghost did reach view 1...
  EXPECT_EQ(ghost_seen, 0);      // ...and was voted out everywhere
}

TEST_F(FusionScene, HolesInView1AreFilledFromOtherViews) {
  auto views = truth;
  for (int v = 50; v < 80; ++v)
    for (int u = 50; u < 100; ++u) views[0].at(u, v) = 0;  // a specular dropout in the reference view
  const auto r = fuse(views_of(views), poses, cam, FusionSettings<double>{});
  int filled = 0, hole = 0;
  for (int v = 50; v < 80; ++v)
    for (int u = 50; u < 100; ++u) {
      if (!smooth(truth[0], u, v)) continue;
      ++hole;
      if (r.depth.at(u, v) > 0) {
        ++filled;
        EXPECT_NEAR(r.depth.at(u, v), truth[0].at(u, v), 1e-3);
      }
    }
  EXPECT_GT(filled, hole * 9 / 10);
}

TEST_F(FusionScene, VirtualTargetMatchesItsTruth) {
  // Fuse views 2..4 into the pose of view 1 without using view 1's depth.
  std::vector<DepthImage<double>> others(truth.begin() + 1, truth.end());
  std::vector<Isometry3<double>> other_poses(poses.begin() + 1, poses.end());
  Fuser<double, PinholeCamera<double>> fuser(cam);
  const auto r = fuser.fuse_virtual(poses[0], views_of(others), other_poses, FusionSettings<double>{});
  // Without a depth of the target itself, forward warping leaves cracks (a target pixel no source
  // pixel lands on) through which a surface hidden from the target can leak at occlusion edges; the
  // fused depth is right almost everywhere else.
  int checked = 0, right = 0;
  for (int v = 0; v < cam.height(); ++v)
    for (int u = 0; u < cam.width(); ++u)
      if (r.depth.at(u, v) > 0 && smooth(truth[0], u, v)) {
        right += std::abs(r.depth.at(u, v) - truth[0].at(u, v)) < 1e-3;
        ++checked;
      }
  EXPECT_GT(checked, cam.width() * cam.height() / 2);
  EXPECT_GT(right, checked * 97 / 100);
}

TEST(Reproject, BrownConradySourceIntoPinholeTargetMatchesTruth) {
  const BrownConradyCamera<double> src(200, 200, 79.5, 63.5, 160, 128, {-0.1, 0.02, 0.001, -0.0005, 0.0});
  const PinholeCamera<double> dst = small_camera<double>();
  const auto scene = sim::boxes_scene();
  const auto poses = sim::arc_poses(2);
  const auto src_img = scene.render<double>(src, poses[1]);
  const auto truth = scene.render<double>(dst, poses[0]);
  const auto r = reproject(src_img.view(), src, relative_pose(poses[0], poses[1]), dst);
  int checked = 0;
  for (int v = 0; v < dst.height(); ++v)
    for (int u = 0; u < dst.width(); ++u)
      if (r.at(u, v) > 0 && smooth(truth, u, v)) {
        EXPECT_NEAR(r.at(u, v), truth.at(u, v), 1.5e-3);
        ++checked;
      }
  EXPECT_GT(checked, 5000);
}

// The pinhole model under another type: reproject() then takes its generic per-point path (the
// camera's own project()), the reference for the vectorized pinhole kernel.
template <typename S>
struct OpaquePinhole {
  using Scalar = S;
  PinholeCamera<Scalar> c;
  int width() const { return c.width(); }
  int height() const { return c.height(); }
  auto project(const Eigen::Matrix<Scalar, 3, 1>& p) const { return c.project(p); }
  Eigen::Matrix<Scalar, 3, 1> backproject(Scalar u, Scalar v, Scalar d) const { return c.backproject(u, v, d); }
};

// Differential: the vectorized pinhole reprojection against the generic path, on random poses,
// widths that leave a tail after the last pack, uint16 and float depths with holes, NaN and inf, at
// every SIMD level, from a pinhole and from a distorted source. Both round each point to the nearest
// pixel; only points within float rounding of a pixel border may land one pixel apart.
template <typename Scalar>
void pinhole_kernel_matches_generic_path() {
  const int w = *rc::gen::inRange(25, 90), h = *rc::gen::inRange(16, 40);
  const Scalar f = Scalar(*rc::gen::inRange(60, 200));
  const PinholeCamera<Scalar> cam(f, f * Scalar(1.05), Scalar(w) * Scalar(0.47), Scalar(h) * Scalar(0.53), w, h);
  std::mt19937 rng(*rc::gen::arbitrary<std::uint32_t>());
  std::uniform_real_distribution<double> depth(0.25, 0.6), angle(-0.05, 0.05), shift(-0.01, 0.01);
  const bool millimetres = *rc::gen::arbitrary<bool>();
  std::vector<std::uint16_t> mm(std::size_t(w) * std::size_t(h));
  DepthImage<Scalar> metres(w, h);
  for (std::size_t i = 0; i < mm.size(); ++i) {
    const unsigned r = rng() % 40;
    const double d = depth(rng);
    mm[i] = r == 0 ? std::uint16_t(0) : std::uint16_t(std::lround(d * 1000));
    metres.storage()[i] = r == 0 ? Scalar(0) : r == 1 ? std::numeric_limits<Scalar>::quiet_NaN()
                          : r == 2 ? std::numeric_limits<Scalar>::infinity() : r == 3 ? Scalar(-d) : Scalar(d);
  }
  const DepthImageView<Scalar> view = millimetres ? DepthImageView<Scalar>(mm.data(), w, h, 0, Scalar(0.001)) : metres.view();
  Isometry3<Scalar> T = Isometry3<Scalar>::Identity();
  const Eigen::Matrix<Scalar, 3, 1> turn = test::draw3<Scalar>([&] { return angle(rng); });  // a fixed order
  T.linear() = (Eigen::AngleAxis<Scalar>(turn.x(), Vector3<Scalar>::UnitX()) *
                Eigen::AngleAxis<Scalar>(turn.y(), Vector3<Scalar>::UnitY()) *
                Eigen::AngleAxis<Scalar>(turn.z(), Vector3<Scalar>::UnitZ())).toRotationMatrix();
  T.translation() = test::draw3<Scalar>([&] { return shift(rng); });
  // A distorted source has one ray per pixel (the kernel's non-separable rows), a pinhole one a ray
  // per row and column.
  const bool distorted = *rc::gen::arbitrary<bool>();
  const BrownConradyCamera<Scalar> lens(cam.fx(), cam.fy(), cam.cx(), cam.cy(), w, h,
                                        {Scalar(-0.08), Scalar(0.01), Scalar(0.001), Scalar(-0.0005), Scalar(0)});
  const auto reproject_into = [&](const auto& target) {
    return distorted ? reproject(view, lens, T, target) : reproject(view, cam, T, target);
  };
  const DepthImage<Scalar> generic = reproject_into(OpaquePinhole<Scalar>{cam});
  RC_ASSERT(generic.valid_count() > std::size_t(0));
  for (const SimdLevel level : available_simd_levels()) {
    const test::SimdCap cap(level);
    const DepthImage<Scalar> fast = reproject_into(cam);
    std::size_t differ = 0;
    for (std::size_t i = 0; i < fast.storage().size(); ++i) {
      const Scalar a = fast.storage()[i], b = generic.storage()[i];
      RC_ASSERT(std::isfinite(a) && a >= Scalar(0));
      if (a > Scalar(0) && b > Scalar(0) && std::abs(a - b) <= Scalar(1e-5) * b) continue;
      differ += !(a == b);
    }
    RC_ASSERT(differ * 100 <= fast.storage().size());  // at most 1 % of the pixels, at a border
  }
}
RC_GTEST_PROP(Reproject, PinholeKernelMatchesGenericPathFloat, ()) { pinhole_kernel_matches_generic_path<float>(); }
RC_GTEST_PROP(Reproject, PinholeKernelMatchesGenericPathDouble, ()) { pinhole_kernel_matches_generic_path<double>(); }

// Differential: the optimized voting against the naive reference, on random per-pixel depths with
// clusters, ghosts and invalid values; at every SIMD level this machine runs (37 pixels a row: packs
// and a tail).
RC_GTEST_PROP(Voting, MatchesNaiveReference, ()) {
  const int n = *rc::gen::inRange(1, 9);
  const int w = 37, h = 11;
  std::mt19937 rng(*rc::gen::arbitrary<std::uint32_t>());
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const double delta = uniform(0.0005, 0.005);
  const int min_votes = *rc::gen::inRange(1, 4);
  const bool reference_first = *rc::gen::arbitrary<bool>();
  std::vector<std::vector<double>> planes(std::size_t(n), std::vector<double>(std::size_t(w * h)));
  for (int i = 0; i < w * h; ++i) {
    const double base = 0.2 + 0.3 * unit(rng);
    for (int k = 0; k < n; ++k) {
      const double r = unit(rng);
      double d = base + (unit(rng) - 0.5) * delta * 0.8;        // agreeing views
      if (r < 0.25) d = base + 0.01 + unit(rng) * 0.05;          // ghosts
      else if (r < 0.35) d = base + (unit(rng) - 0.5) * delta * 3;  // near the threshold
      else if (r < 0.45) d = 0;                                  // dropout
      else if (r < 0.48) d = std::numeric_limits<double>::infinity();
      else if (r < 0.50) d = std::numeric_limits<double>::quiet_NaN();
      else if (r < 0.52) d = -base;
      planes[std::size_t(k)][std::size_t(i)] = d;
    }
  }
  std::vector<const double*> ptrs;
  for (const auto& p : planes) ptrs.push_back(p.data());
  for (const SimdLevel level : available_simd_levels()) {
  const test::SimdCap cap(level);
  std::vector<double> out(std::size_t(w * h));
  VoteMap votes;
  vote<double>(ptrs, w, h, {delta, min_votes, reference_first}, out.data(), &votes);
  for (int i = 0; i < w * h; ++i) {
    std::vector<double> d;
    for (int k = 0; k < n; ++k) d.push_back(planes[std::size_t(k)][std::size_t(i)]);
    // Alg. 1 in ascending order (the order binpick documents); valid depths only.
    d.erase(std::remove_if(d.begin(), d.end(), [](double x) { return !(x > 0 && std::isfinite(x)); }), d.end());
    std::sort(d.begin(), d.end());
    double ref;
    int ref_votes;
    const double reference = reference_first ? planes[0][std::size_t(i)] : std::numeric_limits<double>::infinity();
    naive_vote(d, reference, delta, min_votes, ref, ref_votes);
    RC_ASSERT(std::abs(out[std::size_t(i)] - ref) <= 1e-12);
    RC_ASSERT(int(votes.votes[std::size_t(i)]) == ref_votes);
    RC_ASSERT(std::isfinite(out[std::size_t(i)]));
  }
  }
}

// Where each pixel's depths form clusters further apart than 2 delta, Alg. 1 in the views' own order
// gives the same answer as binpick's sorted order.
RC_GTEST_PROP(Voting, SeparatedClustersAgreeWithViewOrder, ()) {
  const int n = *rc::gen::inRange(2, 9);
  const double delta = 0.002;
  std::mt19937 rng(*rc::gen::arbitrary<std::uint32_t>());
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<double> d;
  for (int k = 0; k < n; ++k) {
    const double level = unit(rng), jitter = unit(rng);  // one draw per declarator: a fixed order
    d.push_back(0.3 + 0.01 * int(level * 3) + jitter * delta * 0.45);
  }
  std::vector<const double*> ptrs;
  for (const double& x : d) ptrs.push_back(&x);
  double out;
  VoteMap votes;
  vote<double>(ptrs, 1, 1, {delta, 1}, &out, &votes);
  double ref;
  int ref_votes;
  naive_vote(d, d[0], delta, 1, ref, ref_votes);
  RC_ASSERT(std::abs(out - ref) <= 1e-9);
  RC_ASSERT(int(votes.votes[0]) == ref_votes);
}

// Ties of votes go to the reference view's candidate (planes[0]), else to the nearest; more votes
// still win. Both kernels: the register one (4 views) and the block one (7 views).
TEST(Voting, TiesGoToTheReferenceViewsCandidate) {
  const float delta = 0.002f, none = 0.f;
  struct Case {
    std::vector<float> depths;  // [0] = the reference view
    float expected;
    int votes;
    float expected_without_reference;  // reference_first = false: ties go to the nearest
  };
  const std::vector<Case> cases = {
      {{0.305f, 0.300f, 0.310f, 0.315f}, 0.305f, 1, 0.300f},        // all disagree: the reference's own depth
      {{0.3105f, 0.3000f, 0.3005f, 0.3100f}, 0.31025f, 2, 0.30025f},  // 2 : 2, the reference in the farther pair
      {{none, 0.3000f, 0.3005f, 0.3100f}, 0.30025f, 2, 0.30025f},   // no reference depth: more votes win
      {{0.310f, 0.300f, 0.3005f, 0.3001f}, 0.3002f, 3, 0.3002f},    // more votes beat the reference
      {{none, 0.305f, 0.300f, 0.310f}, 0.300f, 1, 0.300f},          // no reference, all disagree: the nearest
  };
  for (const Case& c : cases)
    for (const int n : {4, 7}) {
      std::vector<float> d = c.depths;
      while (int(d.size()) < n) d.push_back(none);  // views without a depth here
      std::vector<const float*> ptrs;
      for (const float& x : d) ptrs.push_back(&x);
      float out = -1;
      VoteMap votes;
      vote<float>(ptrs, 1, 1, {delta, 1}, &out, &votes);
      EXPECT_NEAR(out, c.expected, 1e-6f) << "case " << (&c - cases.data()) << ", " << n << " views";
      EXPECT_EQ(int(votes.votes[0]), c.votes) << "case " << (&c - cases.data()) << ", " << n << " views";
      // Without a reference view (a virtual target camera), ties go to the nearest.
      vote<float>(ptrs, 1, 1, {delta, 1, false}, &out, &votes);
      EXPECT_NEAR(out, c.expected_without_reference, 1e-6f)
          << "case " << (&c - cases.data()) << ", " << n << " views, no reference";
    }
}

// The AVX2 kernels chosen at run time do what the baseline ones do: reprojection to the bit (no FMA,
// the same operations per lane); the vote to the bit in its votes and within float rounding in depth
// (pixels whose views all agree take a shortcut decided per pack, and a pack is 8 pixels wide, not 4).
// An odd width (157) leaves a tail in every row.
TEST(Simd, AVX2KernelsMatchTheBaseline) {
  const std::vector<SimdLevel> levels = available_simd_levels();
  if (levels.size() < 2) GTEST_SKIP() << "this build or CPU runs one SIMD level only";
  const PinholeCamera<float> cam(200.f, 200.f, 78.f, 56.f, 157, 113);
  const auto scene = sim::boxes_scene();
  const auto poses = sim::arc_poses(4);
  std::mt19937 rng(7);
  std::normal_distribution<float> noise(0.f, 0.0015f);
  std::vector<DepthImage<float>> imgs;
  for (const auto& T : poses) {
    auto img = scene.render<float>(cam, T);
    for (auto& d : img.storage())
      if (d > 0) d += (rng() % 50 == 0) ? 0.03f : noise(rng);
    imgs.push_back(img);
  }
  FusionSettings<float> s;
  s.compute_votes = true;
  s.register_views = false;
  std::vector<DepthImage<float>> reprojected;
  std::vector<FusionResult<float>> fused;
  for (const SimdLevel level : levels) {
    const test::SimdCap cap(level);
    ASSERT_EQ(simd_level(), level);
    reprojected.push_back(reproject(imgs[1].view(), cam, Isometry3f(relative_pose(poses[0], poses[1]).cast<float>()), cam));
    fused.push_back(fuse(views_of(imgs), cast_poses<float>(poses), cam, s));
  }
  EXPECT_GT(reprojected[0].valid_count(), std::size_t(cam.width() * cam.height() / 2));
  EXPECT_TRUE(reprojected[0].storage() == reprojected[1].storage());
  EXPECT_TRUE(fused[0].votes.votes == fused[1].votes.votes);
  std::size_t disagreeing = 0;
  for (std::size_t i = 0; i < fused[0].depth.storage().size(); ++i) {
    const float a = fused[0].depth.storage()[i], b = fused[1].depth.storage()[i];
    ASSERT_LE(std::abs(a - b), 1e-6f * a) << "pixel " << i;
    disagreeing += fused[0].votes.votes[i] > 0 && fused[0].votes.votes[i] < 4;
  }
  EXPECT_GT(disagreeing, std::size_t(100));  // the full Alg. 1 path ran, not only the shortcut
}

TEST(Fusion, BadInputThrowsNamingTheArgument) {
  const auto cam = small_camera<float>();
  DepthImage<float> img(cam.width(), cam.height(), 0.3f);
  DepthImage<float> small(10, 10, 0.3f);
  auto expect_names = [](auto&& f, const char* arg) {
    try {
      f();
      ADD_FAILURE() << "no exception for " << arg;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(std::string("'") + arg + "'"), std::string::npos) << e.what();
    }
  };
  const Isometry3f I = Isometry3f::Identity();
  expect_names([&] { fuse<float>({}, {}, cam); }, "views");
  expect_names([&] { fuse<float>({img.view(), img.view()}, {I}, cam); }, "T_base_views");
  expect_names([&] { fuse<float>({img.view(), small.view()}, {I, I}, cam); }, "views");
  Isometry3f bad = I;
  bad.translation().x() = NAN;
  expect_names([&] { fuse<float>({img.view(), img.view()}, {I, bad}, cam); }, "T_base_views");
  FusionSettings<float> s;
  s.delta = -1;
  expect_names([&] { fuse<float>({img.view()}, {I}, cam, s); }, "delta");
  s = {};
  s.sensor_accuracy = 0;
  expect_names([&] { fuse<float>({img.view()}, {I}, cam, s); }, "sensor_accuracy");
  s = {};
  s.min_votes = 0;
  expect_names([&] { fuse<float>({img.view()}, {I}, cam, s); }, "min_votes");
  s = {};
  s.num_threads = -1;
  expect_names([&] { fuse<float>({img.view()}, {I}, cam, s); }, "num_threads");
  expect_names([&] { PinholeCamera<float>(0, 200, 1, 1, 10, 10); }, "fx");
  expect_names([&] { PinholeCamera<float>(200, -5, 1, 1, 10, 10); }, "fy");
  std::vector<const float*> none;
  float out;
  expect_names([&] { vote<float>(none, 1, 1, {}, &out); }, "planes");
}

TEST(Fusion, NaNAndNegativeDepthsAreInvalidNeverPropagated) {
  const auto cam = small_camera<float>();
  DepthImage<float> a(cam.width(), cam.height(), 0.3f), b(cam.width(), cam.height(), 0.3f);
  for (int u = 0; u < cam.width(); ++u) a.at(u, 5) = NAN, b.at(u, 5) = -0.3f, a.at(u, 6) = INFINITY;
  const auto r = fuse<float>({a.view(), b.view()}, {Isometry3f::Identity(), Isometry3f::Identity()}, cam);
  for (float d : r.depth.storage()) ASSERT_TRUE(std::isfinite(d));
  for (int u = 0; u < cam.width(); ++u) EXPECT_EQ(r.depth.at(u, 5), 0.0f);
  for (int u = 0; u < cam.width(); ++u) EXPECT_FLOAT_EQ(r.depth.at(u, 6), 0.3f);  // b alone
}

TEST(Fusion, Uint16MillimetreViewsFuseLikeMetres) {
  const auto cam = small_camera<float>();
  const auto scene = sim::boxes_scene();
  const auto poses = sim::arc_poses(3);
  std::vector<std::vector<std::uint16_t>> mm;
  std::vector<DepthImage<float>> metres;
  for (const auto& T : poses) {
    const auto img = scene.render<float>(cam, T);
    std::vector<std::uint16_t> m(img.storage().size());
    DepthImage<float> back(cam.width(), cam.height());
    for (std::size_t i = 0; i < m.size(); ++i) {
      m[i] = std::uint16_t(std::lround(img.storage()[i] * 1000.0f));
      back.storage()[i] = float(m[i]) * 0.001f;
    }
    mm.push_back(m);
    metres.push_back(back);
  }
  std::vector<DepthImageView<float>> views16;
  for (const auto& m : mm) views16.emplace_back(m.data(), cam.width(), cam.height(), 0, 0.001f);
  const auto a = fuse(views16, cast_poses<float>(poses), cam);
  const auto b = fuse(views_of(metres), cast_poses<float>(poses), cam);
  ASSERT_EQ(a.depth.storage().size(), b.depth.storage().size());
  for (std::size_t i = 0; i < a.depth.storage().size(); ++i) EXPECT_FLOAT_EQ(a.depth.storage()[i], b.depth.storage()[i]);
  EXPECT_GT(a.valid_pixels, std::size_t(cam.width() * cam.height() / 2));
}
