#pragma once
/// \file solver_settings.h
/// The settings of the solvers that answer an embedding round's quadratic program, apart from
/// the solvers themselves (admm_qp.h, ipopt_qp.h, separable_qp.h), so that embed.h's users
/// compile without Eigen's sparse modules. Which solver a round uses is decided in one place
/// (src/mark/qp_solver.h) from EmbedOptions: backend, the variant's cost and admm.x_step.

#include "meshmark/core/enum_names.h"
#include "meshmark/solve/separable_qp.h"

namespace meshmark {

/// Which solver answers each round's quadratic program (the CLI's --solver).
enum class SolverBackend {
  Native,  ///< the structured solvers: exact dual Newton (costs S, Q), ADMM (cost L)
  Ipopt,   ///< the general-purpose interior-point solver, for comparison
};

/// The names of SolverBackend's values.
template <>
struct EnumTable<SolverBackend> {
  static constexpr const char* what = "solver";
  static constexpr NamedValue<SolverBackend> values[] = {{SolverBackend::Native, "native"},
                                                         {SolverBackend::Ipopt, "ipopt"}};
};

/// How the ADMM x-step solves (2 H + rho I) x = rhs.
enum class AdmmXStep {
  ConjugateGradients,  ///< matrix-free, Jacobi-preconditioned, inexact where that suffices
  Cholesky,            ///< sparse LDL^T (AMD ordering) of the assembled matrix, exact
};

/// The names of AdmmXStep's values.
template <>
struct EnumTable<AdmmXStep> {
  static constexpr const char* what = "x-step";
  static constexpr NamedValue<AdmmXStep> values[] = {{AdmmXStep::ConjugateGradients, "cg"},
                                                     {AdmmXStep::Cholesky, "cholesky"}};
};

/// Settings of the ADMM solver (admm_qp.h). Residuals are in the problem's units (bin widths
/// for an embedding round).
struct AdmmSettings {
  AdmmXStep x_step = AdmmXStep::ConjugateGradients;  ///< Cholesky needs an assembled Hessian
  double rho = 0;           ///< penalty; 0 picks sqrt(smallest * largest diagonal of 2H)
  double relaxation = 1.8;  ///< over-relaxation alpha in (0, 2)
  double tolerance = 1e-7;  ///< on |x - z|_inf and rho |z - z_prev|_inf
  int max_iterations = 5000;
  /// Stalled: this many ADMM iterations without halving the best residual so far
  /// (max(|x - z|_inf, |z - z_prev|_inf)) end the solve.
  int stall_iterations = 500;
  double cg_tolerance = 1e-8;  ///< relative residual of each x-step (ADMM tolerates inexact steps)
  int max_cg_iterations = 1000;  ///< per x-step; an x-step that needs more ends the solve
};

/// Ipopt's settings (ipopt_qp.h).
struct IpoptOptions {
  double tolerance = 1e-13;  ///< Ipopt's tol
  int max_iterations = 1000;
};

}  // namespace meshmark
