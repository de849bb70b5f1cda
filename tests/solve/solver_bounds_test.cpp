// Every solver ends with a status, and an empty constraint set is reported as such (issue 13,
// item 9): calibration's first trial, the strongest, asks for bins that can each reach their
// target but not all of them while the center stays; the separable solver walked its
// multipliers towards infinity until its iteration limit, and ADMM, ignoring that, repeated
// such projections for up to 5000 iterations per round.

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include "meshmark/core/random.h"
#include "meshmark/solve/separable_qp.h"
#include "solve/admm_qp.h"

using namespace meshmark;

namespace {

// Rows that each can be met but not together with the equality, shaped like an embedding
// round (zero displacement inside every box): groups of k variables in [-1/2, 1/2], row j
// asks for the mean of its group >= 0.4, and the first equality for sum_i e_i x_i = c with
// e_i in {1, 2, 3} / n (independent of the rows, as a center's Jacobian is). A group's mean of
// at least 0.4 leaves it at most 0.05 k of negative mass, so its share of the sum is at least
// (0.4 k - 2 * 0.05 k) / n > 0: c = 0 is infeasible, while each row alone is reachable (its
// variables can all go to 1/2). The feasible variant asks for means >= 0.2 and
// c = 0.3 sum_i e_i: x = 0.3 everywhere satisfies it.
SeparableQp rows_and_center(int rows, int k, bool feasible) {
  const int n = rows * k;
  SeparableQp qp;
  qp.h = Eigen::VectorXd::Ones(n);
  qp.lo = Eigen::VectorXd::Constant(n, -0.5);
  qp.hi = Eigen::VectorXd::Constant(n, 0.5);
  qp.row.resize(n);
  qp.a = Eigen::VectorXd::Constant(n, 1.0 / k);
  qp.b = Eigen::VectorXd::Constant(rows, feasible ? 0.2 : 0.4);
  qp.e = Eigen::Matrix3Xd::Zero(3, n);
  for (int i = 0; i < n; ++i) {
    qp.row[i] = i / k;
    qp.e(0, i) = (1 + i % 3) / static_cast<double>(n);
  }
  qp.c = Eigen::Vector3d(feasible ? 0.3 * qp.e.row(0).sum() : 0.0, 0, 0);
  return qp;
}

SeparableQp rows_against_the_center(int rows, int k) {
  return rows_and_center(rows, k, false);
}

SeparableQp rows_with_the_center(int rows, int k) {
  return rows_and_center(rows, k, true);
}

// Constraint violation of x, computed from the problem's definition.
double violation(const SeparableQp& qp, const Eigen::VectorXd& x) {
  Eigen::VectorXd rows = Eigen::VectorXd::Zero(qp.b.size());
  double worst = 0;
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    worst = std::max({worst, qp.lo(i) - x(i), x(i) - qp.hi(i)});
    if (qp.row[i] >= 0) rows(qp.row[i]) += qp.a(i) * x(i);
  }
  for (Eigen::Index j = 0; j < qp.b.size(); ++j) worst = std::max(worst, qp.b(j) - rows(j));
  return std::max(worst, (qp.e * x - qp.c).cwiseAbs().maxCoeff());
}

// A positive definite Hessian with off-diagonal terms: a 1-D Laplacian plus the identity.
HessianOperator chain_hessian(Eigen::Index n) {
  HessianOperator H;
  H.diagonal = Eigen::VectorXd::Constant(n, 3.0);
  H.apply = [n](const Eigen::VectorXd& x, Eigen::VectorXd& Hx) {
    Hx = 3.0 * x;
    Hx.head(n - 1) -= x.tail(n - 1);
    Hx.tail(n - 1) -= x.head(n - 1);
  };
  return H;
}

}  // namespace

