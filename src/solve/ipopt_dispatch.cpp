// The core's side of the ipopt component: the Ipopt backend's entry points, called through the
// slot the component fills (core/component.h), or MissingComponentError without it (a build
// with -DMESHMARK_WITH_IPOPT=OFF, or a program linked without meshmark::ipopt).

#include "core/component.h"
#include "solve/ipopt_qp.h"

namespace meshmark {

namespace detail {
const IpoptSolver*& ipopt_solver_slot() {
  static const IpoptSolver* solver = nullptr;
  return solver;
}
}  // namespace detail

GeneralQpSolution solve_general_qp_with_ipopt(const GeneralQp& qp, const IpoptOptions& options) {
  return detail::require_component(detail::ipopt_solver_slot(), "ipopt", "the Ipopt solver")
      .solve_general(qp, options);
}

QpResult solve_round_with_ipopt(const SeparableQp& qp, const Eigen::SparseMatrix<double>* H,
                                const IpoptOptions& options) {
  return detail::require_component(detail::ipopt_solver_slot(), "ipopt", "the Ipopt solver")
      .solve_round(qp, H, options);
}

}  // namespace meshmark
