#pragma once
/// \file ray_caster.hpp
/// Ray casting over a triangle soup with a bounding volume hierarchy (BVH): binned surface-area
/// heuristic (SAH) splits over the triangle centroids (falling back to a median split), leaves of at
/// most 4 triangles, and a stack traversal that visits the nearer child first. Triangle test: Möller–Trumbore. Built once per
/// scene revision, then queried concurrently (queries are const).

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <vector>

#include "binpick/core/pose.hpp"
#include "binpick/sim/mesh.hpp"

namespace binpick::sim {

template <typename Scalar>
struct RayHit {
  Scalar t = 0;       ///< ray parameter of the hit (distance in units of |direction|)
  int triangle = -1;  ///< index into the caster's triangles
  Scalar u = 0, v = 0;  ///< barycentric coordinates of corners 1 and 2
};

template <typename Scalar>
class RayCaster {
 public:
  using Vec3 = Vector3<Scalar>;

  RayCaster() = default;
  explicit RayCaster(const TriangleMesh<Scalar>& mesh) { build(mesh); }

  /// (Re)builds the hierarchy over the mesh's triangles (triangle indices are kept).
  void build(const TriangleMesh<Scalar>& mesh) {
    const std::size_t n = mesh.triangles.size();
    v0_.resize(n);
    e1_.resize(n);
    e2_.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      const auto& t = mesh.triangles[i];
      v0_[i] = mesh.vertices[std::size_t(t.x())];
      e1_[i] = mesh.vertices[std::size_t(t.y())] - v0_[i];
      e2_[i] = mesh.vertices[std::size_t(t.z())] - v0_[i];
    }
    order_.resize(n);
    std::iota(order_.begin(), order_.end(), 0);
    nodes_.clear();
    nodes_.reserve(2 * n / kLeafSize + 2);
    std::vector<Vec3> centroid(n);
    for (std::size_t i = 0; i < n; ++i) centroid[i] = v0_[i] + (e1_[i] + e2_[i]) / Scalar(3);
    if (n > 0) build_node(0, int(n), centroid);
  }

  std::size_t size() const { return v0_.size(); }

  /// Closest hit with t in (t_min, t_max); false when none.
  bool intersect(const Vec3& origin, const Vec3& dir, Scalar t_min, Scalar t_max, RayHit<Scalar>& hit) const {
    return traverse<false>(origin, dir, t_min, t_max, &hit);
  }
  /// True when any triangle is hit with t in (t_min, t_max) (shadow / visibility rays).
  bool occluded(const Vec3& origin, const Vec3& dir, Scalar t_min, Scalar t_max) const {
    return traverse<true>(origin, dir, t_min, t_max, nullptr);
  }

 private:
  static constexpr int kLeafSize = 4;
  struct Node {
    Vec3 lo, hi;
    int first = 0, count = 0;  // leaf: triangles order_[first, first+count); inner: count = 0, left child
                               // is the next node (depth-first layout), right child is `first`
  };

  int build_node(int begin, int end, const std::vector<Vec3>& centroid) {
    const int index = int(nodes_.size());
    nodes_.emplace_back();
    Vec3 lo = Vec3::Constant(std::numeric_limits<Scalar>::max()), hi = -lo;
    Vec3 clo = lo, chi = hi;
    for (int i = begin; i < end; ++i) {
      const int t = order_[std::size_t(i)];
      const Vec3 a = v0_[std::size_t(t)], b = a + e1_[std::size_t(t)], c = a + e2_[std::size_t(t)];
      lo = lo.cwiseMin(a).cwiseMin(b).cwiseMin(c);
      hi = hi.cwiseMax(a).cwiseMax(b).cwiseMax(c);
      clo = clo.cwiseMin(centroid[std::size_t(t)]);
      chi = chi.cwiseMax(centroid[std::size_t(t)]);
    }
    nodes_[std::size_t(index)].lo = lo;
    nodes_[std::size_t(index)].hi = hi;
    if (end - begin <= kLeafSize) {
      nodes_[std::size_t(index)].first = begin;
      nodes_[std::size_t(index)].count = end - begin;
      return index;
    }
    const int mid = sah_split(begin, end, clo, chi, centroid);
    build_node(begin, mid, centroid);  // = index + 1
    const int right = build_node(mid, end, centroid);
    nodes_[std::size_t(index)].first = right;
    nodes_[std::size_t(index)].count = 0;
    return index;
  }

