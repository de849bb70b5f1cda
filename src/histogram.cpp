#include "meshmark/histogram.h"

#include <Eigen/Geometry>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "meshmark/error.h"

namespace meshmark {

namespace {

Eigen::Vector3d discrete_center(const Eigen::MatrixX3d& V,
                                const std::vector<std::uint8_t>& referenced, double& count) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  count = 0;
  for (Eigen::Index i = 0; i < V.rows(); ++i)
    if (referenced[i]) {
      sum += V.row(i).transpose();
      count += 1;
    }
  return count > 0 ? Eigen::Vector3d(sum / count) : sum;
}

}  // namespace

Center center_of_mass(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                      const std::vector<std::uint8_t>& referenced, CenterKind kind) {
  Center c;
  double count = 0;
  const Eigen::Vector3d d = discrete_center(V, referenced, count);
  if (kind == CenterKind::Discrete) {
    c.point = d;
    c.quality = count;
    c.well_defined = count > 0;
    return c;
  }
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  double weight = 0, magnitude = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d p0 = V.row(F(f, 0)), p1 = V.row(F(f, 1)), p2 = V.row(F(f, 2));
    if (kind == CenterKind::Surface) {
      const double area = 0.5 * (p1 - p0).cross(p2 - p0).norm();
      sum += area * (p0 + p1 + p2) / 3.0;
      weight += area;
      magnitude += area;
    } else {
      const double w = (p0 - d).dot((p1 - d).cross(p2 - d)) / 6.0;
      sum += w * (d + p0 + p1 + p2) / 4.0;
      weight += w;
      magnitude += std::abs(w);
    }
  }
  if (kind == CenterKind::Surface) {
    c.quality = weight;
    c.well_defined = weight > 0;
  } else {
    c.quality = magnitude > 0 ? std::abs(weight) / magnitude : 0;
    c.well_defined = c.quality > 1e-3;
  }
  c.point = weight != 0 ? Eigen::Vector3d(sum / weight) : d;
  return c;
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

CenterKind center_from_letter(char letter) {
  switch (letter) {
    case 'D':
    case 'd':
      return CenterKind::Discrete;
    case 'S':
    case 's':
      return CenterKind::Surface;
    case 'V':
    case 'v':
      return CenterKind::Volume;
    default:
      break;
  }
  throw InvalidArgumentError(fmt::format("unknown center '{}' (expected D, S or V)", letter));
}

}  // namespace meshmark
