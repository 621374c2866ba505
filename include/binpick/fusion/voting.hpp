#pragma once
/// \file voting.hpp
/// Candidate voting (paper Alg. 1, lines 2–10). Each target pixel receives one depth per view (after
/// reprojection and z-test). An incoming depth within δ of a candidate is averaged into it and votes
/// for it (lines 4–6); otherwise it becomes a new candidate (line 8). The output is the candidate with
/// the most votes (line 10; ties: the nearest), or no measurement when it has fewer than `min_votes`.
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

/// Votes the pixels [begin, end) of `n` planes (+inf or 0 or non-finite = no depth from that view) into
/// `out` (0 = no measurement) and, when non-null, `votes_out`.
///
/// Branch-free over blocks of pixels, vectorized across pixels: each pixel's depths are
/// sorted with an odd-even transposition network (invalid ones become +inf and sink to the end), then
/// Alg. 1 runs over the sorted depths with selects instead of branches.
template <typename Scalar>
void vote_range(const Scalar* const* planes, int n, std::size_t begin, std::size_t end, Scalar delta, int min_votes,
                Scalar* out, std::uint8_t* votes_out) {
  constexpr std::size_t kBlock = 64;
  const Scalar inf = std::numeric_limits<Scalar>::infinity();
  alignas(64) Scalar s[kMaxFusionViews][kBlock];
  alignas(64) Scalar mean[kBlock], votes_all[kBlock];
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
    // Written with SIMD packs and selects: a conditional division is control flow to the
    // auto-vectorizer.
    using P = Pack<Scalar>;
    using V = typename P::type;
    const V vinf = P::splat(inf), vdelta = P::splat(delta), vone = P::splat(Scalar(1)), vzero = P::splat(Scalar(0));
    for (std::size_t j = 0; j < kBlock; j += std::size_t(P::size)) {
      V m = P::load(&s[0][j]);
      V votes = P::select(m < vinf, vone, vzero);
      V best_mean = vzero, best_votes = vzero;
      for (int k = 1; k < n; ++k) {
        const V d = P::load(&s[k][j]);
        const V diff = d - m;
        const V adiff = P::select(diff < vzero, -diff, diff);
        const auto valid = d < vinf;
        const auto match = valid & (adiff < vdelta);  // lines 4-6: average into it, vote for it
        const auto close = valid & ~match;            // line 8: a new candidate
        const auto better = close & (votes > best_votes);  // ties keep the nearer, earlier one
        best_votes = P::select(better, votes, best_votes);
        best_mean = P::select(better, m, best_mean);
        const V nv = votes + vone;
        const V averaged = m + diff / nv;
        m = P::select(match, averaged, P::select(close, d, m));
        votes = P::select(match, nv, P::select(close, vone, votes));
      }
      const auto better = votes > best_votes;  // line 10: the most votes wins
      P::store(&mean[j], P::select(better, m, best_mean));
      P::store(&votes_all[j], P::select(better, votes, best_votes));
    }
    for (std::size_t j = 0; j < m; ++j) out[b + j] = votes_all[j] >= min_v ? mean[j] : Scalar(0);
    if (votes_out)
      for (std::size_t j = 0; j < m; ++j)
        votes_out[b + j] = std::uint8_t(votes_all[j]);
  }
}

/// vote_range for a view count known at compile time: each pack of pixels keeps its N depths in
/// registers through the sort network and Alg. 1 (no block copies); the tail goes to vote_range.
template <typename Scalar, int N>
void vote_range_fixed(const Scalar* const* planes, std::size_t begin, std::size_t end, Scalar delta, int min_votes,
                      Scalar* out, std::uint8_t* votes_out) {
  using P = Pack<Scalar>;
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
      if (votes_out)
        for (int l = 0; l < P::size; ++l) votes_out[j + std::size_t(l)] = std::uint8_t(count[l]);
      continue;
    }
    for (int pass = 0; pass < N; ++pass)
      for (int k = pass & 1; k + 1 < N; k += 2) {
        const V lo = P::select(d[k] < d[k + 1], d[k], d[k + 1]);
        const V hi = P::select(d[k] < d[k + 1], d[k + 1], d[k]);
        d[k] = lo;
        d[k + 1] = hi;
      }
    V m = d[0];
    V votes = P::select(m < vinf, vone, vzero);
    V best_mean = vzero, best_votes = vzero;
    for (int k = 1; k < N; ++k) {
      const V diff = d[k] - m;
      const V adiff = P::select(diff < vzero, -diff, diff);
      const auto valid = d[k] < vinf;
      const auto match = valid & (adiff < vdelta);
      const auto close = valid & ~match;
      const auto better = close & (votes > best_votes);
      best_votes = P::select(better, votes, best_votes);
      best_mean = P::select(better, m, best_mean);
      const V nv = votes + vone;
      const V averaged = m + diff / nv;
      m = P::select(match, averaged, P::select(close, d[k], m));
      votes = P::select(match, nv, P::select(close, vone, votes));
    }
    const auto better = votes > best_votes;
    const V win_votes = P::select(better, votes, best_votes);
    P::store(out + j, P::select(win_votes >= vmin, P::select(better, m, best_mean), vzero));
    if (votes_out)
      for (int l = 0; l < P::size; ++l) votes_out[j + std::size_t(l)] = std::uint8_t(win_votes[l]);
  }
  if (j < end) vote_range(planes, N, j, end, delta, min_votes, out, votes_out);
}

/// Dispatches to the register-resident kernel for 2..8 views, the block kernel otherwise.
template <typename Scalar>
void vote_pixels(const Scalar* const* planes, int n, std::size_t begin, std::size_t end, Scalar delta, int min_votes,
                 Scalar* out, std::uint8_t* votes_out) {
  switch (n) {
    case 2: return vote_range_fixed<Scalar, 2>(planes, begin, end, delta, min_votes, out, votes_out);
    case 3: return vote_range_fixed<Scalar, 3>(planes, begin, end, delta, min_votes, out, votes_out);
    case 4: return vote_range_fixed<Scalar, 4>(planes, begin, end, delta, min_votes, out, votes_out);
    case 5: return vote_range_fixed<Scalar, 5>(planes, begin, end, delta, min_votes, out, votes_out);
    case 6: return vote_range_fixed<Scalar, 6>(planes, begin, end, delta, min_votes, out, votes_out);
    case 8: return vote_range_fixed<Scalar, 8>(planes, begin, end, delta, min_votes, out, votes_out);
    default: return vote_range(planes, n, begin, end, delta, min_votes, out, votes_out);
  }
}

}  // namespace detail

/// Votes `planes` (each `width * height` depths [m] of the target view; 0, negative, +inf or NaN = no
/// depth) into one depth image (Alg. 1, lines 2–10). `votes` is filled only when non-null.
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
    votes->votes.assign(std::size_t(width) * std::size_t(height), 0);
    v = votes->votes.data();
  }
  detail::vote_pixels(planes.data(), int(planes.size()), 0, std::size_t(width) * std::size_t(height), settings.delta,
                      settings.min_votes, out, v);
}

}  // namespace binpick
