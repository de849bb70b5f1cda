#include "meshmark/solve/separable_qp.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cassert>
#include <cmath>

namespace meshmark {

namespace {

// The variables regrouped by watermark row (those in no row first), in flat arrays, so that
// a pass over them keeps each row's sums in registers and reads memory in order.
struct PackedQp {
  std::vector<int> index;    // original index of each packed variable
  std::vector<int> offsets;  // segment k (0: in no row, j + 1: row j): [offsets[k], offsets[k + 1])
  std::vector<double> a, ex, ey, ez, h, d, lo, hi;  // d = 1 / (2 h)
};

PackedQp pack(const SeparableQp& qp) {
  const Eigen::Index n = qp.h.size(), m = qp.b.size();
  PackedQp p;
  p.offsets.assign(static_cast<std::size_t>(m + 2), 0);
  for (Eigen::Index i = 0; i < n; ++i) ++p.offsets[qp.row[i] + 1];
  int sum = 0;
  for (auto& o : p.offsets) {
    const int c = o;
    o = sum;
    sum += c;
  }
  p.offsets.push_back(sum);  // offsets[k] is now the start of segment k (segment 0: no row)
  std::vector<int> next(p.offsets.begin(), p.offsets.end() - 1);
  p.index.resize(static_cast<std::size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i) p.index[next[qp.row[i] + 1]++] = static_cast<int>(i);
  for (auto* v : {&p.a, &p.ex, &p.ey, &p.ez, &p.h, &p.d, &p.lo, &p.hi})
    v->resize(static_cast<std::size_t>(n));
  for (Eigen::Index k = 0; k < n; ++k) {
    const int i = p.index[k];
    p.a[k] = qp.row[i] >= 0 ? qp.a(i) : 0.0;
    p.ex[k] = qp.e(0, i);
    p.ey[k] = qp.e(1, i);
    p.ez[k] = qp.e(2, i);
    p.h[k] = qp.h(i);
    p.d[k] = qp.h(i) == 1.0 ? 0.5 : 0.5 / qp.h(i);  // unit weights are the common case
    p.lo[k] = qp.lo(i);
    p.hi[k] = qp.hi(i);
  }
  return p;
}

// Everything one pass over the variables gives for multipliers y: the primal minimizer (in
// packed order), the dual value and gradient, and the generalized Hessian blocks over the
// unclipped variables.
struct DualPoint {
  Eigen::VectorXd y;
  Eigen::VectorXd x;
  double value = 0;      // dual objective
  Eigen::VectorXd g;     // gradient: b - M x (m + 3)
  Eigen::VectorXd hww;   // m, diagonal block of M_F D M_F^T
  Eigen::Matrix3Xd hwe;  // 3 x m, coupling block
  Eigen::Matrix3d hee;   // equality block
};

void evaluate(const SeparableQp& qp, const PackedQp& pq, DualPoint& p) {
  const Eigen::Index n = qp.h.size(), m = qp.b.size();
  const double y0 = p.y(m), y1 = p.y(m + 1), y2 = p.y(m + 2);
  p.x.resize(n);
  p.g.resize(m + 3);
  p.hww.resize(m);
  p.hwe.resize(3, m);
  double value = 0, gx = 0, gy = 0, gz = 0;
  double hxx = 0, hxy = 0, hxz = 0, hyy = 0, hyz = 0, hzz = 0;
  for (Eigen::Index seg = 0; seg <= m; ++seg) {
    const double yj = seg > 0 ? p.y(seg - 1) : 0.0;
    double gj = 0, wj = 0, cx = 0, cy = 0, cz = 0;
    for (int k = pq.offsets[seg]; k < pq.offsets[seg + 1]; ++k) {
      const double a = pq.a[k], ex = pq.ex[k], ey = pq.ey[k], ez = pq.ez[k];
      const double z = a * yj + ex * y0 + ey * y1 + ez * y2;
      const double u = z * pq.d[k];
      const double xi = std::min(std::max(u, pq.lo[k]), pq.hi[k]);
      p.x(k) = xi;
      value += xi * (pq.h[k] * xi - z);
      gj += a * xi;
      gx += ex * xi, gy += ey * xi, gz += ez * xi;
      const double f = (u > pq.lo[k] && u < pq.hi[k]) ? pq.d[k] : 0.0;  // free: its curvature
      const double fa = f * a, fx = f * ex, fy = f * ey;
      wj += fa * a;
      cx += fa * ex, cy += fa * ey, cz += fa * ez;
      hxx += fx * ex, hxy += fx * ey, hxz += fx * ez;
      hyy += fy * ey, hyz += fy * ez, hzz += f * ez * ez;
    }
    if (seg > 0) {
      p.g(seg - 1) = qp.b(seg - 1) - gj;
      p.hww(seg - 1) = wj;
      p.hwe.col(seg - 1) = Eigen::Vector3d(cx, cy, cz);
    }
  }
  p.g.tail<3>() = qp.c - Eigen::Vector3d(gx, gy, gz);
  p.hee << hxx, hxy, hxz, hxy, hyy, hyz, hxz, hyz, hzz;
  p.value = value + qp.b.dot(p.y.head(m)) + qp.c.dot(p.y.tail<3>());
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

// Rows whose bounds alone keep them below b_j (one pass over the packed rows).
std::vector<int> unreachable_rows(const SeparableQp& qp, const PackedQp& pq, double tolerance) {
  const Eigen::Index m = qp.b.size();
  std::vector<int> rows;
  for (Eigen::Index j = 0; j < m; ++j) {
    double reach = 0;
    for (int k = pq.offsets[j + 1]; k < pq.offsets[j + 2]; ++k)
      reach += pq.a[k] * (pq.a[k] > 0 ? pq.hi[k] : pq.lo[k]);
    if (reach < qp.b(j) - tolerance) rows.push_back(static_cast<int>(j));
  }
  return rows;
}

// Farkas certificate of infeasibility from multipliers y (rows >= 0): every feasible x has
// (M^T y) . x >= b . y_rows + c . y_eq, while over the box (M^T y) . x is at most
// sum_i max(z_i lo_i, z_i hi_i), z = M^T y. When the right side exceeds that bound beyond
// rounding, no x is feasible. A concave dual that grows without bound (y running off to
// infinity, as it does when the rows and the center equality cannot hold together although
// each row alone can) points along such a y, so its iterates certify the infeasibility.
bool certifies_infeasibility(const SeparableQp& qp, const PackedQp& pq, const Eigen::VectorXd& y) {
  const Eigen::Index m = qp.b.size();
  const double scale = y.cwiseAbs().maxCoeff();
  if (!(scale > 0) || !std::isfinite(scale)) return false;
  const Eigen::VectorXd w = y / scale;  // the direction; rows already >= 0
  double demand = qp.b.dot(w.head(m)) + qp.c.dot(w.tail<3>());
  double supply = 0, magnitude = std::abs(demand);
  for (Eigen::Index seg = 0; seg <= m; ++seg) {
    const double wj = seg > 0 ? w(seg - 1) : 0.0;
    for (int k = pq.offsets[seg]; k < pq.offsets[seg + 1]; ++k) {
      const double z = pq.a[k] * wj + pq.ex[k] * w(m) + pq.ey[k] * w(m + 1) + pq.ez[k] * w(m + 2);
      supply += std::max(z * pq.lo[k], z * pq.hi[k]);
      magnitude += std::abs(z) * std::max(std::abs(pq.lo[k]), std::abs(pq.hi[k]));
    }
  }
  return demand - supply > 1e-9 * magnitude;
}

}  // namespace

const char* qp_status_name(QpStatus status) {
  return enum_name(status);
}

QpResult solve_separable_qp(const SeparableQp& qp, const QpSettings& settings,
                            const Eigen::VectorXd* warm_y) {
  [[maybe_unused]] const Eigen::Index n = qp.h.size();
  const Eigen::Index m = qp.b.size();
  assert(qp.lo.size() == n && qp.hi.size() == n && qp.a.size() == n && qp.e.cols() == n);
  assert(static_cast<Eigen::Index>(qp.row.size()) == n);
  QpResult result;
  const PackedQp pq = pack(qp);
  result.infeasible_rows = unreachable_rows(qp, pq, settings.tolerance);
  DualPoint p;
  p.y = warm_y && warm_y->size() == m + 3 ? *warm_y : Eigen::VectorXd::Zero(m + 3);
  p.y.head(m) = p.y.head(m).cwiseMax(0.0);
  evaluate(qp, pq, p);
  auto finish = [&](QpStatus status) {
    result.status = status;
    result.x.resize(qp.h.size());
    for (std::size_t k = 0; k < pq.index.size(); ++k) result.x(pq.index[k]) = p.x(k);
    result.y = p.y;
    result.objective = (qp.h.array() * result.x.array().square()).sum();
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
      evaluate(qp, pq, trial);
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
    // A solve that takes long may be one whose dual is unbounded: look for the certificate
    // now and then (an O(n) pass; feasible solves end in a few iterations).
    if ((it + 1) % 8 == 0 && certifies_infeasibility(qp, pq, p.y))
      return finish(QpStatus::Infeasible);
  }
  double primal = 0, comp = 0;
  if (kkt_residual(p, m, primal, comp) <= settings.tolerance) return finish(QpStatus::Solved);
  return finish(certifies_infeasibility(qp, pq, p.y) ? QpStatus::Infeasible
                                                     : QpStatus::IterationLimit);
}

}  // namespace meshmark
