// The Ipopt backend's entry points in a build without Ipopt (-DMESHMARK_WITH_IPOPT=OFF): each
// refuses with a message that names the build option, so that `--solver ipopt` fails clearly.

#include "meshmark/core/error.h"
#include "solve/ipopt_qp.h"

namespace meshmark {

namespace {

[[noreturn]] void refuse() {
  throw InvalidArgumentError(
      "the Ipopt backend is not available: meshmark was built with -DMESHMARK_WITH_IPOPT=OFF");
}

}  // namespace

GeneralQpSolution solve_general_qp_with_ipopt(const GeneralQp&, const IpoptOptions&) {
  refuse();
}

QpResult solve_round_with_ipopt(const SeparableQp&, const Eigen::SparseMatrix<double>*,
                                const IpoptOptions&) {
  refuse();
}

}  // namespace meshmark
