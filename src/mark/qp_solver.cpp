#include "mark/qp_solver.h"

#include "solve/admm_qp.h"
#include "solve/ipopt_qp.h"

namespace meshmark::detail {

bool needs_assembled_hessian(const EmbedOptions& o) {
  return o.variant.cost == CostKind::Laplacian &&
         (o.backend == SolverBackend::Ipopt || o.admm.x_step == AdmmXStep::Cholesky);
}

RoundSolver::RoundSolver(const EmbedOptions& o) : o_(o) {
  if (o.backend == SolverBackend::Native && o.variant.cost == CostKind::Laplacian)
    admm_ = std::make_unique<AdmmQpSolver>();
}

RoundSolver::~RoundSolver() = default;

QpResult RoundSolver::solve(const EmbedContext& ctx, const RoundProblem& round) {
  const bool laplacian = o_.variant.cost == CostKind::Laplacian;
  if (o_.backend == SolverBackend::Ipopt)
    return solve_round_with_ipopt(round.qp, laplacian ? &round.H : nullptr, o_.ipopt);
  if (!laplacian) {
    // No warm start: a later round's problem is a small correction whose multipliers are near
    // zero, so the previous round's are a worse start than none (measured: one to two Newton
    // steps more).
    return solve_separable_qp(round.qp, o_.separable);
  }
  if (needs_assembled_hessian(o_)) {
    admm_->set_hessian(round.H, o_.admm);
    return admm_->solve(round.qp);
  }
  const LaplacianOperator H(ctx, round.U, o_.lambda);  // lives through the solve that uses it
  admm_->set_hessian(
      {[&H](const Eigen::VectorXd& x, Eigen::VectorXd& Hx) { H.apply(x, Hx); }, H.diagonal()},
      o_.admm);
  return admm_->solve(round.qp);
}

}  // namespace meshmark::detail
