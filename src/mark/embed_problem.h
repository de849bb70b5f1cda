#pragma once
// Internal: the quadratic program of one embedding round (docs/method.md section 3), in units of
// the bin width s (x_g = r_g / s), over groups of vertices at identical positions.

#include <Eigen/SparseCore>

#include "meshmark/carrier/center.h"
#include "meshmark/carrier/histogram.h"
#include "meshmark/core/mesh.h"
#include "meshmark/mark/embed.h"

namespace meshmark::detail {

/// Cost L's one-ring structure over groups, which the rounds share: row i of B (one per
/// referenced vertex with neighbours) is u_gi e_gi^T - (1 / |N1(i)|) sum_{j in N1(i)} u_gj e_gj^T.
struct LaplacianRows {
  std::vector<int> row_group;       ///< per vertex: its group when it has a row, else -1
  std::vector<double> inv_degree;   ///< per vertex: 1 / |N1(i)| (0 without a row)
  std::vector<int> neighbor_group;  ///< per adjacency entry: the neighbour's group
  Eigen::VectorXd ctc_diagonal;     ///< per group: (C^T C)_gg = sum_i c_ig^2
};

/// Builds the rows' structure (topology only).
LaplacianRows laplacian_rows(const PositionGroups& groups, const Adjacency& adjacency);

struct EmbedContext;

/// Cost L's Hessian H = lambda I + (1 - lambda) B^T B, applied without assembling it:
/// B x and B^T y are one pass over the one-rings each (B^T by symmetry of the adjacency).
class LaplacianOperator {
 public:
  LaplacianOperator(const EmbedContext& ctx, const Eigen::MatrixX3d& U, double lambda);
  /// Hx = H x.
  void apply(const Eigen::VectorXd& x, Eigen::VectorXd& Hx) const;
  /// diag(H).
  Eigen::VectorXd diagonal() const;

 private:
  const EmbedContext* ctx_;
  const Eigen::MatrixX3d* U_;
  double lambda_;
  mutable std::vector<Eigen::Vector3d> v_, w_, t_;  // scratch: u_g x_g, B x per vertex, / degree
  mutable std::vector<double> s_;                   // scratch: per vertex, its share of B^T B x
};

/// What depends on the mesh and the variant only: the same over the rounds of one embedding and
/// over every payload, strength and bin offset (PreparedEmbedder keeps one).
struct EmbedContext {
  const Eigen::MatrixX3i* F = nullptr;
  std::vector<std::uint8_t> referenced;
  PositionGroups groups;
  Adjacency adjacency;                             // cost L only
  LaplacianRows laplacian;                         // cost L
  Eigen::SparseMatrix<double> laplacian_topology;  // cost L, assembled Hessian: C^T C
  Eigen::VectorXd smoothness;                      // direction S only
  double smooth_threshold = 0.8;
  Eigen::Vector3d original_center = Eigen::Vector3d::Zero();
};

/// Fills res's displacement fields (squared_displacement, rms_displacement, rms_percent) from
/// res.V against V; referenced: the carrier mask (each position counted once).
void measure_displacement(const Eigen::MatrixX3d& V, const std::vector<std::uint8_t>& referenced,
                          EmbedResult& res);

/// Signed margins m_j (score_j - 1/2) of the payload's bits in a histogram, read with the
/// statistic (method.h); -1/2 for an empty bin.
std::vector<double> signed_margins(const Histogram& h, const Payload& payload,
                                   BinStatistic statistic = BinStatistic::Mean);

/// Whether every bit holds its strength (bit_strength), less options.margin_tolerance (at most
/// half the strength): a round's stopping rule, for either method.
bool margins_held(const std::vector<double>& margins, const EmbedOptions& options);

/// Embeds payload with Cho et al.'s method options.method (cho.h) on the prepared context,
/// into res (its V the original positions, its carrier check done and usable); fills every
/// field but seconds.
void embed_cho(const Eigen::MatrixX3d& V, const EmbedContext& ctx, const Payload& payload,
               const EmbedOptions& options, EmbedResult& res);

/// One round's problem.
struct RoundProblem {
  Histogram hist;
  Center center;
  SeparableQp qp;                 // constraints; qp.h is the diagonal cost (S, Q)
  Eigen::SparseMatrix<double> H;  // cost L, when assembled: the Hessian over groups
  Eigen::MatrixX3d U;             // per group, the unit direction of displacement
  int radial_fallbacks = 0;
};

/// Cost L: the scalar matrix C^T C over groups (C's row i: 1 at i's group, -1/|N1(i)| at each
/// neighbour's), whose entries times u_g . u_h give B^T B. Depends on the connectivity only.
Eigen::SparseMatrix<double> laplacian_topology(const PositionGroups& groups,
                                               const Adjacency& adjacency);

/// Builds the round's problem for payload under options o at positions V; with
/// assemble_hessian (cost L, and ctx.laplacian_topology built), round.H too. Returns false when
/// the histogram or the center is not defined (the message says which).
bool build_round(const EmbedContext& ctx, const Payload& payload, const EmbedOptions& o,
                 const Eigen::MatrixX3d& V, bool assemble_hessian, RoundProblem& round,
                 std::string& message);

}  // namespace meshmark::detail
