#pragma once
/// \file voting.hpp
/// Candidate voting (paper Alg. 1, lines 2–10). Each target pixel receives one depth per view (after
/// reprojection and z-test). An incoming depth within δ of a candidate is averaged into it and votes
/// for it (lines 4–6); otherwise it becomes a new candidate (line 8). The output is the candidate with
/// the most votes (line 10), or no measurement when it has fewer than `min_votes`. Ties go to the candidate
/// holding the reference view's own depth (the first plane: view 1, whose pose is exact and whose depth
/// needs no reprojection), else to the nearest. With the nearest alone, a pixel where every view
/// disagrees took the smallest of n noisy depths, a bias toward the camera: in the simulated cell
/// (4 views of brass tubes, SENSOR_MODEL.md) 36 % of the part pixels lay more than 1 mm nearer than
/// the truth (median -0.46 mm), 31 % with this rule (median -0.29 mm).
///
/// Order: the algorithm as written depends on the order the depths arrive in. binpick feeds each
/// pixel's depths in ascending order, which makes the result independent of the order of the views and
/// makes "the candidate within δ" unique: with sorted input the last candidate's running mean is the
/// nearest one to the incoming depth, so a pixel's candidate list never holds more than the number of
/// views and needs no storage beyond the per-view planes.
///

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "binpick/core/detail/simd.hpp"
#include "binpick/core/errors.hpp"

namespace binpick {

/// Settings of the voting step.
template <typename Scalar>
struct VotingSettings {
  Scalar delta = Scalar(0.002);  ///< [m] δ of Alg. 1 (line 4); the fusion sets it to 2 × sensor accuracy
  int min_votes = 1;             ///< fewer votes → no measurement; 1 lets a single view pass unchanged
  /// planes[0] is the reference view's own depth, and ties go to it (file comment); false: every plane
  /// is a reprojection (a virtual target camera), ties go to the nearest.
  bool reference_first = true;
};

/// Per-pixel vote count of the fused result (a confidence map), row-major.
struct VoteMap {
  int width = 0, height = 0;
  std::vector<std::uint8_t> votes;
  std::uint8_t at(int u, int v) const { return votes[std::size_t(v) * std::size_t(width) + std::size_t(u)]; }
};

/// The largest number of views one fusion takes (votes are stored in 8 bits; the per-pixel sort is on
/// the stack).
constexpr int kMaxFusionViews = 64;

namespace detail {
BINPICK_SIMD_BEGIN

/// Alg. 1 over one pack of pixels' depths in ascending order (invalid = +inf, last), with selects
/// instead of branches: a conditional division is control flow to the auto-vectorizer. `ref` is the
/// reference view's depth of each pixel (+inf when it has none); the constructor takes the smallest
/// depth, add() each next one, and winner() gives the mean and votes of the chosen candidate.
template <typename Scalar, int Bytes = kPackBytes>
struct SortedVote {
  using P = Pack<Scalar, Bytes>;
  using V = typename P::type;
  const V vinf = P::splat(std::numeric_limits<Scalar>::infinity()), vone = P::splat(Scalar(1)),
          vzero = P::splat(Scalar(0));
  V delta, ref;
  V m, votes, has_ref;                     // the open candidate (always the farthest so far)
  V best_mean = vzero, best_votes = vzero, best_has_ref = vzero;  // the best closed one

