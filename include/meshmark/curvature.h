#pragma once
/// \file curvature.h
/// Per-vertex curvature from the normal cycle (Cohen-Steiner and Morvan, SoCG 2003), as MSDM
/// and the roughness field use it: around each vertex, the edges inside a ball of the given
/// radius (reached through the mesh, so a geodesic disc when the radius is small) contribute
/// beta(e) |e inside the ball| e e^T / area; the two eigenvalues of largest magnitude are the
/// principal curvatures.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "meshmark/mesh.h"

namespace meshmark {

/// Principal curvatures per vertex (1 / model units); kmax >= kmin in magnitude.
struct CurvatureField {
  Eigen::VectorXd kmin;  ///< smaller-magnitude principal curvature (signed)
  Eigen::VectorXd kmax;  ///< larger-magnitude principal curvature (signed)
  /// |kmin| + |kmax| per vertex.
  Eigen::VectorXd magnitude() const { return kmin.cwiseAbs() + kmax.cwiseAbs(); }
};

/// Normal-cycle curvature over balls of `radius` (model units) around every vertex.
/// Boundary and non-manifold edges carry no dihedral angle. Unreferenced vertices get 0.
/// V: #V x 3, F: #F x 3 (consistently oriented for meaningful signs).
CurvatureField normal_cycle_curvature(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                                      double radius);

/// For every vertex, the vertices reached from it through edges without leaving the ball of
/// `radius` around it (itself first), in compressed rows. Computed once, it serves every
/// computation over balls of that radius or less.
struct Neighborhoods {
  std::vector<std::int64_t> offsets{0};
  std::vector<int> indices;
};

/// Builds the neighborhoods of radius `radius` (model units).
Neighborhoods ball_neighborhoods(const Eigen::MatrixX3d& V, const Adjacency& adj, double radius);

/// The same curvature, over the members of precomputed neighborhoods (of a radius at least
/// `radius`) that lie within `radius` of the vertex.
CurvatureField normal_cycle_curvature(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                                      double radius, const Neighborhoods& near);

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