  static Scalar half_area(const Vec3& lo, const Vec3& hi) {
    const Vec3 e = (hi - lo).cwiseMax(Vec3::Zero());
    return e.x() * e.y() + e.y() * e.z() + e.z() * e.x();
  }

  /// Partitions order_[begin, end) by the cheapest of 16 centroid bins per axis (SAH); returns the
  /// split position, the median of the longest axis when no split beats a leaf's cost ordering.
  int sah_split(int begin, int end, const Vec3& clo, const Vec3& chi, const std::vector<Vec3>& centroid) {
    constexpr int kBins = 16;
    Scalar best_cost = std::numeric_limits<Scalar>::max();
    int best_axis = -1, best_bin = 0;
    for (int axis = 0; axis < 3; ++axis) {
      const Scalar extent = chi[axis] - clo[axis];
      if (!(extent > Scalar(0))) continue;
      Vec3 blo[kBins], bhi[kBins];
      int cnt[kBins] = {0};
      for (int b = 0; b < kBins; ++b) {
        blo[b] = Vec3::Constant(std::numeric_limits<Scalar>::max());
        bhi[b] = -blo[b];
      }
      for (int i = begin; i < end; ++i) {
        const int t = order_[std::size_t(i)];
        const int b = bin_of(centroid[std::size_t(t)][axis], clo[axis], extent, kBins);
        ++cnt[b];
        const Vec3 a = v0_[std::size_t(t)];
        blo[b] = blo[b].cwiseMin(a).cwiseMin(a + e1_[std::size_t(t)]).cwiseMin(a + e2_[std::size_t(t)]);
        bhi[b] = bhi[b].cwiseMax(a).cwiseMax(a + e1_[std::size_t(t)]).cwiseMax(a + e2_[std::size_t(t)]);
      }
      // Sweep: cost of splitting after bin b = A_left N_left + A_right N_right.
      Scalar right_area[kBins];
      int right_count[kBins];
      Vec3 lo = Vec3::Constant(std::numeric_limits<Scalar>::max()), hi = -lo;
      int n = 0;
      for (int b = kBins - 1; b > 0; --b) {
        lo = lo.cwiseMin(blo[b]);
        hi = hi.cwiseMax(bhi[b]);
        n += cnt[b];
        right_area[b] = half_area(lo, hi);
        right_count[b] = n;
      }
      lo = Vec3::Constant(std::numeric_limits<Scalar>::max());
      hi = -lo;
      n = 0;
      for (int b = 0; b < kBins - 1; ++b) {
        lo = lo.cwiseMin(blo[b]);
        hi = hi.cwiseMax(bhi[b]);
        n += cnt[b];
        if (n == 0 || right_count[b + 1] == 0) continue;
        const Scalar cost = half_area(lo, hi) * Scalar(n) + right_area[b + 1] * Scalar(right_count[b + 1]);
        if (cost < best_cost) {
          best_cost = cost;
          best_axis = axis;
          best_bin = b;
        }
      }
    }
    if (best_axis >= 0) {
      const Scalar extent = chi[best_axis] - clo[best_axis];
      const auto mid_it = std::partition(order_.begin() + begin, order_.begin() + end, [&](int t) {
        return bin_of(centroid[std::size_t(t)][best_axis], clo[best_axis], extent, kBins) <= best_bin;
      });
      const int mid = int(mid_it - order_.begin());
      if (mid > begin && mid < end) return mid;
    }
    int axis = 0;
    (chi - clo).maxCoeff(&axis);
    const int mid = (begin + end) / 2;
    std::nth_element(order_.begin() + begin, order_.begin() + mid, order_.begin() + end,
                     [&](int a, int b) { return centroid[std::size_t(a)][axis] < centroid[std::size_t(b)][axis]; });
    return mid;
  }

  static int bin_of(Scalar c, Scalar lo, Scalar extent, int bins) {
    const int b = int((c - lo) / extent * Scalar(bins));
    return std::clamp(b, 0, bins - 1);
  }

