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
/// Fast path: when a pixel's valid depths span less than δ they form one candidate (every depth is
/// within δ of the running mean, which lies between the smallest depth and itself), so the result is
/// their mean with one vote each; only pixels whose depths disagree take the sorting path.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

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

/// Alg. 1 for one pixel on its depths sorted ascending (all valid). Writes the winner's mean and votes.
template <typename Scalar>
inline void vote_sorted(const Scalar* d, int n, Scalar delta, Scalar& out_depth, int& out_votes) {
  Scalar best_mean = Scalar(0);
  int best_votes = 0;
  Scalar mean = d[0];
  int votes = 1;
  for (int i = 1; i < n; ++i) {
    if (std::abs(d[i] - mean) < delta) {  // lines 4-6: average into the candidate and vote for it
      ++votes;
      mean += (d[i] - mean) / Scalar(votes);
    } else {  // line 8: a new candidate; the finished one competes (ties keep the nearer, earlier one)
      if (votes > best_votes) best_votes = votes, best_mean = mean;
      mean = d[i];
      votes = 1;
    }
  }
  if (votes > best_votes) best_votes = votes, best_mean = mean;
  out_depth = best_mean;
  out_votes = best_votes;
}

/// Votes the pixels [begin, end) of `n` planes (+inf or 0 or non-finite = no depth from that view) into
/// `out` (0 = no measurement) and, when non-null, `votes_out`.
template <typename Scalar>
void vote_range(const Scalar* const* planes, int n, std::size_t begin, std::size_t end, Scalar delta, int min_votes,
                Scalar* out, std::uint8_t* votes_out) {
  constexpr std::size_t kBlock = 256;
  const Scalar inf = std::numeric_limits<Scalar>::infinity();
  std::uint16_t slow[kBlock];
  for (std::size_t b = begin; b < end; b += kBlock) {
    const std::size_t e = std::min(end, b + kBlock);
    int nslow = 0;
    // Branch-free fast path over the block (auto-vectorizes): count, min, max of valid depths, then
    // the sum of their differences to the minimum. Those differences are exact (Sterbenz) and integer
    // multiples of the minimum's ulp, so their sum, and the mean, do not depend on the order of the
    // views (exact while n * delta stays below 2^digits ulps: far beyond any real sensor setting).
    for (std::size_t i = b; i < e; ++i) {
      Scalar lo = inf, hi = 0;
      int count = 0;
      for (int k = 0; k < n; ++k) {
        const Scalar v = planes[k][i];
        const bool ok = v > Scalar(0) && v < inf;
        lo = std::min(lo, ok ? v : inf);
        hi = std::max(hi, ok ? v : Scalar(0));
        count += ok;
      }
      Scalar sum = 0;
      for (int k = 0; k < n; ++k) {
        const Scalar v = planes[k][i];
        sum += (v > Scalar(0) && v < inf) ? v - lo : Scalar(0);
      }
      const bool agree = (hi - lo) < delta;
      const Scalar mean = count > 0 ? lo + sum / Scalar(count) : Scalar(0);
      out[i] = (count >= min_votes && agree) ? mean : Scalar(0);
      if (votes_out) votes_out[i] = std::uint8_t(agree ? count : 0);
      if (count > 0 && !agree) slow[nslow++] = std::uint16_t(i - b);
    }
    // Pixels whose views disagree: sort and run Alg. 1.
    for (int s = 0; s < nslow; ++s) {
      const std::size_t i = b + slow[s];
      Scalar d[kMaxFusionViews] = {};
      int m = 0;
      for (int k = 0; k < n; ++k) {
        const Scalar v = planes[k][i];
        if (v > Scalar(0) && v < inf) d[m++] = v;
      }
      std::sort(d, d + m);
      Scalar depth = 0;
      int votes = 0;
      vote_sorted(d, m, delta, depth, votes);
      out[i] = votes >= min_votes ? depth : Scalar(0);
      if (votes_out) votes_out[i] = std::uint8_t(votes);
    }
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
  detail::vote_range(planes.data(), int(planes.size()), 0, std::size_t(width) * std::size_t(height), settings.delta,
                     settings.min_votes, out, v);
}

}  // namespace binpick
