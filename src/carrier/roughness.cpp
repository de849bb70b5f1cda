#include "meshmark/carrier/roughness.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "carrier/curvature.h"
#include "core/parallel.h"
#include "meshmark/core/mesh.h"

namespace meshmark {

namespace {

Eigen::VectorXd vertex_areas(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F) {
  Eigen::VectorXd area = Eigen::VectorXd::Zero(V.rows());
  for (Eigen::Index t = 0; t < F.rows(); ++t) {
    const Eigen::RowVector3d e1 = V.row(F(t, 1)) - V.row(F(t, 0)),
                             e2 = V.row(F(t, 2)) - V.row(F(t, 0));
    const double a = 0.5 * e1.cross(e2).norm() / 3;
    for (int c = 0; c < 3; ++c) area(F(t, c)) += a;
  }
  return area;
}

// Gaussian-weighted, area-weighted average of `values` (#V x k) over the neighborhood members
// within 2 sigma (of positions P).
Eigen::MatrixXd gaussian_average(const Eigen::MatrixX3d& positions, const Neighborhoods& near,
                                 const Eigen::VectorXd& area, const Eigen::MatrixXd& values,
                                 double sigma) {
  const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> P =
      positions;  // one cache line per point
  Eigen::MatrixXd out = values;
  const double inv = 1.0 / (2 * sigma * sigma), r2 = 4 * sigma * sigma;
  detail::parallel_chunks(P.rows(), [&](int, std::int64_t begin, std::int64_t end) {
    Eigen::RowVectorXd sum(values.cols());
    for (Eigen::Index i = begin; i < end; ++i) {
      if (near.offsets[i] == near.offsets[i + 1]) continue;
      sum.setZero();
      double weight = 0;
      for (auto k = near.offsets[i]; k < near.offsets[i + 1]; ++k) {
        const int v = near.indices[k];
        const double d2 = (P.row(v) - P.row(i)).squaredNorm();
        if (d2 > r2) continue;
        const double w = area(v) * std::exp(-d2 * inv);
        sum += w * values.row(v);
        weight += w;
      }
      if (weight > 0) out.row(i) = sum / weight;
    }
  });
  return out;
}

}  // namespace

RoughnessField roughness_field(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                               const RoughnessOptions& o) {
  const auto used = referenced_vertices(F, V.rows());
  const double D = bounding_box_diagonal(V, used);
  // One set of neighborhoods, at the largest Gaussian reach, serves every average; the
  // curvature walks its own balls over the same adjacency.
  const Adjacency adj = vertex_adjacency(F, V.rows());
  const Neighborhoods near =
      ball_neighborhoods(V, adj, D * std::max(2 * o.smoothing_sigma, 2 * o.window_sigma));
  const Eigen::VectorXd area = vertex_areas(V, F);
  const Eigen::VectorXd c = normal_cycle_curvature(V, F, adj, o.curvature_radius * D).magnitude();
  const Eigen::MatrixX3d smoothed = gaussian_average(V, near, area, V, o.smoothing_sigma * D);
  const Eigen::VectorXd cs =
      normal_cycle_curvature(smoothed, F, adj, o.curvature_radius * D).magnitude();
  RoughnessField field;
  field.roughness =
      D * gaussian_average(V, near, area, (c - cs).cwiseAbs(), o.window_sigma * D).col(0);
  std::vector<double> sorted;
  for (Eigen::Index i = 0; i < V.rows(); ++i)
    if (used[i]) sorted.push_back(field.roughness(i));
  field.smoothness = Eigen::VectorXd::Ones(V.rows());
  if (sorted.empty()) return field;
  std::sort(sorted.begin(), sorted.end());
  auto quantile = [&](double q) {
    return sorted[static_cast<std::size_t>(q * static_cast<double>(sorted.size() - 1))];
  };
  const double cap = quantile(o.outlier_quantile);
  if (cap > 0)
    for (Eigen::Index i = 0; i < V.rows(); ++i)
      if (used[i]) field.smoothness(i) = 1 - std::min(field.roughness(i), cap) / cap;
  std::vector<double> smooth;
  for (Eigen::Index i = 0; i < V.rows(); ++i)
    if (used[i]) smooth.push_back(field.smoothness(i));
  std::nth_element(
      smooth.begin(),
      smooth.begin() + static_cast<std::ptrdiff_t>(0.8 * static_cast<double>(smooth.size() - 1)),
      smooth.end());
  field.smooth_threshold =
      std::min(0.8, smooth[static_cast<std::size_t>(0.8 * static_cast<double>(smooth.size() - 1))]);
  return field;
}

}  // namespace meshmark
