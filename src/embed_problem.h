#pragma once
// Internal: the quadratic program of one embedding round (WATERMARK.md section 3), in units of
// the bin width s (x_g = r_g / s), over groups of vertices at identical positions.

#include <Eigen/SparseCore>

#include "meshmark/center.h"
#include "meshmark/embed.h"
#include "meshmark/histogram.h"
#include "meshmark/mesh.h"

namespace meshmark::detail {

/// What stays the same over the rounds of one embedding.
struct EmbedContext {
  const Eigen::MatrixX3i* F = nullptr;
  std::vector<std::uint8_t> referenced;
  PositionGroups groups;
  Adjacency adjacency;                             // cost L only
  Eigen::SparseMatrix<double> laplacian_topology;  // cost L: C^T C (see laplacian_topology)
  Eigen::VectorXd smoothness;                      // direction S only
  double smooth_threshold = 0.8;
  Eigen::Vector3d original_center = Eigen::Vector3d::Zero();
  const Payload* payload = nullptr;
  const EmbedOptions* options = nullptr;
};

/// One round's problem.
struct RoundProblem {
  Histogram hist;
  Center center;
  SeparableQp qp;                 // constraints; qp.h is the diagonal cost (S, Q)
  Eigen::SparseMatrix<double> H;  // cost L: the full Hessian over groups
  Eigen::MatrixX3d U;             // per group, the unit direction of displacement
  int radial_fallbacks = 0;
};

/// Cost L: the scalar matrix C^T C over groups (C's row i: 1 at i's group, -1/|N1(i)| at each
/// neighbour's), whose entries times u_g . u_h give B^T B. Depends on the connectivity only.
Eigen::SparseMatrix<double> laplacian_topology(const PositionGroups& groups,
                                               const Adjacency& adjacency);

/// Builds the round's problem at positions V. Returns false when the histogram or the center
/// is not defined (the message says which).
bool build_round(const EmbedContext& ctx, const Eigen::MatrixX3d& V, RoundProblem& round,
                 std::string& message);

}  // namespace meshmark::detail
