#pragma once
// The walk over a ball that Lavoue's reference code (MEPP's Curvature and MSDM components,
// MEPP2's curvature.hpp and msdm2.h) uses for the normal-cycle curvature and for the MSDM
// windows: from the center O, every edge of O; from every vertex v reached, every edge that
// leaves v away from O ((w - v) . (v - O) > 0). Each such edge is clipped to the sphere of
// radius r around O; when its far end w lies inside, the walk goes on from w. Every edge is
// seen at most once (from its end nearer O), and the set seen does not depend on the order.

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <vector>

#include "meshmark/core/mesh.h"

namespace meshmark::detail {

/// Scratch space of walk_sphere, reused across walks: stamp of size #V, a stack, a counter.
struct WalkScratch {
  std::vector<int> stamp;
  std::vector<int> stack;
  int mark = 0;
  explicit WalkScratch(Eigen::Index nv) : stamp(static_cast<std::size_t>(nv), -1) {}
};

/// Where the segment p + t d, t in [0, 1], leaves the ball of squared radius r2 around o (p
/// inside it): t = 1 and inside = true when p + d is inside the ball.
struct Clip {
  double t = 1;
  bool inside = true;
};

inline Clip clip_to_sphere(const Eigen::RowVector3d& o, double r2, const Eigen::RowVector3d& p,
                           const Eigen::RowVector3d& d) {
  const Eigen::RowVector3d w = p - o;
  const double a = d.squaredNorm(), b = d.dot(w), c = w.squaredNorm() - r2;
  // A zero-length edge leads on to its other end (MEPP divides by its zero length there).
  if (a == 0 || c + 2 * b + a <= 0) return {};
  const double root = (-b + std::sqrt(std::max(0.0, b * b - a * c))) / a;
  return {std::clamp(root, 0.0, 1.0), false};
}

/// Walks the ball of `radius` around vertex `center` of P (#V x 3, one row per vertex) over
/// the adjacency, calling visit(v, slot, w, clip, fresh) for every edge seen: v the end it is
/// seen from, slot its index in adj.indices (adj.indices[slot] == w), clip where it leaves the
/// ball, fresh whether w was reached for the first time through it.
template <class Points, class Visit>
void walk_sphere(const Points& P, const Adjacency& adj, int center, double radius,
                 WalkScratch& scratch, Visit&& visit) {
  const int mark = ++scratch.mark;
  const Eigen::RowVector3d o = P.row(center);
  const double r2 = radius * radius;
  scratch.stack.clear();
  scratch.stack.push_back(center);
  scratch.stamp[center] = mark;
  while (!scratch.stack.empty()) {
    const int v = scratch.stack.back();
    scratch.stack.pop_back();
    const Eigen::RowVector3d p = P.row(v), away = p - o;
    for (int s = adj.offsets[v]; s < adj.offsets[v + 1]; ++s) {
      const int w = adj.indices[s];
      const Eigen::RowVector3d d = P.row(w) - p;
      if (v != center && !(d.dot(away) > 0)) continue;
      const Clip clip = clip_to_sphere(o, r2, p, d);
      const bool fresh = clip.inside && scratch.stamp[w] != mark;
      if (fresh) {
        scratch.stamp[w] = mark;
        scratch.stack.push_back(w);
      }
      visit(v, s, w, clip, fresh);
    }
  }
}

}  // namespace meshmark::detail
