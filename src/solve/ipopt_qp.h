#pragma once
/// \file ipopt_qp.h
/// A general-purpose backend: the embedding problem handed to Ipopt (an interior-point solver,
/// coinor-libipopt-dev), for comparison with the structured solvers and as an independent
/// check. Selected by EmbedOptions::backend (CLI: --solver ipopt); its settings, IpoptOptions,
/// are in solver_settings.h.

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <vector>

#include "meshmark/solve/separable_qp.h"
#include "meshmark/solve/solver_settings.h"

namespace meshmark {

/// minimize sum_i c_i x_i^2 + x^T Q x  subject to  row_lo <= A x <= row_hi,  x_lo <= x <= x_hi.
struct GeneralQp {
  Eigen::VectorXd c, x_lo, x_hi;
  Eigen::SparseMatrix<double> Q;  ///< symmetric, both triangles stored; empty for none
  std::vector<Eigen::Triplet<double>> A;
  Eigen::VectorXd row_lo, row_hi;  ///< use +-1e19 for no bound (Ipopt's infinity)
};

/// Ipopt's answer.
struct GeneralQpSolution {
  bool ok = false;
  int status = 0;  ///< Ipopt's ApplicationReturnStatus
  Eigen::VectorXd x;
  double objective = 0;
  int iterations = 0;  ///< Ipopt's iterations (its intermediate callback's last iter_count)
};

/// Solves with Ipopt (no bound relaxation, exact constant Hessian and Jacobian).
GeneralQpSolution solve_general_qp_with_ipopt(const GeneralQp& qp,
                                              const IpoptOptions& options = {});

/// One embedding round's problem (the constraints of qp; the cost diag(qp.h), or x^T H x when H
/// is given) solved by Ipopt, reported like the structured solvers (KKT residuals of rows and
/// equalities; y left empty).
QpResult solve_round_with_ipopt(const SeparableQp& qp, const Eigen::SparseMatrix<double>* H,
                                const IpoptOptions& options = {});

namespace detail {
/// The ipopt component's entry points (ipopt_qp.cpp), which the two functions above call;
/// without the component they throw MissingComponentError.
struct IpoptSolver {
  GeneralQpSolution (*solve_general)(const GeneralQp& qp, const IpoptOptions& options);
  QpResult (*solve_round)(const SeparableQp& qp, const Eigen::SparseMatrix<double>* H,
                          const IpoptOptions& options);
};
/// The core's slot for them (core/component.h).
const IpoptSolver*& ipopt_solver_slot();
}  // namespace detail

}  // namespace meshmark
