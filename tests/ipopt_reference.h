#pragma once
// An independent reference for the embedding QP: the problem of WATERMARK.md section 3 built
// from the geometry by code written only for the tests, solved by Ipopt (a general interior
// point solver from coinor-libipopt-dev) with tight tolerances.

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <vector>

namespace meshmark::test {

/// minimize sum_i c_i x_i^2 + x^T Q x  subject to  row_lo <= A x <= row_hi,  x_lo <= x <= x_hi.
struct SparseQp {
  Eigen::VectorXd c, x_lo, x_hi;
  Eigen::SparseMatrix<double> Q;  ///< symmetric, both triangles stored; empty for none
  std::vector<Eigen::Triplet<double>> A;
  Eigen::VectorXd row_lo, row_hi;
};

struct ReferenceSolution {
  bool ok = false;
  int status = 0;  // Ipopt's ApplicationReturnStatus
  Eigen::VectorXd x;
  double objective = 0;
};

/// Solves with Ipopt (tol 1e-13, no bound relaxation, exact constant Hessian).
ReferenceSolution solve_with_ipopt(const SparseQp& qp);

/// The DRS problem (discrete center, radial directions, squared error) for payload bits, in
/// model units: variable i is the radial displacement of referenced vertex referenced[i]
/// (variables in vertex order). directions receives rhohat per referenced vertex.
SparseQp drs_reference_problem(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                               const std::vector<int>& bits, double alpha, double G,
                               std::vector<int>& referenced, Eigen::MatrixX3d& directions);

}  // namespace meshmark::test
