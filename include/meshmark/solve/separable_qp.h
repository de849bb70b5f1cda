#pragma once
/// \file separable_qp.h
/// An exact solver for the embedding quadratic program with a diagonal cost
/// (docs/method.md section 4):
///
///     minimize    sum_i h_i x_i^2
///     subject to  sum_{i : row(i) = j} a_i x_i >= b_j      for every watermark row j
///                 sum_i e_i x_i = c                        (3 rows: the center stays)
///                 lo_i <= x_i <= hi_i
///
/// The watermark rows have disjoint supports. The Lagrangian dual has only m + 3 unknowns:
/// for multipliers y the primal minimizer is x_i(y) = clip((M^T y)_i / (2 h_i), lo_i, hi_i), and
/// the dual is concave and piecewise quadratic. A projected semismooth Newton method on it
/// (O(n) work per iteration, an (m + 3)-square arrow-shaped system solved by a 3 x 3 Schur
/// complement) finds the exact optimum: once the clipped set settles, a full Newton step
/// lands on it. The KKT conditions of the answer are measured and returned.

#include <Eigen/Core>
#include <vector>
#include "meshmark/core/enum_names.h"

namespace meshmark {

/// The problem, n variables and m watermark rows.
struct SeparableQp {
  Eigen::VectorXd h;     ///< n, cost weights, > 0
  Eigen::VectorXd lo;    ///< n, lower bounds
  Eigen::VectorXd hi;    ///< n, upper bounds, >= lo
  std::vector<int> row;  ///< n, the watermark row holding x_i, or -1
  Eigen::VectorXd a;     ///< n, coefficient of x_i in its row (ignored when row(i) = -1)
  Eigen::VectorXd b;     ///< m, right-hand sides of the rows
  Eigen::Matrix3Xd e;    ///< 3 x n, columns of the equality constraint
  Eigen::Vector3d c = Eigen::Vector3d::Zero();  ///< right-hand side of the equality
};

/// Solver settings.
struct QpSettings {
  int max_iterations = 100;  ///< Newton iterations
  double tolerance = 1e-11;  ///< on the KKT residuals (rows and equalities, absolute)
};

/// Outcome of a solve.
enum class QpStatus {
  Solved,          ///< KKT conditions hold within the tolerance
  Infeasible,      ///< some row cannot reach b_j inside the bounds (infeasible_rows), or the
                   ///< equality cannot hold together with the rows (proven by a Farkas
                   ///< certificate from the multipliers, checked every 8 iterations and at
                   ///< the end, or multipliers beyond 1e30)
  IterationLimit,  ///< max_iterations reached; x is the best iterate
};

/// The names of QpStatus's values (qp_status_name).
template <>
struct EnumTable<QpStatus> {
  static constexpr const char* what = "QP status";
  static constexpr NamedValue<QpStatus> values[] = {{QpStatus::Solved, "solved"},
                                                    {QpStatus::Infeasible, "infeasible"},
                                                    {QpStatus::IterationLimit, "iteration limit"}};
};

/// Solution and diagnostics, shared by the round solvers (this one, ADMM in admm_qp.h and
/// Ipopt in ipopt_qp.h); each residual says which solver fills it. Residuals are in x's units.
struct QpResult {
  QpStatus status = QpStatus::IterationLimit;
  Eigen::VectorXd x;  ///< n, the minimizer (bounds hold exactly)
  Eigen::VectorXd y;  ///< m + 3 multipliers: rows (>= 0), then the equalities (empty: ADMM, Ipopt)
  double objective = 0;  ///< sum h_i x_i^2 (ADMM: not filled)
  /// This solver and Ipopt: max(row violation, |E x - c|_inf). ADMM: |x - z|_inf, its
  /// splitting's primal residual (z, returned as x, meets every constraint exactly).
  double primal_residual = 0;
  double complementarity = 0;        ///< this solver only: max_j |min(y_j, slack_j)|; 0 otherwise
  double dual_residual = 0;          ///< ADMM only: rho |z - z_prev|_inf; 0 otherwise
  int iterations = 0;                ///< Newton iterations (ADMM: ADMM steps; Ipopt: its own)
  std::vector<int> infeasible_rows;  ///< rows that cannot reach their right-hand side
};

/// Solves the problem. warm_y (m + 3, optional) starts the multipliers there. Bounded work:
/// at most max_iterations Newton steps of at most 60 O(n) evaluations each; never throws.
/// Preconditions (asserted): consistent sizes, h > 0, lo <= hi.
QpResult solve_separable_qp(const SeparableQp& qp, const QpSettings& settings = {},
                            const Eigen::VectorXd* warm_y = nullptr);

/// "solved", "infeasible", "iteration limit".
const char* qp_status_name(QpStatus status);

}  // namespace meshmark
