// Laplacian and Taubin smoothing: umbrella steps with uniform (1 / degree) or inverse-distance
// (Open3D's) neighbour weights, boundary vertices moving or fixed (the LIRIS benchmark's).

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <utility>

#include "meshmark/attacks/attack.h"
#include "meshmark/core/error.h"

namespace meshmark {

std::vector<std::uint8_t> boundary_vertices(const Eigen::MatrixX3i& F, Eigen::Index nv) {
  std::vector<std::pair<int, int>> edges;
  edges.reserve(static_cast<std::size_t>(3 * F.rows()));
  for (Eigen::Index t = 0; t < F.rows(); ++t)
    for (int k = 0; k < 3; ++k) {
      const int a = F(t, k), b = F(t, (k + 1) % 3);
      if (a != b) edges.emplace_back(std::min(a, b), std::max(a, b));
    }
  std::sort(edges.begin(), edges.end());
  std::vector<std::uint8_t> boundary(static_cast<std::size_t>(nv), 0);
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    if (j - i == 1) boundary[edges[i].first] = boundary[edges[i].second] = 1;
    i = j;
  }
  return boundary;
}

namespace {

// One umbrella step from the previous positions: p_i += factor (weighted mean of the
// neighbours - p_i), for every vertex with neighbours that is not fixed.
void umbrella_step(const Adjacency& adj, const std::vector<std::uint8_t>& fixed, double factor,
                   SmoothWeighting weighting, Eigen::MatrixX3d& V) {
  const Eigen::MatrixX3d P = V;
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    if (adj.degree(static_cast<int>(i)) == 0 || (!fixed.empty() && fixed[i])) continue;
    Eigen::RowVector3d sum = Eigen::RowVector3d::Zero();
    double total = 0;
    for (int k = adj.offsets[i]; k < adj.offsets[i + 1]; ++k) {
      const auto j = adj.indices[k];
      const double w = weighting == SmoothWeighting::Uniform
                           ? 1.0
                           : 1.0 / ((P.row(j) - P.row(i)).norm() + 1e-12);
      sum += w * P.row(j);
      total += w;
    }
    V.row(i) += factor * (sum / total - P.row(i));
  }
}

void check_iterations(int iterations) {
  if (iterations < 0)
    throw InvalidArgumentError(fmt::format("smoothing iterations {} must be >= 0", iterations));
}

}  // namespace

Smoother::Smoother(const Eigen::MatrixX3i& F, Eigen::Index nv)
    : adjacency_(vertex_adjacency(F, nv)), boundary_(boundary_vertices(F, nv)) {}

void Smoother::check_size(const Eigen::MatrixX3d& V) const {
  if (V.rows() != static_cast<Eigen::Index>(boundary_.size()))
    throw InvalidArgumentError(
        fmt::format("smoothing {} positions of a mesh of {} vertices", V.rows(), boundary_.size()));
}

void Smoother::laplacian(Eigen::MatrixX3d& V, int iterations, const LaplacianOptions& o) const {
  check_iterations(iterations);
  if (!std::isfinite(o.lambda))
    throw InvalidArgumentError(fmt::format("smoothing lambda {} is not finite", o.lambda));
  check_size(V);
  const std::vector<std::uint8_t> none;
  for (int k = 0; k < iterations; ++k)
    umbrella_step(adjacency_, o.fixed_boundary ? boundary_ : none, o.lambda, o.weighting, V);
}

void Smoother::taubin(Eigen::MatrixX3d& V, int iterations, const TaubinOptions& o) const {
  check_iterations(iterations);
  if (!(o.lambda > 0 && std::isfinite(o.lambda)))
    throw InvalidArgumentError(fmt::format("Taubin lambda {} must be positive", o.lambda));
  const double mu = o.mu != 0 ? o.mu : 1.0 / (o.k_pb - 1.0 / o.lambda);
  if (!(mu < 0 && std::isfinite(mu)))
    throw InvalidArgumentError(fmt::format("Taubin mu {} must be negative", mu));
  check_size(V);
  const std::vector<std::uint8_t> none;
  const std::vector<std::uint8_t>& fixed = o.fixed_boundary ? boundary_ : none;
  for (int k = 0; k < iterations; ++k) {
    umbrella_step(adjacency_, fixed, o.lambda, o.weighting, V);
    umbrella_step(adjacency_, fixed, mu, o.weighting, V);
  }
}

Mesh attack_smooth_laplacian(const Mesh& mesh, int iterations, const LaplacianOptions& o) {
  Mesh out = mesh;
  Smoother(mesh.F, mesh.V.rows()).laplacian(out.V, iterations, o);
  return out;
}

Mesh attack_smooth_laplacian(const Mesh& mesh, int iterations, double lambda) {
  LaplacianOptions o;
  o.lambda = lambda;
  return attack_smooth_laplacian(mesh, iterations, o);
}

Mesh attack_smooth_taubin(const Mesh& mesh, int iterations, const TaubinOptions& o) {
  Mesh out = mesh;
  Smoother(mesh.F, mesh.V.rows()).taubin(out.V, iterations, o);
  return out;
}

Mesh attack_smooth_taubin(const Mesh& mesh, int iterations, double lambda, double k_pb) {
  TaubinOptions o;
  o.lambda = lambda;
  o.k_pb = k_pb;
  return attack_smooth_taubin(mesh, iterations, o);
}

}  // namespace meshmark
