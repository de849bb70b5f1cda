#include "ipopt_reference.h"

#include <IpStdCInterface.h>

#include <algorithm>
#include <cmath>
#include <set>

namespace meshmark::test {

namespace {

struct Data {
  const SparseQp* qp;
};

Eigen::VectorXd quadratic_part(const SparseQp& qp, const Number* x) {
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
std::vector<std::pair<Index, Index>> hessian_pattern(const SparseQp& qp) {
  std::vector<std::pair<Index, Index>> pattern;
  const auto n = static_cast<Index>(qp.c.size());
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

}  // namespace

ReferenceSolution solve_with_ipopt(const SparseQp& qp) {
  const auto n = static_cast<Index>(qp.c.size());
  const auto m = static_cast<Index>(qp.row_lo.size());
  Eigen::VectorXd xl = qp.x_lo, xu = qp.x_hi, gl = qp.row_lo, gu = qp.row_hi;
  IpoptProblem problem = CreateIpoptProblem(n, xl.data(), xu.data(), m, gl.data(), gu.data(),
                                            static_cast<Index>(qp.A.size()),
                                            static_cast<Index>(hessian_pattern(qp).size()), 0,
                                            eval_f, eval_g, eval_grad_f, eval_jac_g, eval_h);
  AddIpoptIntOption(problem, const_cast<char*>("print_level"), 0);
  AddIpoptNumOption(problem, const_cast<char*>("tol"), 1e-13);
  AddIpoptNumOption(problem, const_cast<char*>("bound_relax_factor"), 0.0);
  AddIpoptIntOption(problem, const_cast<char*>("max_iter"), 500);
  AddIpoptStrOption(problem, const_cast<char*>("hessian_constant"), const_cast<char*>("yes"));
  AddIpoptStrOption(problem, const_cast<char*>("jac_c_constant"), const_cast<char*>("yes"));
  AddIpoptStrOption(problem, const_cast<char*>("jac_d_constant"), const_cast<char*>("yes"));
  AddIpoptStrOption(problem, const_cast<char*>("sb"), const_cast<char*>("yes"));
  ReferenceSolution sol;
  sol.x = (qp.x_lo + qp.x_hi) / 2;
  Data data{&qp};
  Number obj = 0;
  const auto status =
      IpoptSolve(problem, sol.x.data(), nullptr, &obj, nullptr, nullptr, nullptr, &data);
  FreeIpoptProblem(problem);
  sol.status = static_cast<int>(status);
  sol.ok = status == Solve_Succeeded || status == Solved_To_Acceptable_Level;
  sol.objective = obj;
  return sol;
}

SparseQp drs_reference_problem(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                               const std::vector<int>& bits, double alpha, double G,
                               std::vector<int>& referenced, Eigen::MatrixX3d& directions) {
  std::set<int> used(F.data(), F.data() + F.size());
  referenced.assign(used.begin(), used.end());
  const auto n = static_cast<Eigen::Index>(referenced.size());
  Eigen::Vector3d C = Eigen::Vector3d::Zero();
  for (int i : referenced) C += V.row(i).transpose();
  C /= static_cast<double>(n);
  Eigen::VectorXd rho(n);
  directions.resize(n, 3);
  for (Eigen::Index k = 0; k < n; ++k) {
    const Eigen::Vector3d d = V.row(referenced[k]).transpose() - C;
    rho(k) = d.norm();
    directions.row(k) = (d / rho(k)).transpose();
  }
  const double lo = rho.minCoeff(), hi = rho.maxCoeff();
  const int nb = static_cast<int>(bits.size()), nB = nb + 2;
  const double s = (hi - lo) / nB;
  std::vector<int> bin(static_cast<std::size_t>(n));
  Eigen::VectorXd t(n), sum_t = Eigen::VectorXd::Zero(nB), count = Eigen::VectorXd::Zero(nB);
  for (Eigen::Index k = 0; k < n; ++k) {
    const double x = (rho(k) - lo) / s;
    bin[k] = std::min(static_cast<int>(std::floor(x)), nB - 1);
    t(k) = x - bin[k];
    sum_t(bin[k]) += t(k);
    count(bin[k]) += 1;
  }
  SparseQp qp;
  qp.c = Eigen::VectorXd::Ones(n);
  qp.x_lo.resize(n);
  qp.x_hi.resize(n);
  for (Eigen::Index k = 0; k < n; ++k) {
    const bool fixed = rho(k) == lo || rho(k) == hi;
    qp.x_lo(k) = fixed ? 0 : s * (G - t(k));
    qp.x_hi(k) = fixed ? 0 : s * (1 - G - t(k));
  }
  qp.row_lo.resize(nb + 3);
  qp.row_hi.resize(nb + 3);
  for (int j = 0; j < nb; ++j) {
    const double mj = bits[j] ? 1 : -1;
    qp.row_lo(j) = alpha - mj * (sum_t(j + 1) / count(j + 1) - 0.5);
    qp.row_hi(j) = 1e19;  // Ipopt's infinity
  }
  for (int a = 0; a < 3; ++a) qp.row_lo(nb + a) = qp.row_hi(nb + a) = 0;
  for (Eigen::Index k = 0; k < n; ++k) {
    const int b = bin[k];
    if (b >= 1 && b <= nb) qp.A.emplace_back(b - 1, k, (bits[b - 1] ? 1.0 : -1.0) / (count(b) * s));
    for (int a = 0; a < 3; ++a)
      qp.A.emplace_back(nb + a, k, directions(k, a) / static_cast<double>(n));
  }
  return qp;
}

}  // namespace meshmark::test
