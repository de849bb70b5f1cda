#include "meshmark/histogram.h"

#include <cmath>
#include <limits>

namespace meshmark {

Histogram build_histogram(const Eigen::MatrixX3d& V, const std::vector<std::uint8_t>& referenced,
                          const Eigen::Vector3d& center, int nbits) {
  Histogram h;
  h.center = center;
  h.bins = nbits + 2;
  const Eigen::Index nv = V.rows();
  h.rho = Eigen::VectorXd::Constant(nv, std::numeric_limits<double>::quiet_NaN());
  h.t = Eigen::VectorXd::Zero(nv);
  h.bin.assign(static_cast<std::size_t>(nv), -1);
  h.rho_min = std::numeric_limits<double>::infinity();
  h.rho_max = -h.rho_min;
  for (Eigen::Index i = 0; i < nv; ++i) {
    if (!referenced[i]) continue;
    const double r = (V.row(i).transpose() - center).norm();
    h.rho(i) = r;
    if (r < h.rho_min) h.rho_min = r, h.argmin = static_cast<int>(i);
    if (r > h.rho_max) h.rho_max = r, h.argmax = static_cast<int>(i);
  }
  if (h.argmin < 0 || !(h.rho_max > h.rho_min)) {
    h.step = 0;
    return h;
  }
  h.step = (h.rho_max - h.rho_min) / h.bins;
  for (Eigen::Index i = 0; i < nv; ++i) {
    if (!referenced[i]) continue;
    const double x = (h.rho(i) - h.rho_min) / h.step;
    const int b = std::min(static_cast<int>(std::floor(x)), h.bins - 1);
    h.bin[i] = b;
    h.t(i) = x - b;
  }
  return h;
}

}  // namespace meshmark
