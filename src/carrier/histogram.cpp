#include "meshmark/carrier/histogram.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

#include "core/exact_scale.h"
#include "meshmark/core/error.h"
#include "meshmark/core/mesh.h"

namespace meshmark {

std::vector<std::uint8_t> carrier_vertices(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F) {
  const Eigen::Index nv = V.rows();
  std::vector<std::uint8_t> used(static_cast<std::size_t>(nv), 0);  // 1 carrier, 2 orphan
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const int a = F(f, 0), b = F(f, 1), c = F(f, 2);
    if (a < 0 || b < 0 || c < 0 || a >= nv || b >= nv || c >= nv) continue;
    const Eigen::RowVector3d pa = V.row(a), pb = V.row(b), pc = V.row(c);
    if (pa == pb || pb == pc || pc == pa) continue;  // collapsed
    // Flat: the sine of the angle at a below 1e-9 (three collinear corners, or a sliver an
    // attacker hides a vertex in). Each side is scaled by a power of two (exactly), so that the
    // test's fourth powers neither underflow (coordinates below about 1e-77 made every triangle
    // flat) nor overflow (above about 1e77); elsewhere the answer is the unscaled one, bit for
    // bit.
    int eu = 0, ev = 0;
    const Eigen::RowVector3d u = detail::power_of_two_scaled<Eigen::RowVector3d>(pb - pa, eu),
                             v = detail::power_of_two_scaled<Eigen::RowVector3d>(pc - pa, ev);
    if (u.cross(v).squaredNorm() <= 1e-18 * u.squaredNorm() * v.squaredNorm()) continue;
    used[a] = used[b] = used[c] = 1;
  }
  // Vertices only collapsed faces use (orphans): one at the position of a carrier vertex (a
  // seam's twin) joins it, since they move together and its faces stay collapsed.
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int i = F(f, k);
      if (i >= 0 && i < nv && used[i] == 0) used[i] = 2;
    }
  // One hash pass over the positions: the first vertex at each position counts, the others at
  // it are twins; a position with no carrier vertex (orphans alone) is left out.
  const std::vector<int> first = first_at_same_position(V, used);
  std::vector<std::uint8_t> carried(static_cast<std::size_t>(nv), 0);
  for (Eigen::Index i = 0; i < nv; ++i)
    if (used[i] == 1) carried[first[i]] = 1;
  for (Eigen::Index i = 0; i < nv; ++i)
    used[i] = first[i] < 0 || !carried[first[i]] ? 0 : first[i] == i ? kCounted : kTwin;
  return used;
}

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
    if (referenced[i] != kCounted) continue;
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
    if (referenced[i] != kCounted) continue;
    const double x = (h.rho(i) - h.rho_min) / h.step;
    const int b = std::min(static_cast<int>(std::floor(x)), h.bins - 1);
    h.bin[i] = b;
    h.t(i) = x - b;
  }
  return h;
}

Histogram histogram_at(const Histogram& h, const Eigen::MatrixX3d& P,
                       const std::vector<std::uint8_t>& mask) {
  if (mask.size() != static_cast<std::size_t>(P.rows()))
    throw InvalidArgumentError("the mask does not match the points");
  Histogram out = h;
  const Eigen::Index n = P.rows();
  out.rho = Eigen::VectorXd::Constant(n, std::numeric_limits<double>::quiet_NaN());
  out.t = Eigen::VectorXd::Zero(n);
  out.bin.assign(static_cast<std::size_t>(n), -1);
  out.argmin = out.argmax = -1;
  if (!h.valid()) return out;
  for (Eigen::Index i = 0; i < n; ++i) {
    if (!mask[i]) continue;
    const double r = (P.row(i).transpose() - h.center).norm();
    if (!(r >= h.rho_min && r <= h.rho_max)) continue;
    const double x = (r - h.rho_min) / h.step;
    const int b = std::min(static_cast<int>(std::floor(x)), h.bins - 1);
    out.rho(i) = r, out.bin[i] = b, out.t(i) = x - b;
  }
  return out;
}

void bin_means(const Histogram& h, std::vector<double>& means, std::vector<int>& counts,
               BinStatistic statistic) {
  const int nb = h.bins - 2;
  std::vector<double> sums(static_cast<std::size_t>(nb), 0.0);
  counts.assign(static_cast<std::size_t>(nb), 0);
  for (std::size_t i = 0; i < h.bin.size(); ++i) {
    const int j = h.bin[i] - 1;
    if (j < 0 || j >= nb) continue;
    sums[j] += bin_score_term(statistic, h.t(static_cast<Eigen::Index>(i)));
    counts[j] += 1;
  }
  means.resize(static_cast<std::size_t>(nb));
  for (int j = 0; j < nb; ++j)
    means[j] = counts[j] > 0 ? sums[j] / counts[j] : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace meshmark
