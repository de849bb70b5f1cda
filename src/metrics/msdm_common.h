#pragma once
// What MSDM (msdm.cpp) and MSDM2 (msdm2.cpp) share: the bounding box's longest side, MSDM's
// comparison of two windows' statistics, the pooling of local values.

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstddef>

#include "meshmark/core/mesh.h"

namespace meshmark::detail {

/// Positions with one cache line per point, for the walks.
using RowPoints = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;

/// Longest side of the bounding box of the vertices F references (MSDM's D).
inline double longest_side(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F) {
  const auto used = referenced_vertices(F, V.rows());
  Eigen::RowVector3d lo = Eigen::RowVector3d::Constant(1e300), hi = -lo;
  for (Eigen::Index i = 0; i < V.rows(); ++i)
    if (used[i]) lo = lo.cwiseMin(V.row(i)), hi = hi.cwiseMax(V.row(i));
  return used.empty() || hi(0) < lo(0) ? 0.0 : (hi - lo).maxCoeff();
}

/// Gaussian-weighted statistics of one window: mean and standard deviation of the curvature.
struct WindowStats {
  double mean = 0, deviation = 0;
};

/// MSDM's three comparison terms (Lavoue et al. 2006, eq. 4-6): luminance-like L,
/// contrast-like C and structure-like S, from both windows' statistics and their covariance.
struct MsdmTerms {
  double L = 0, C = 0, S = 0;
};

inline MsdmTerms msdm_terms(const WindowStats& x, const WindowStats& y, double covariance) {
  MsdmTerms t;
  t.L = std::abs(x.mean - y.mean) / (std::max(x.mean, y.mean) + 1);
  t.C = std::abs(x.deviation - y.deviation) / (std::max(x.deviation, y.deviation) + 1);
  t.S = std::abs(x.deviation * y.deviation - covariance) / (x.deviation * y.deviation + 1);
  return t;
}

/// Which of the n points (x[j], y[j], z[j]) lies nearest (qx, qy, qz), as a loop that starts
/// from point 0 and moves to each strictly nearer one finds it with Eigen's squaredNorm: the
/// first of equally near ones, squared distances summed as (dx^2 + dy^2) + dz^2, a later
/// distance that is not a number never winning, point 0 kept when its own is not one. MSDM's
/// pairing of samples (msdm.cpp). Same units as the points; n >= 1.
std::ptrdiff_t nearest_point(const double* x, const double* y, const double* z, std::ptrdiff_t n,
                             double qx, double qy, double qz);

/// (mean of local^3)^(1/3) over the vertices F references, or over those of every
/// `stride`-th vertex (0, stride, 2 stride, ...).
inline double pool3(const Eigen::VectorXd& local, const Eigen::MatrixX3i& F,
                    Eigen::Index stride = 1) {
  const auto used = referenced_vertices(F, local.size());
  double sum = 0, n = 0;
  for (Eigen::Index i = 0; i < local.size(); i += stride)
    if (used[i]) sum += local(i) * local(i) * local(i), n += 1;
  return n > 0 ? std::cbrt(sum / n) : 0.0;
}

}  // namespace meshmark::detail