  __attribute__((always_inline)) static bool hit_box(const Node& n, const Vec3& o, const Vec3& inv, Scalar t_min, Scalar t_max, Scalar& t_enter) {
    // Slab test; NaN (0 * inf on a slab plane) compares false and leaves the interval unchanged.
    Scalar ta = (n.lo.x() - o.x()) * inv.x(), tb = (n.hi.x() - o.x()) * inv.x();
    Scalar t0 = std::max(t_min, std::min(ta, tb)), t1 = std::min(t_max, std::max(ta, tb));
    ta = (n.lo.y() - o.y()) * inv.y();
    tb = (n.hi.y() - o.y()) * inv.y();
    t0 = std::max(t0, std::min(ta, tb));
    t1 = std::min(t1, std::max(ta, tb));
    ta = (n.lo.z() - o.z()) * inv.z();
    tb = (n.hi.z() - o.z()) * inv.z();
    t0 = std::max(t0, std::min(ta, tb));
    t1 = std::min(t1, std::max(ta, tb));
    t_enter = t0;
    return t0 <= t1;
  }

  __attribute__((always_inline)) bool hit_triangle(int t, const Vec3& o, const Vec3& d, Scalar t_min, Scalar t_max, Scalar& t_out, Scalar& u_out,
                    Scalar& v_out) const {
    const Vec3& e1 = e1_[std::size_t(t)];
    const Vec3& e2 = e2_[std::size_t(t)];
    const Vec3 p = d.cross(e2);
    const Scalar det = e1.dot(p);
    if (!(std::abs(det) > std::numeric_limits<Scalar>::min())) return false;
    const Scalar inv = Scalar(1) / det;
    const Vec3 s = o - v0_[std::size_t(t)];
    // Edges widened by a few ulps: a ray through the edge two triangles share must hit one of them,
    // and rounding can put it outside both (a seam in a floor; the ray then hit what lies behind).
    const Scalar eps = Scalar(64) * std::numeric_limits<Scalar>::epsilon();
    const Scalar u = s.dot(p) * inv;
    if (u < -eps || u > Scalar(1) + eps) return false;
    const Vec3 q = s.cross(e1);
    const Scalar v = d.dot(q) * inv;
    if (v < -eps || u + v > Scalar(1) + eps) return false;
    const Scalar tt = e2.dot(q) * inv;
    if (!(tt > t_min && tt < t_max)) return false;
    t_out = tt;
    u_out = u;
    v_out = v;
    return true;
  }

  template <bool kAny>
  bool traverse(const Vec3& o, const Vec3& d, Scalar t_min, Scalar t_max, RayHit<Scalar>* hit) const {
    if (nodes_.empty()) return false;
    const Vec3 inv(Scalar(1) / d.x(), Scalar(1) / d.y(), Scalar(1) / d.z());
    // Each stack entry is a node whose box the ray enters at `enter`; boxes are tested when pushed.
    struct Entry {
      int node;
      Scalar enter;
    };
    Entry stack[64];
    int top = 0;
    Scalar best = t_max, t_root;
    if (!hit_box(nodes_[0], o, inv, t_min, best, t_root)) return false;
    stack[top++] = {0, t_root};
    bool found = false;
    while (top > 0) {
      const Entry e = stack[--top];
      if (e.enter > best) continue;  // a closer hit was found since it was pushed
      const Node& n = nodes_[std::size_t(e.node)];
      if (n.count > 0) {
        for (int i = n.first; i < n.first + n.count; ++i) {
          const int t = order_[std::size_t(i)];
          Scalar tt, u, v;
          if (!hit_triangle(t, o, d, t_min, best, tt, u, v)) continue;
          if (kAny) return true;
          found = true;
          best = tt;
          hit->t = tt;
          hit->triangle = t;
          hit->u = u;
          hit->v = v;
        }
        continue;
      }
      // Push the farther child first so the nearer one is visited first and shrinks `best`.
      const int left = e.node + 1, right = n.first;
      Scalar tl, tr;
      const bool hl = hit_box(nodes_[std::size_t(left)], o, inv, t_min, best, tl);
      const bool hr = hit_box(nodes_[std::size_t(right)], o, inv, t_min, best, tr);
      if (hl && hr) {
        if (tl <= tr) {
          stack[top++] = {right, tr};
          stack[top++] = {left, tl};
        } else {
          stack[top++] = {left, tl};
          stack[top++] = {right, tr};
        }
      } else if (hl) {
        stack[top++] = {left, tl};
      } else if (hr) {
        stack[top++] = {right, tr};
      }
    }
    return found;
  }

  std::vector<Vec3> v0_, e1_, e2_;
  std::vector<int> order_;
  std::vector<Node> nodes_;
};

}  // namespace binpick::sim
