#pragma once
/// \file admm_qp.h
/// A solver for the embedding problem with a sparse, non-diagonal cost (the Laplacian cost L,
/// docs/method.md section 4): minimize x^T H x over the constraint set of a SeparableQp (rows,
/// center equality, bounds). ADMM (as in OSQP) splits it into
///   x-step: (2 H + rho I) x = rho (z - u)  -- by default conjugate gradients preconditioned by
///           the diagonal, warm-started from the previous x, H applied as an operator (the
///           matrix is well conditioned); or a sparse LDL^T factorization of the assembled
///           matrix, its ordering and symbolic analysis computed once, its numeric factors
///           reused by every iteration and by every round whose Hessian is unchanged;
///   z-step: the Euclidean projection onto the constraint set -- the separable problem, solved
///           exactly by solve_separable_qp, warm-started from the previous iteration;
///   u-step: u += x - z,
/// with over-relaxation. H = lambda W + (1 - lambda) B^T B is well conditioned for lambda > 0,
/// so a fixed rho converges fast. The answer z satisfies every constraint exactly; primal and
/// dual residuals measure its optimality.

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <functional>
#include <memory>

#include "meshmark/core/enum_names.h"
#include "meshmark/solve/separable_qp.h"
#include "meshmark/solve/solver_settings.h"

namespace meshmark {

/// Why the last AdmmQpSolver::solve ended.
enum class AdmmStop {
  Converged,         ///< both residuals within tolerance: QpStatus::Solved
  Infeasible,        ///< the constraint set is empty (a projection proved it): Infeasible
  IterationLimit,    ///< max_iterations reached: QpStatus::IterationLimit
  Stalled,           ///< stall_iterations without progress: QpStatus::IterationLimit
  ProjectionFailed,  ///< a z-step's projection did not converge: QpStatus::IterationLimit
  XStepFailed,       ///< an x-step's conjugate gradients did not converge (H not positive
                     ///< semidefinite, or max_cg_iterations too few): QpStatus::IterationLimit
};

/// The names of AdmmStop's values (admm_stop_name).
template <>
struct EnumTable<AdmmStop> {
  static constexpr const char* what = "ADMM stop";
  static constexpr NamedValue<AdmmStop> values[] = {
      {AdmmStop::Converged, "converged"},
      {AdmmStop::Infeasible, "infeasible"},
      {AdmmStop::IterationLimit, "iteration limit"},
      {AdmmStop::Stalled, "stalled"},
      {AdmmStop::ProjectionFailed, "projection not converged"},
      {AdmmStop::XStepFailed, "x-step not converged"}};
};

/// "converged", "infeasible", "iteration limit", "stalled", "projection not converged",
/// "x-step not converged".
const char* admm_stop_name(AdmmStop stop);

/// A symmetric positive semidefinite n x n Hessian given by its action, so that structured
/// costs need not be assembled (the Laplacian cost's B^T B is applied as two one-ring passes).
struct HessianOperator {
  /// Hx = H x (Hx is sized by the callee).
  std::function<void(const Eigen::VectorXd& x, Eigen::VectorXd& Hx)> apply;
  Eigen::VectorXd diagonal;  ///< diag(H), n, for rho and the preconditioner
};

/// Reusable solver: set_hessian once per Hessian, solve as often as needed.
class AdmmQpSolver {
 public:
  AdmmQpSolver();
  ~AdmmQpSolver();
  AdmmQpSolver(AdmmQpSolver&&) noexcept;
  AdmmQpSolver& operator=(AdmmQpSolver&&) noexcept;
  /// Takes a new Hessian. The first call (or refactor = true) chooses rho; later calls keep it.
  void set_hessian(HessianOperator H, const AdmmSettings& settings = {}, bool refactor = false);
  /// The same for an assembled matrix (n x n, symmetric, both triangles stored). With
  /// AdmmXStep::Cholesky, factors 2 H + rho I, unless H is the previous call's (then the
  /// factors are kept); the symbolic analysis is redone only when the pattern changes.
  void set_hessian(const Eigen::SparseMatrix<double>& H, const AdmmSettings& settings = {},
                   bool refactor = false);
  /// Numeric factorizations done so far (Cholesky x-steps).
  int factorizations() const { return factorizations_; }
  /// Solves over the constraints of qp (qp.h is ignored). warm_z and warm_u (size n) start the
  /// iteration where a previous solve ended. QpResult::x is z; primal_residual is |x - z|_inf;
  /// dual_residual is rho |z - z_prev|_inf; iterations counts ADMM steps.
  /// Every outcome is a status (stop_reason() says which way it ended), never an exception,
  /// and the work is bounded: at most max_iterations steps, each of at most max_cg_iterations
  /// operator products and one separable solve (itself bounded, QpSettings).
  /// \throw Error only for Cholesky x-steps without an assembled Hessian (a programming error).
  QpResult solve(const SeparableQp& qp, const Eigen::VectorXd* warm_z = nullptr,
                 const Eigen::VectorXd* warm_u = nullptr);
  /// The scaled dual u of the last solve (for warm starts).
  const Eigen::VectorXd& scaled_dual() const { return u_; }
  double rho() const { return rho_; }
  /// How the last solve ended.
  AdmmStop stop_reason() const { return stop_; }
  /// Conjugate-gradient iterations of the last solve, over all its ADMM steps.
  int cg_iterations() const { return cg_iterations_; }

 private:
  // CG on K x = rhs from x (the guess) to max(cg_tolerance |rhs|, looser_target) in
  // |residual|_2; false when max_cg_iterations do not get there.
  bool solve_x(const Eigen::VectorXd& rhs, Eigen::VectorXd& x, double looser_target) const;

  void apply_k(const Eigen::VectorXd& x, Eigen::VectorXd& Kx) const;  // K = 2 H + rho I

  HessianOperator H_;
  // Cholesky x-steps: K = 2 H + rho I and its sparse LDL^T (defined in admm_qp.cpp, so that
  // this header does not include Eigen/SparseCholesky).
  struct Factorization;
  std::unique_ptr<Factorization> factors_;
  bool analyzed_ = false, factored_k_ = false;
  int factorizations_ = 0;
  Eigen::VectorXd inv_diagonal_;  // Jacobi preconditioner: 1 / diag(K)
  bool rho_chosen_ = false;
  double rho_ = 1;
  AdmmSettings settings_;
  Eigen::VectorXd u_;
  AdmmStop stop_ = AdmmStop::Converged;
  mutable int cg_iterations_ = 0;
  mutable Eigen::VectorXd r_, z_, p_, Kp_;  // conjugate-gradient scratch
  mutable Eigen::VectorXd last_rhs_;        // r_ = last_rhs_ - K x (x: the last x-step)
  mutable bool residual_known_ = false;
};

}  // namespace meshmark
