#include "solve/ipopt_qp.h"
#include "core/component.h"

#include <IpStdCInterface.h>

#include <algorithm>
#include <cmath>

namespace meshmark {

namespace {

struct Data {
  const GeneralQp* qp;
  int iterations = 0;  // the last iteration Ipopt reported
};

// Ipopt's intermediate callback: records the iteration count, never stops the solve.
Bool count_iterations(Index, Index iter_count, Number, Number, Number, Number, Number, Number,
                      Number, Number, Index, UserDataPtr user) {
  static_cast<Data*>(user)->iterations = static_cast<int>(iter_count);
  return 1;
}

Eigen::VectorXd quadratic_part(const GeneralQp& qp, const Number* x) {
  const Eigen::Map<const Eigen::VectorXd> xv(x, qp.c.size());
  return qp.Q.nonZeros() ? Eigen::VectorXd(qp.Q * xv) : Eigen::VectorXd::Zero(qp.c.size());
}
Bool eval_f(Index n, Number* x, Bool, Number* f, UserDataPtr user) {
  const auto& qp = *static_cast<Data*>(user)->qp;
  const Eigen::VectorXd Qx = quadratic_part(qp, x);
  double s = 0;
  for (Index i = 0; i < n; ++i) s += qp.c(i) * x[i] * x[i] + x[i] * Qx(i);
  *f = s;
  return 1;
}
Bool eval_grad_f(Index n, Number* x, Bool, Number* g, UserDataPtr user) {
  const auto& qp = *static_cast<Data*>(user)->qp;
  const Eigen::VectorXd Qx = quadratic_part(qp, x);
  for (Index i = 0; i < n; ++i) g[i] = 2 * qp.c(i) * x[i] + 2 * Qx(i);
  return 1;
}
Bool eval_g(Index, Number* x, Bool, Index m, Number* g, UserDataPtr user) {
  const auto& qp = *static_cast<Data*>(user)->qp;
  std::fill(g, g + m, 0.0);
  for (const auto& t : qp.A) g[t.row()] += t.value() * x[t.col()];
  return 1;
}
Bool eval_jac_g(Index, Number*, Bool, Index, Index, Index* rows, Index* cols, Number* values,
                UserDataPtr user) {
  const auto& qp = *static_cast<Data*>(user)->qp;
  for (std::size_t k = 0; k < qp.A.size(); ++k) {
    if (values) {
      values[k] = qp.A[k].value();
    } else {
      rows[k] = qp.A[k].row();
      cols[k] = qp.A[k].col();
    }
  }
  return 1;
}
// The Hessian's lower triangle: the diagonal 2 c_i, then 2 Q_ij for i > j (Q's diagonal is
// added to the first entries).
std::vector<std::pair<Index, Index>> hessian_pattern(const GeneralQp& qp) {
  std::vector<std::pair<Index, Index>> pattern;
  const auto n = static_cast<Index>(qp.c.size());
  pattern.reserve(static_cast<std::size_t>(n + qp.Q.nonZeros()));
  for (Index i = 0; i < n; ++i) pattern.emplace_back(i, i);
  for (int k = 0; k < qp.Q.outerSize(); ++k)
    for (Eigen::SparseMatrix<double>::InnerIterator it(qp.Q, k); it; ++it)
      if (it.row() > it.col())
        pattern.emplace_back(static_cast<Index>(it.row()), static_cast<Index>(it.col()));
  return pattern;
}
Bool eval_h(Index n, Number*, Bool, Number obj_factor, Index, Number*, Bool, Index, Index* rows,
            Index* cols, Number* values, UserDataPtr user) {
  const auto& qp = *static_cast<Data*>(user)->qp;
  if (!values) {
    const auto pattern = hessian_pattern(qp);
    for (std::size_t k = 0; k < pattern.size(); ++k)
      rows[k] = pattern[k].first, cols[k] = pattern[k].second;
    return 1;
  }
  for (Index i = 0; i < n; ++i)
    values[i] = 2 * obj_factor * (qp.c(i) + (qp.Q.nonZeros() ? qp.Q.coeff(i, i) : 0.0));
  Index k = n;
  for (int col = 0; col < qp.Q.outerSize(); ++col)
    for (Eigen::SparseMatrix<double>::InnerIterator it(qp.Q, col); it; ++it)
      if (it.row() > it.col()) values[k++] = 2 * obj_factor * it.value();
  return 1;
}

GeneralQpSolution solve_general(const GeneralQp& qp, const IpoptOptions& options) {
  const auto n = static_cast<Index>(qp.c.size());
  const auto m = static_cast<Index>(qp.row_lo.size());
  Eigen::VectorXd xl = qp.x_lo, xu = qp.x_hi, gl = qp.row_lo, gu = qp.row_hi;
  IpoptProblem problem = CreateIpoptProblem(n, xl.data(), xu.data(), m, gl.data(), gu.data(),
                                            static_cast<Index>(qp.A.size()),
                                            static_cast<Index>(hessian_pattern(qp).size()), 0,
                                            eval_f, eval_g, eval_grad_f, eval_jac_g, eval_h);
  AddIpoptIntOption(problem, const_cast<char*>("print_level"), 0);
  AddIpoptNumOption(problem, const_cast<char*>("tol"), options.tolerance);
  AddIpoptNumOption(problem, const_cast<char*>("bound_relax_factor"), 0.0);
  AddIpoptIntOption(problem, const_cast<char*>("max_iter"), options.max_iterations);
  AddIpoptStrOption(problem, const_cast<char*>("hessian_constant"), const_cast<char*>("yes"));
  AddIpoptStrOption(problem, const_cast<char*>("jac_c_constant"), const_cast<char*>("yes"));
  AddIpoptStrOption(problem, const_cast<char*>("jac_d_constant"), const_cast<char*>("yes"));
  AddIpoptStrOption(problem, const_cast<char*>("sb"), const_cast<char*>("yes"));
  // QAMD ordering copes with the dense center rows (AMD asks MUMPS for gigabytes of fill).
  AddIpoptIntOption(problem, const_cast<char*>("mumps_pivot_order"), 6);
  GeneralQpSolution sol;
  sol.x = (qp.x_lo + qp.x_hi) / 2;
  Data data{&qp};
  SetIntermediateCallback(problem, count_iterations);
  Number obj = 0;
  const auto status =
      IpoptSolve(problem, sol.x.data(), nullptr, &obj, nullptr, nullptr, nullptr, &data);
  FreeIpoptProblem(problem);
  sol.status = static_cast<int>(status);
  sol.ok = status == Solve_Succeeded || status == Solved_To_Acceptable_Level;
  sol.objective = obj;
  sol.iterations = data.iterations;
  return sol;
}

QpResult solve_round(const SeparableQp& qp, const Eigen::SparseMatrix<double>* H,
                     const IpoptOptions& options) {
  const Eigen::Index n = qp.lo.size(), m = qp.b.size();
  GeneralQp g;
  g.c = H ? Eigen::VectorXd::Zero(n) : qp.h;
  if (H) g.Q = *H;
  g.x_lo = qp.lo;
  g.x_hi = qp.hi;
  g.row_lo.resize(m + 3);
  g.row_hi.resize(m + 3);
  g.row_lo.head(m) = qp.b;
  g.row_hi.head(m).setConstant(1e19);
  g.row_lo.tail(3) = qp.c;
  g.row_hi.tail(3) = qp.c;
  // Rows scaled to a largest coefficient of 1 (the center rows' are about 1 / #V): Ipopt's
  // tolerances are absolute.
  Eigen::VectorXd scale = Eigen::VectorXd::Zero(m + 3);
  for (Eigen::Index i = 0; i < n; ++i) {
    if (qp.row[i] >= 0) scale(qp.row[i]) = std::max(scale(qp.row[i]), std::abs(qp.a(i)));
    for (int k = 0; k < 3; ++k) scale(m + k) = std::max(scale(m + k), std::abs(qp.e(k, i)));
  }
  for (Eigen::Index j = 0; j < m + 3; ++j) {
    scale(j) = scale(j) > 0 ? 1 / scale(j) : 1;
    g.row_lo(j) *= scale(j);
    if (j >= m) g.row_hi(j) *= scale(j);
  }
  for (Eigen::Index i = 0; i < n; ++i) {
    if (qp.row[i] >= 0) g.A.emplace_back(qp.row[i], i, qp.a(i) * scale(qp.row[i]));
    for (int k = 0; k < 3; ++k) g.A.emplace_back(m + k, i, qp.e(k, i) * scale(m + k));
  }
  const GeneralQpSolution s = solve_general(g, options);
  QpResult r;
  r.x = s.x.cwiseMax(qp.lo).cwiseMin(qp.hi);
  r.objective = s.objective;
  r.iterations = s.iterations;
  r.status = s.ok ? QpStatus::Solved : QpStatus::IterationLimit;
  Eigen::VectorXd rows = Eigen::VectorXd::Zero(m);
  Eigen::Vector3d ex = -qp.c;
  for (Eigen::Index i = 0; i < n; ++i) {
    if (qp.row[i] >= 0) rows(qp.row[i]) += qp.a(i) * r.x(i);
    ex += qp.e.col(i) * r.x(i);
  }
  r.primal_residual = ex.cwiseAbs().maxCoeff();
  for (Eigen::Index j = 0; j < m; ++j)
    r.primal_residual = std::max(r.primal_residual, qp.b(j) - rows(j));
  return r;
}

}  // namespace

// The ipopt component: the core's solve_general_qp_with_ipopt and solve_round_with_ipopt
// (ipopt_dispatch.cpp) call these.
const detail::IpoptSolver kIpoptSolver{&solve_general, &solve_round};
MESHMARK_COMPONENT(ipopt, detail::ipopt_solver_slot(), kIpoptSolver)

}  // namespace meshmark
