#pragma once
// An independent construction of the embedding QP: the problem of docs/method.md section 3 built
// from the geometry by code written only for the tests, to be solved by Ipopt (through the
// library's general-purpose backend, a thin wrapper over Ipopt's C interface).

#include <Eigen/Core>
#include <vector>

#include "solve/ipopt_qp.h"

namespace meshmark::test {

/// The DRS problem (discrete center, radial directions, squared error) for payload bits, in
/// model units: variable i is the radial displacement of referenced vertex referenced[i], the
/// first vertex at its position (each distinct position counts once; variables in vertex
/// order). directions receives rhohat per referenced vertex.
GeneralQp drs_reference_problem(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                                const std::vector<int>& bits, double alpha, double G,
                                std::vector<int>& referenced, Eigen::MatrixX3d& directions);

}  // namespace meshmark::test
