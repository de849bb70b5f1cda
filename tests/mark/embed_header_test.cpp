// embed.h compiles without Eigen's sparse modules: its users (the CLI, campaigns, bindings)
// do not parse the sparse Cholesky and sparse matrix headers. This translation unit includes
// embed.h alone; the checks are the modules' own include guards, as Eigen defines them
// (/usr/include/eigen3/Eigen/SparseCholesky, Eigen/SparseCore).

#include "meshmark/mark/embed.h"

namespace {

#ifdef EIGEN_SPARSECHOLESKY_MODULE_H
constexpr bool kSparseCholeskyIncluded = true;
#else
constexpr bool kSparseCholeskyIncluded = false;
#endif
#ifdef EIGEN_SPARSECORE_MODULE_H
constexpr bool kSparseCoreIncluded = true;
#else
constexpr bool kSparseCoreIncluded = false;
#endif

static_assert(!kSparseCholeskyIncluded, "embed.h pulls in Eigen/SparseCholesky");
static_assert(!kSparseCoreIncluded, "embed.h pulls in Eigen/SparseCore");

// The scheme is the right one: Eigen/Core, which embed.h does include, defines its guard.
#ifndef EIGEN_CORE_H
static_assert(false, "Eigen/Core's guard is not EIGEN_CORE_H: check the names above");
#endif

}  // namespace
