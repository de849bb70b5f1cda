#include "solve/admm_qp.h"

#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>
#include <limits>

#include "meshmark/core/error.h"

namespace meshmark {

struct AdmmQpSolver::Factorization {
  Eigen::SparseMatrix<double> K;  // 2 H + rho I
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
};

AdmmQpSolver::AdmmQpSolver() : factors_(std::make_unique<Factorization>()) {}
AdmmQpSolver::~AdmmQpSolver() = default;
AdmmQpSolver::AdmmQpSolver(AdmmQpSolver&&) noexcept = default;
AdmmQpSolver& AdmmQpSolver::operator=(AdmmQpSolver&&) noexcept = default;

void AdmmQpSolver::set_hessian(HessianOperator H, const AdmmSettings& settings, bool refactor) {
  settings_ = settings;
  factored_k_ = false;  // an operator has no factors (the matrix overload sets them again)
  H_ = std::move(H);
  const Eigen::VectorXd d = 2 * H_.diagonal;
  if ((d.array() < 0).any() || !d.allFinite())
    throw Error("ADMM: the Hessian has a negative diagonal (is it positive semidefinite?)");
  if (!rho_chosen_ || refactor) {
    rho_ = settings.rho > 0
               ? settings.rho
               : std::sqrt(std::max(d.minCoeff(), 1e-12) * std::max(d.maxCoeff(), 1e-12));
    rho_chosen_ = true;
  }
  inv_diagonal_ = (d.array() + rho_).inverse().matrix();
}

void AdmmQpSolver::set_hessian(const Eigen::SparseMatrix<double>& H, const AdmmSettings& settings,
                               bool refactor) {
  const bool had_factors = factored_k_;
  HessianOperator op;
  op.diagonal = H.diagonal();
  op.apply = [H](const Eigen::VectorXd& x, Eigen::VectorXd& Hx) { Hx.noalias() = H * x; };
  set_hessian(std::move(op), settings, refactor);
  if (settings.x_step != AdmmXStep::Cholesky) return;
  Eigen::SparseMatrix<double> K = 2 * H;
  K.diagonal().array() += rho_;
  K.makeCompressed();
  const bool same_pattern =
      analyzed_ && K.rows() == factors_->K.rows() && K.nonZeros() == factors_->K.nonZeros() &&
      std::equal(K.outerIndexPtr(), K.outerIndexPtr() + K.outerSize() + 1,
                 factors_->K.outerIndexPtr()) &&
      std::equal(K.innerIndexPtr(), K.innerIndexPtr() + K.nonZeros(), factors_->K.innerIndexPtr());
  if (same_pattern && had_factors && !refactor &&
      std::equal(K.valuePtr(), K.valuePtr() + K.nonZeros(), factors_->K.valuePtr())) {
    factored_k_ = true;  // the same matrix: keep its factors
    return;
  }
  if (!same_pattern) {
    factors_->ldlt.analyzePattern(K);
    analyzed_ = true;
  }
  factors_->ldlt.factorize(K);
  if (factors_->ldlt.info() != Eigen::Success)
    throw Error("ADMM: the LDL^T factorization failed (is the Hessian positive semidefinite?)");
  factors_->K = std::move(K);
  factored_k_ = true;
  ++factorizations_;
}

void AdmmQpSolver::apply_k(const Eigen::VectorXd& x, Eigen::VectorXd& Kx) const {
  H_.apply(x, Kx);
  Kx = 2 * Kx + rho_ * x;
}

// Conjugate gradients on K x = rhs from guess, to a relative residual of cg_tolerance, with
// the diagonal of K as preconditioner: K = 2 H + rho I is well conditioned (H's spectrum lies
// in [lambda min w, lambda max w + 4 (1 - lambda)], and rho shifts it away from 0), so a few
// iterations suffice and no factorization is needed. Works in the solver's scratch vectors.
bool AdmmQpSolver::solve_x(const Eigen::VectorXd& rhs, Eigen::VectorXd& x,
                           double looser_target) const {
  if (settings_.x_step == AdmmXStep::Cholesky) {
    if (!factored_k_) throw Error("ADMM: Cholesky x-steps need an assembled Hessian");
    x = factors_->ldlt.solve(rhs);
    return x.allFinite();
  }
  // The guess is the previous x-step's answer, whose residual against the previous right-hand
  // side CG has kept: K x = last_rhs - r, so the new residual costs no product with K. The
  // caller asks for the true residual now and then, so that rounding cannot build up.
  if (residual_known_) {
    r_ += rhs - last_rhs_;
  } else {
    apply_k(x, Kp_);
    r_ = rhs - Kp_;
  }
  last_rhs_ = rhs;
  residual_known_ = true;
  const double target =
      std::max(settings_.cg_tolerance * std::max(rhs.norm(), 1e-300), looser_target);
  if (r_.norm() <= target) return true;
  z_ = r_.cwiseProduct(inv_diagonal_);
  p_ = z_;
  double rz = r_.dot(z_);
  for (int k = 0; k < settings_.max_cg_iterations; ++k) {
    ++cg_iterations_;
    apply_k(p_, Kp_);
    const double step = rz / p_.dot(Kp_);
    if (!std::isfinite(step) || step <= 0) break;  // K is not positive definite
    x += step * p_;
    r_ -= step * Kp_;
    if (r_.norm() <= target) return true;
    z_ = r_.cwiseProduct(inv_diagonal_);
    const double rz_next = r_.dot(z_);
    p_ = z_ + (rz_next / rz) * p_;
    rz = rz_next;
  }
  residual_known_ = false;
  return false;
}

const char* admm_stop_name(AdmmStop stop) {
  return enum_name(stop);
}

QpResult AdmmQpSolver::solve(const SeparableQp& qp, const Eigen::VectorXd* warm_z,
                             const Eigen::VectorXd* warm_u) {
  const Eigen::Index n = qp.lo.size();
  QpResult result;
  Eigen::VectorXd z = warm_z && warm_z->size() == n ? *warm_z : qp.lo.cwiseMax(0.0).cwiseMin(qp.hi);
  u_ = warm_u && warm_u->size() == n ? *warm_u : Eigen::VectorXd::Zero(n);
  // The projection problem: min |d|^2 with z = v + d inside the constraint set.
  SeparableQp proj = qp;
  proj.h = Eigen::VectorXd::Ones(n);
  Eigen::VectorXd y;  // projection multipliers, for warm starts
  Eigen::VectorXd x = z, z_prev(n), v(n);
  cg_iterations_ = 0;
  auto stop = [&](AdmmStop why) {
    stop_ = why;
    result.status = why == AdmmStop::Converged    ? QpStatus::Solved
                    : why == AdmmStop::Infeasible ? QpStatus::Infeasible
                                                  : QpStatus::IterationLimit;
    result.x = z;
    result.y = y;
    Eigen::VectorXd Hz;
    H_.apply(z, Hz);
    result.objective = z.dot(Hz);
    return result;
  };
  const double alpha = settings_.relaxation;
  // Inexact x-steps: far from the answer, an x-step need not be more accurate than the ADMM
  // residuals show the iterate to be. Its error is at most |r|_2 / lambda_min(K) <= |r|_2 / rho,
  // so a residual of 0.3 rho times the last ADMM residual keeps the error below a third of it
  // (0.1 to 1 measured alike); near the answer the relative cg_tolerance takes over. The errors
  // shrink as fast as the residuals do, which keeps ADMM convergent.
  double progress = std::numeric_limits<double>::infinity();
  // Stall watch: the best residual so far, and the iteration that last halved it.
  double best = std::numeric_limits<double>::infinity();
  int best_at = 0;
  for (int it = 0; it < settings_.max_iterations; ++it) {
    if (it % 16 == 0) residual_known_ = false;  // a fresh K x now and then
    if (!solve_x(rho_ * (z - u_), x, std::isfinite(progress) ? 0.3 * rho_ * progress : 0.0))
      return stop(AdmmStop::XStepFailed);
    const Eigen::VectorXd xr = alpha * x + (1 - alpha) * z;
    v = xr + u_;
    // Shift the constraints to the unknown d = z - v.
    proj.lo = qp.lo - v;
    proj.hi = qp.hi - v;
    proj.b = qp.b;
    proj.c = qp.c;
    for (Eigen::Index i = 0; i < n; ++i) {
      if (qp.row[i] >= 0) proj.b(qp.row[i]) -= qp.a(i) * v(i);
      proj.c -= qp.e.col(i) * v(i);
    }
    const QpResult p = solve_separable_qp(proj, {}, y.size() ? &y : nullptr);
    if (p.status == QpStatus::Infeasible) {
      result.infeasible_rows = p.infeasible_rows;
      return stop(AdmmStop::Infeasible);
    }
    // z must lie in the constraint set: a projection that did not converge ends the solve,
    // unless only rounding kept it from its tolerance (constraints within 1 % of ADMM's).
    if (p.status != QpStatus::Solved && !(p.primal_residual <= 0.01 * settings_.tolerance))
      return stop(AdmmStop::ProjectionFailed);
    y = p.y;
    z_prev = z;
    z = v + p.x;
    u_ += xr - z;
    result.iterations = it + 1;
    result.primal_residual = (x - z).cwiseAbs().maxCoeff();
    result.dual_residual = rho_ * (z - z_prev).cwiseAbs().maxCoeff();
    progress = std::min(result.primal_residual, result.dual_residual / rho_);
    if (result.primal_residual <= settings_.tolerance &&
        result.dual_residual <= settings_.tolerance)
      return stop(AdmmStop::Converged);
    const double residual = std::max(result.primal_residual, result.dual_residual / rho_);
    if (residual <= 0.5 * best || !std::isfinite(best)) best = residual, best_at = it;
    if (it - best_at >= settings_.stall_iterations) return stop(AdmmStop::Stalled);
  }
  return stop(AdmmStop::IterationLimit);
}

}  // namespace meshmark
