#include "meshmark/separable_qp.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cassert>
#include <cmath>

namespace meshmark {

namespace {

// Everything one pass over the variables gives for multipliers y: the primal minimizer, the
// dual value and gradient, and the generalized Hessian blocks over the unclipped variables.
struct DualPoint {
  Eigen::VectorXd y;
  Eigen::VectorXd x;
  double value = 0;      // dual objective
  Eigen::VectorXd g;     // gradient: b - M x (m + 3)
  Eigen::VectorXd hww;   // m, diagonal block of M_F D M_F^T
  Eigen::Matrix3Xd hwe;  // 3 x m, coupling block
  Eigen::Matrix3d hee;   // equality block
};

void evaluate(const SeparableQp& qp, DualPoint& p) {
  const Eigen::Index n = qp.h.size(), m = qp.b.size();
  const Eigen::Vector3d ye = p.y.tail<3>();
  p.x.resize(n);
  p.g.setZero(m + 3);
  p.hww.setZero(m);
  p.hwe.setZero(3, m);
  p.hee.setZero();
  double value = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    const int j = qp.row[i];
    const Eigen::Vector3d ei = qp.e.col(i);
    const double z = (j >= 0 ? qp.a(i) * p.y(j) : 0.0) + ei.dot(ye);
    const double d = 0.5 / qp.h(i);
    const double u = z * d;
    const double xi = std::clamp(u, qp.lo(i), qp.hi(i));
    p.x(i) = xi;
    value += qp.h(i) * xi * xi - z * xi;
    if (j >= 0) p.g(j) -= qp.a(i) * xi;
    p.g.tail<3>() -= ei * xi;
    if (u > qp.lo(i) && u < qp.hi(i)) {
      if (j >= 0) {
        p.hww(j) += qp.a(i) * qp.a(i) * d;
        p.hwe.col(j) += (qp.a(i) * d) * ei;
      }
      p.hee.noalias() += d * ei * ei.transpose();
    }
  }
  p.g.head(m) += qp.b;
  p.g.tail<3>() += qp.c;
  p.value = value + qp.b.dot(p.y.head(m)) + qp.c.dot(ye);
}

// Residual of the KKT conditions that x(y) does not satisfy by construction.
double kkt_residual(const DualPoint& p, Eigen::Index m, double& primal, double& complementarity) {
  primal = p.g.tail<3>().cwiseAbs().maxCoeff();
  complementarity = 0;
  for (Eigen::Index j = 0; j < m; ++j) {
    primal = std::max(primal, p.g(j));
    complementarity = std::max(complementarity, std::abs(std::min(p.y(j), -p.g(j))));
  }
  return std::max(primal, complementarity);
}

// Newton direction on the rows not held at y_j = 0, by a Schur complement on the 3 x 3
// equality block. Rows held at their bound get a zero step.
Eigen::VectorXd newton_direction(const DualPoint& p, Eigen::Index m, double mu) {
  Eigen::VectorXd dy = Eigen::VectorXd::Zero(m + 3);
  Eigen::Matrix3d schur = p.hee + mu * Eigen::Matrix3d::Identity();
  Eigen::Vector3d rhs = p.g.tail<3>();
  std::vector<char> held(static_cast<std::size_t>(m), 0);
  for (Eigen::Index j = 0; j < m; ++j) {
    held[j] = p.y(j) <= 0 && p.g(j) <= 0;
    if (held[j]) continue;
    const double dj = p.hww(j) + mu;
    schur.noalias() -= p.hwe.col(j) * p.hwe.col(j).transpose() / dj;
    rhs -= p.hwe.col(j) * (p.g(j) / dj);
  }
  const Eigen::Vector3d dye = schur.ldlt().solve(rhs);
  dy.tail<3>() = dye;
  for (Eigen::Index j = 0; j < m; ++j)
    if (!held[j]) dy(j) = (p.g(j) - p.hwe.col(j).dot(dye)) / (p.hww(j) + mu);
  return dy;
}

// Rows whose bounds alone keep them below b_j.
std::vector<int> unreachable_rows(const SeparableQp& qp, double tolerance) {
  const Eigen::Index m = qp.b.size();
  Eigen::VectorXd reach = Eigen::VectorXd::Zero(m);
  for (Eigen::Index i = 0; i < qp.h.size(); ++i)
    if (qp.row[i] >= 0) reach(qp.row[i]) += qp.a(i) * (qp.a(i) > 0 ? qp.hi(i) : qp.lo(i));
  std::vector<int> rows;
  for (Eigen::Index j = 0; j < m; ++j)
    if (reach(j) < qp.b(j) - tolerance) rows.push_back(static_cast<int>(j));
  return rows;
}

}  // namespace