TEST(SolverBounds, SeparableRowsReachableAloneButNotWithTheCenterAreInfeasible) {
  for (int rows : {1, 4, 64}) {
    SCOPED_TRACE(rows);
    const SeparableQp qp = rows_against_the_center(rows, 50);
    const QpResult r = solve_separable_qp(qp);
    EXPECT_EQ(r.status, QpStatus::Infeasible);
    EXPECT_TRUE(r.infeasible_rows.empty()) << "every row alone is reachable";
  }
}

TEST(SolverBounds, SeparableFeasibleVariantIsSolvedAndFeasible) {
  const SeparableQp qp = rows_with_the_center(64, 50);
  const QpResult r = solve_separable_qp(qp);
  ASSERT_EQ(r.status, QpStatus::Solved);
  EXPECT_LE(violation(qp, r.x), 1e-9);
}

TEST(SolverBounds, AdmmReportsAnEmptyConstraintSetAsInfeasibleAndSolvesTheFeasibleOne) {
  for (bool feasible : {false, true}) {
    SCOPED_TRACE(feasible);
    const SeparableQp qp =
        feasible ? rows_with_the_center(16, 40) : rows_against_the_center(16, 40);
    AdmmQpSolver admm;
    admm.set_hessian(chain_hessian(qp.lo.size()));
    const QpResult r = admm.solve(qp);
    EXPECT_EQ(r.status, feasible ? QpStatus::Solved : QpStatus::Infeasible);
    EXPECT_EQ(admm.stop_reason(), feasible ? AdmmStop::Converged : AdmmStop::Infeasible);
    if (feasible) EXPECT_LE(violation(qp, r.x), 1e-9) << "solved means inside the set";
  }
}

TEST(SolverBounds, AdmmWithAnIndefiniteHessianEndsWithAStatus) {
  // Nonnegative diagonal, eigenvalues 3 and -1: conjugate gradients cannot solve with it.
  HessianOperator H;
  H.diagonal = Eigen::VectorXd::Ones(2);
  H.apply = [](const Eigen::VectorXd& x, Eigen::VectorXd& Hx) {
    Hx.resize(2);
    Hx << x(0) + 2 * x(1), 2 * x(0) + x(1);
  };
  SeparableQp qp;
  qp.h = Eigen::VectorXd::Ones(2);
  qp.lo = Eigen::VectorXd::Constant(2, -10);
  qp.hi = Eigen::VectorXd::Constant(2, 10);
  qp.row = {0, -1};
  qp.a = Eigen::VectorXd::Ones(2);
  qp.b = Eigen::VectorXd::Constant(1, 1.0);
  qp.e = Eigen::Matrix3Xd::Zero(3, 2);
  AdmmQpSolver admm;
  AdmmSettings settings;
  settings.rho = 0.1;  // K = 2 H + rho I stays indefinite
  admm.set_hessian(H, settings);
  QpResult r;
  EXPECT_NO_THROW(r = admm.solve(qp));
  EXPECT_NE(r.status, QpStatus::Solved);
  EXPECT_EQ(admm.stop_reason(), AdmmStop::XStepFailed);
}

TEST(SolverBounds, AdmmStopsWhenItStalls) {
  // A tolerance below rounding cannot be met: the residual stops halving and the solve ends
  // as stalled, long before max_iterations.
  const SeparableQp qp = rows_with_the_center(16, 40);
  AdmmQpSolver admm;
  AdmmSettings settings;
  settings.tolerance = 0;
  settings.max_iterations = 1000000;
  settings.stall_iterations = 50;
  admm.set_hessian(chain_hessian(qp.lo.size()), settings);
  const QpResult r = admm.solve(qp);
  EXPECT_EQ(r.status, QpStatus::IterationLimit);
  EXPECT_EQ(admm.stop_reason(), AdmmStop::Stalled);
  EXPECT_LT(r.iterations, settings.max_iterations);
  EXPECT_LE(violation(qp, r.x), 1e-9) << "the answer is still a projection onto the set";
}