  BINPICK_SIMD_INLINE SortedVote(const V& delta_, const V& ref_, const V& d0)
      : delta(delta_), ref(ref_), m(d0), votes(P::select(d0 < vinf, vone, vzero)),
        has_ref(P::select((d0 < vinf) & (d0 == ref_), vone, vzero)) {}
  /// Does the candidate (v, h) beat the best closed one? More votes; on a tie, the reference's.
  BINPICK_SIMD_INLINE auto beats(const V& v, const V& h) const {
    return (v > best_votes) | ((v == best_votes) & (h > best_has_ref));
  }
  BINPICK_SIMD_INLINE void add(const V& d) {
    const V diff = d - m;
    const V adiff = P::select(diff < vzero, -diff, diff);
    const auto valid = d < vinf;
    const auto match = valid & (adiff < delta);  // lines 4-6: average into it, vote for it
    const auto close = valid & ~match;           // line 8: a new candidate
    const auto better = close & beats(votes, has_ref);  // full ties keep the nearer, earlier one
    best_votes = P::select(better, votes, best_votes);
    best_mean = P::select(better, m, best_mean);
    best_has_ref = P::select(better, has_ref, best_has_ref);
    const V nv = votes + vone;
    const V is_ref = P::select(valid & (d == ref), vone, vzero);
    m = P::select(match, m + diff / nv, P::select(close, d, m));
    votes = P::select(match, nv, P::select(close, vone, votes));
    // A new candidate holds the reference if d is it; the open one also if it held it already (an
    // invalid d is no reference: is_ref = 0).
    has_ref = P::select(close, is_ref, P::select(is_ref > has_ref, is_ref, has_ref));
  }
  /// Line 10: the winning candidate's mean and votes.
  BINPICK_SIMD_INLINE void winner(V& mean, V& win_votes) const {
    const auto better = beats(votes, has_ref);
    mean = P::select(better, m, best_mean);
    win_votes = P::select(better, votes, best_votes);
  }
};

/// Votes the pixels [begin, end) of `n` planes (+inf or 0 or non-finite = no depth from that view) into
/// `out` (0 = no measurement) and, when non-null, `votes_out`.
///
/// Branch-free over blocks of pixels, vectorized across pixels: each pixel's depths are
/// sorted with an odd-even transposition network (invalid ones become +inf and sink to the end), then
/// Alg. 1 runs over the sorted depths with selects instead of branches.
template <typename Scalar>
void vote_range(const Scalar* const* planes, int n, std::size_t begin, std::size_t end, Scalar delta, int min_votes,
                bool reference_first, Scalar* out, std::uint8_t* votes_out) {
  constexpr std::size_t kBlock = 64;
  const Scalar inf = std::numeric_limits<Scalar>::infinity();
  alignas(64) Scalar s[kMaxFusionViews][kBlock];
  alignas(64) Scalar mean[kBlock], votes_all[kBlock], ref[kBlock];
  std::fill(ref, ref + kBlock, inf);  // no reference: +inf matches no depth
  const Scalar min_v = Scalar(min_votes);
  for (std::size_t b = begin; b < end; b += kBlock) {
    const std::size_t m = std::min(kBlock, end - b);
    for (int k = 0; k < n; ++k) {
      const Scalar* __restrict p = planes[k] + b;
      Scalar* __restrict sk = s[k];
      for (std::size_t j = 0; j < m; ++j) {
        const Scalar v = p[j];
        sk[j] = ((v > Scalar(0)) & (v < inf)) ? v : inf;
      }
      for (std::size_t j = m; j < kBlock; ++j) sk[j] = inf;
    }
    if (reference_first) std::copy(s[0], s[0] + kBlock, ref);  // the reference view's depths, before the sort
    // Sort each pixel's depths ascending (n passes of compare-exchange on neighbouring planes).
    for (int pass = 0; pass < n; ++pass)
      for (int k = pass & 1; k + 1 < n; k += 2) {
        Scalar* __restrict a = s[k];
        Scalar* __restrict c = s[k + 1];
        for (std::size_t j = 0; j < kBlock; ++j) {
          const Scalar lo = std::min(a[j], c[j]), hi = std::max(a[j], c[j]);
          a[j] = lo;
          c[j] = hi;
        }
      }
    // Alg. 1 on the sorted depths: the last candidate is always the nearest one (see file comment).
    using P = Pack<Scalar>;
    using V = typename P::type;
    const V vdelta = P::splat(delta);
    for (std::size_t j = 0; j < kBlock; j += std::size_t(P::size)) {
      SortedVote<Scalar> sv(vdelta, P::load(&ref[j]), P::load(&s[0][j]));
      for (int k = 1; k < n; ++k) sv.add(P::load(&s[k][j]));
      V mj, vj;
      sv.winner(mj, vj);
      P::store(&mean[j], mj);
      P::store(&votes_all[j], vj);
    }
    for (std::size_t j = 0; j < m; ++j) out[b + j] = votes_all[j] >= min_v ? mean[j] : Scalar(0);
    if (votes_out)
      for (std::size_t j = 0; j < m; ++j)
        votes_out[b + j] = std::uint8_t(votes_all[j]);
  }
}

/// vote_range for a view count known at compile time: each pack of pixels keeps its N depths in
/// registers through the sort network and Alg. 1 (no block copies); the tail goes to vote_range.
/// Packs of `Bytes` (inlined into simd_call's choice, see vote_pixels).
template <typename Scalar, int N, int Bytes>
BINPICK_SIMD_INLINE void vote_range_fixed(const Scalar* const* planes, std::size_t begin, std::size_t end, Scalar delta,
                                          int min_votes, bool reference_first, Scalar* out, std::uint8_t* votes_out) {
  using P = Pack<Scalar, Bytes>;
  using V = typename P::type;
  const Scalar inf = std::numeric_limits<Scalar>::infinity();
  const V vinf = P::splat(inf), vdelta = P::splat(delta), vone = P::splat(Scalar(1)), vzero = P::splat(Scalar(0));
  const V vmin = P::splat(Scalar(min_votes));
  std::size_t j = begin;
  for (; j + std::size_t(P::size) <= end; j += std::size_t(P::size)) {
    V d[N];
    V lo = vinf, hi = vzero, count = vzero;
    for (int k = 0; k < N; ++k) {
      const V v = P::load(planes[k] + j);
      const auto valid = (v > vzero) & (v < vinf);
      d[k] = P::select(valid, v, vinf);
      lo = P::select(d[k] < lo, d[k], lo);
      hi = P::select(valid & (v > hi), v, hi);
      count = count + P::select(valid, vone, vzero);
    }
    // Common case: in every lane the valid depths span less than delta, so they form one candidate
    // (each is within delta of the running mean, which lies between the smallest and itself). Its
    // mean is taken as the minimum plus the mean of the exact differences to it, so it does not
    // depend on the order of the views either.
    if (P::all((hi - lo < vdelta) | (count == vzero))) {
      V sum = vzero;
      for (int k = 0; k < N; ++k) sum = sum + P::select(d[k] < vinf, d[k] - lo, vzero);
      const V mean = lo + sum / P::select(count > vzero, count, vone);
      P::store(out + j, P::select((count >= vmin) & (count > vzero), mean, vzero));
      if (votes_out) P::store_bytes(votes_out + j, count);
      continue;
    }
    const V ref = reference_first ? d[0] : vinf;  // the reference view's depths, before the sort
    for (int pass = 0; pass < N; ++pass)
      for (int k = pass & 1; k + 1 < N; k += 2) {
        const V lo = P::select(d[k] < d[k + 1], d[k], d[k + 1]);
        const V hi = P::select(d[k] < d[k + 1], d[k + 1], d[k]);
        d[k] = lo;
        d[k + 1] = hi;
      }
    SortedVote<Scalar, Bytes> sv(vdelta, ref, d[0]);
    for (int k = 1; k < N; ++k) sv.add(d[k]);
    V win_mean, win_votes;
    sv.winner(win_mean, win_votes);
    P::store(out + j, P::select(win_votes >= vmin, win_mean, vzero));
    if (votes_out) P::store_bytes(votes_out + j, win_votes);
  }
  if (j < end) vote_range(planes, N, j, end, delta, min_votes, reference_first, out, votes_out);
}

/// Dispatches to the register-resident kernel for 2..8 views (at simd_level()), the block kernel
/// otherwise.
template <typename Scalar>
void vote_pixels(const Scalar* const* planes, int n, std::size_t begin, std::size_t end, Scalar delta, int min_votes,
                 bool reference_first, Scalar* out, std::uint8_t* votes_out) {
  simd_call([&](auto bytes) BINPICK_SIMD_INLINE_LAMBDA {
    constexpr int B = decltype(bytes)::value;
    switch (n) {
      case 2: return vote_range_fixed<Scalar, 2, B>(planes, begin, end, delta, min_votes, reference_first, out, votes_out);
      case 3: return vote_range_fixed<Scalar, 3, B>(planes, begin, end, delta, min_votes, reference_first, out, votes_out);
      case 4: return vote_range_fixed<Scalar, 4, B>(planes, begin, end, delta, min_votes, reference_first, out, votes_out);
      case 5: return vote_range_fixed<Scalar, 5, B>(planes, begin, end, delta, min_votes, reference_first, out, votes_out);
      case 6: return vote_range_fixed<Scalar, 6, B>(planes, begin, end, delta, min_votes, reference_first, out, votes_out);
      case 8: return vote_range_fixed<Scalar, 8, B>(planes, begin, end, delta, min_votes, reference_first, out, votes_out);
      default: return vote_range(planes, n, begin, end, delta, min_votes, reference_first, out, votes_out);
    }
  });
}

BINPICK_SIMD_END
}  // namespace detail

/// Votes `planes` (each `width * height` depths [m] of the target view; 0, negative, +inf or NaN = no
/// depth) into one depth image (Alg. 1, lines 2–10); planes[0] is the reference view's own depth (ties
/// go to it, see the file comment). `votes` is filled only when non-null.
/// Throws std::invalid_argument for no planes, more than kMaxFusionViews, δ ≤ 0 or min_votes < 1.
template <typename Scalar>
void vote(const std::vector<const Scalar*>& planes, int width, int height, const VotingSettings<Scalar>& settings,
          Scalar* out, VoteMap* votes = nullptr) {
  require(!planes.empty(), "planes", "is empty");
  require(int(planes.size()) <= kMaxFusionViews, "planes", "holds more than kMaxFusionViews views");
  require(std::isfinite(settings.delta) && settings.delta > Scalar(0), "delta", "must be finite and > 0");
  require(settings.min_votes >= 1, "min_votes", "must be >= 1");
  require(width >= 0 && height >= 0, "width", "image size must be >= 0");
  for (const Scalar* p : planes) require(p != nullptr || width * height == 0, "planes", "holds a null plane");
  std::uint8_t* v = nullptr;
  if (votes) {
    votes->width = width;
    votes->height = height;
    votes->votes.resize(std::size_t(width) * std::size_t(height));  // the vote writes every pixel's count
    v = votes->votes.data();
  }
  detail::vote_pixels(planes.data(), int(planes.size()), 0, std::size_t(width) * std::size_t(height), settings.delta,
                      settings.min_votes, settings.reference_first, out, v);
}

}  // namespace binpick
