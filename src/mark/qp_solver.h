#pragma once
// Internal: which solver answers an embedding round's quadratic program, decided in one place
// from EmbedOptions (backend, the variant's cost, admm.x_step), so that the problem's builder
// (embed_problem.h) knows none of the backends.

#include <memory>

#include "mark/embed_problem.h"
#include "meshmark/mark/embed.h"
#include "meshmark/solve/separable_qp.h"

namespace meshmark {
class AdmmQpSolver;
}

namespace meshmark::detail {

/// Cost L: whether the rounds' Hessian must be assembled (for Ipopt, or for Cholesky x-steps)
/// rather than only applied. The context and each round are built accordingly.
bool needs_assembled_hessian(const EmbedOptions& o);

/// The solver of one embedding's rounds: Ipopt (backend Ipopt), ADMM (cost L; its penalty and
/// factorization kept over the rounds) or the exact separable solver (costs S and Q).
class RoundSolver {
 public:
  /// o must outlive the solver.
  explicit RoundSolver(const EmbedOptions& o);
  ~RoundSolver();
  RoundSolver(const RoundSolver&) = delete;
  RoundSolver& operator=(const RoundSolver&) = delete;
  /// Solves round's problem (built by build_round on ctx with needs_assembled_hessian(o)).
  QpResult solve(const EmbedContext& ctx, const RoundProblem& round);

 private:
  const EmbedOptions& o_;
  std::unique_ptr<AdmmQpSolver> admm_;  // cost L, backend Native
};

}  // namespace meshmark::detail
