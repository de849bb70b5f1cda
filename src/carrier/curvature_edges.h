#pragma once
// Internal: the edge table of the normal-cycle curvature (curvature.cpp), which depends on the
// connectivity only, apart from the computation that uses it, so that a caller comparing
// several positions of one connectivity (MsdmReference) builds it once.

#include <Eigen/Core>
#include <array>
#include <vector>

#include "carrier/curvature.h"
#include "meshmark/core/mesh.h"

namespace meshmark::detail {

/// Unique undirected edges (ends, smaller first) with the faces around each (compressed rows),
/// the two faces of each manifold, consistently oriented edge (sides: the one running from the
/// smaller end first; -1, -1 otherwise: no dihedral angle), the edge of each face's side c
/// (from corner c to c + 1; -1 for a degenerate side) and the edge of each adjacency slot.
struct EdgeTable {
  std::vector<std::array<int, 2>> ends, sides;
  std::vector<int> face_offsets{0}, faces;
  std::vector<std::array<int, 3>> face_edges;
  std::vector<int> edge_of_slot;
};

/// The edge table of F over nv vertices; adj = vertex_adjacency(F, nv).
EdgeTable edge_table(const Eigen::MatrixX3i& F, const Adjacency& adj, Eigen::Index nv);

/// normal_cycle_curvature (curvature.h) with the edge table of F computed once.
CurvatureField normal_cycle_curvature(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                                      const Adjacency& adj, const EdgeTable& table, double radius,
                                      BallEdges which);

}  // namespace meshmark::detail