const char* qp_status_name(QpStatus status) {
  switch (status) {
    case QpStatus::Solved:
      return "solved";
    case QpStatus::Infeasible:
      return "infeasible";
    case QpStatus::IterationLimit:
      return "iteration limit";
  }
  return "?";
}

QpResult solve_separable_qp(const SeparableQp& qp, const QpSettings& settings,
                            const Eigen::VectorXd* warm_y) {
  [[maybe_unused]] const Eigen::Index n = qp.h.size();
  const Eigen::Index m = qp.b.size();
  assert(qp.lo.size() == n && qp.hi.size() == n && qp.a.size() == n && qp.e.cols() == n);
  assert(static_cast<Eigen::Index>(qp.row.size()) == n);
  QpResult result;
  result.infeasible_rows = unreachable_rows(qp, settings.tolerance);
  DualPoint p;
  p.y = warm_y && warm_y->size() == m + 3 ? *warm_y : Eigen::VectorXd::Zero(m + 3);
  p.y.head(m) = p.y.head(m).cwiseMax(0.0);
  evaluate(qp, p);
  auto finish = [&](QpStatus status) {
    result.status = status;
    result.x = p.x;
    result.y = p.y;
    result.objective = (qp.h.array() * p.x.array().square()).sum();
    kkt_residual(p, m, result.primal_residual, result.complementarity);
    return result;
  };
  if (!result.infeasible_rows.empty()) return finish(QpStatus::Infeasible);

  DualPoint trial;
  for (int it = 0; it < settings.max_iterations; ++it) {
    double primal = 0, comp = 0;
    if (kkt_residual(p, m, primal, comp) <= settings.tolerance) return finish(QpStatus::Solved);
    result.iterations = it + 1;
    // Levenberg-style regularization that fades as the gradient vanishes, so that rows whose
    // variables are all clipped still get a bounded step.
    const double scale =
        std::max({p.hww.size() ? p.hww.maxCoeff() : 0.0, p.hee.diagonal().maxCoeff(), 1e-300});
    const double mu = scale * std::max(1e-15, std::min(1e-4, std::max(primal, comp)));
    const Eigen::VectorXd dy = newton_direction(p, m, mu);
    // Projected backtracking (Armijo along the projection arc) on the concave dual.
    double step = 1.0;
    bool accepted = false;
    for (int k = 0; k < 60; ++k, step *= 0.5) {
      trial.y = p.y + step * dy;
      trial.y.head(m) = trial.y.head(m).cwiseMax(0.0);
      evaluate(qp, trial);
      // Near the optimum the change of the dual value drowns in rounding: a full step that
      // halves the KKT residual is taken on that evidence instead.
      double tp = 0, tc = 0;
      const bool residual_halved =
          k == 0 && kkt_residual(trial, m, tp, tc) <= 0.5 * std::max(primal, comp);
      if (residual_halved || trial.value >= p.value + 1e-4 * p.g.dot(trial.y - p.y)) {
        accepted = true;
        break;
      }
    }
    if (!accepted) break;
    std::swap(p, trial);  // the trial point, Hessian included, becomes the iterate
    if (!std::isfinite(p.value) || p.y.cwiseAbs().maxCoeff() > 1e30)
      return finish(QpStatus::Infeasible);
  }
  double primal = 0, comp = 0;
  return finish(kkt_residual(p, m, primal, comp) <= settings.tolerance ? QpStatus::Solved
                                                                       : QpStatus::IterationLimit);
}

}  // namespace meshmark
