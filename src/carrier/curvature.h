#pragma once
/// \file curvature.h
/// Per-vertex curvature from the normal cycle (Cohen-Steiner and Morvan, SoCG 2003), as MSDM,
/// MSDM2 and the roughness field use it: around each vertex O, every edge e of the ball
/// B(O, r) contributes beta(e) |e inside B| e e^T / |e|^2, the sum is divided by the disc's
/// area pi r^2 (as Lavoue's reference code, MEPP's Curvature component and MEPP2's
/// curvature.hpp, divides), and the two eigenvalues of largest magnitude are the principal
/// curvatures. Which edges enter (BallEdges): all those the surface brings into the ball
/// (kClipped, the definition), or those the reference code's walk sees (kReferenceWalk, for
/// MSDM and MSDM2 to read as the literature's): every edge of O, then, from every vertex v
/// reached, every edge leaving v away from O ((w - v) . (v - O) > 0), clipped to the sphere,
/// going on from w when w is inside. That walk misses edges nearly tangent to the sphere
/// near O (the link of O's one-ring, for one) and edges with both ends outside: with edges
/// of length l it reads about 2 l / (pi r) low on a sphere or cylinder.
/// Below an edge's length only O's own edges enter, each for the length r: the value then
/// scales as 1 / r (sum of beta e e^T / (pi r |e|^2)), unlike a one-ring average.
/// beta(e) is the signed dihedral angle from atan2 (the reference's asin folds angles beyond
/// 90 degrees); zero-area faces give no normal and their edges no angle (the reference gets
/// NaN there).

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "meshmark/core/mesh.h"

namespace meshmark {

/// Principal curvatures per vertex (1 / model units); kmax >= kmin in magnitude.
struct CurvatureField {
  Eigen::VectorXd kmin;  ///< smaller-magnitude principal curvature (signed)
  Eigen::VectorXd kmax;  ///< larger-magnitude principal curvature (signed)
  /// |kmin| + |kmax| per vertex.
  Eigen::VectorXd magnitude() const { return kmin.cwiseAbs() + kmax.cwiseAbs(); }
};

/// Which edges a ball takes, and for which length.
enum class BallEdges {
  /// Every edge the surface around the vertex brings into the ball, for its length inside
  /// (Cohen-Steiner and Morvan's clipped normal cycle): faces are flooded from the vertex's
  /// across every edge that meets the ball, so edges with one or both ends outside count.
  kClipped,
  /// The reference code's walk (file comment): what MSDM and MSDM2 use.
  kReferenceWalk,
};

/// Normal-cycle curvature over balls of `radius` (model units, > 0; else all zero) around
/// every vertex, divided by pi radius^2. Boundary and non-manifold edges carry no dihedral
/// angle but the ball crosses them. Unreferenced vertices get 0. V: #V x 3, F: #F x 3
/// (consistently oriented for meaningful signs).
CurvatureField normal_cycle_curvature(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                                      double radius, BallEdges which = BallEdges::kClipped);

/// The same with the adjacency of F computed once (vertex_adjacency(F, V.rows())).
CurvatureField normal_cycle_curvature(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                                      const Adjacency& adj, double radius,
                                      BallEdges which = BallEdges::kClipped);

/// For every vertex, the vertices reached from it through edges without leaving the ball of
/// `radius` around it (itself first), in compressed rows. Computed once, it serves every
/// vertex-sampled computation over balls of that radius or less (the roughness field's
/// Gaussian averages).
struct Neighborhoods {
  std::vector<std::int64_t> offsets{0};
  std::vector<int> indices;
};

/// Builds the neighborhoods of radius `radius` (model units).
Neighborhoods ball_neighborhoods(const Eigen::MatrixX3d& V, const Adjacency& adj, double radius);

/// Visits the vertices reachable from `seed` through edges of the adjacency while staying
/// within `radius` of `center`, calling visit(vertex). `stamp` (size #V, initially all -1) and
/// `queue` are scratch space reused across calls; `mark` must differ between calls.
template <class Points, class Visit>
void for_each_vertex_in_ball(const Points& V, const Adjacency& adj, int seed,
                             const Eigen::RowVector3d& center, double radius,
                             std::vector<int>& stamp, std::vector<int>& queue, int mark,
                             Visit&& visit) {
  queue.clear();
  queue.push_back(seed);
  stamp[seed] = mark;
  const double r2 = radius * radius;
  for (std::size_t k = 0; k < queue.size(); ++k) {
    const int v = queue[k];
    visit(v);
    for (int e = adj.offsets[v]; e < adj.offsets[v + 1]; ++e) {
      const int w = adj.indices[e];
      if (stamp[w] == mark || (V.row(w) - center).squaredNorm() > r2) continue;
      stamp[w] = mark;
      queue.push_back(w);
    }
  }
}

}  // namespace meshmark
