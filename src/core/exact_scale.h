#pragma once
// Internal: vectors scaled by a power of two, which floating point does exactly, so that
// products of several lengths (squared areas, fourth powers) neither underflow nor overflow on
// meshes of tiny or huge coordinates, and give the same bits as unscaled ones elsewhere.

#include <Eigen/Core>
#include <cmath>

namespace meshmark::detail {

/// x times 2^-e, e the binary exponent of its largest component (std::frexp): its largest
/// component's magnitude then lies in [1/2, 1). Exact (std::ldexp); x = 0 gives 0 and e = 0.
template <class Vector>
Vector power_of_two_scaled(const Vector& x, int& e) {
  std::frexp(x.cwiseAbs().maxCoeff(), &e);
  const int k = e;
  return x.unaryExpr([k](double xi) { return std::ldexp(xi, -k); });
}

}  // namespace meshmark::detail
