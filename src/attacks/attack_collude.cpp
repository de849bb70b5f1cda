// Collusion: copies of one original bought by several buyers, merged vertex by vertex (an
// average, equal or weighted) or cut into regions pasted from different copies.

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "meshmark/attacks/attack.h"
#include "meshmark/core/error.h"
#include "meshmark/core/mesh.h"
#include "meshmark/core/random.h"

namespace meshmark {

namespace {

// A copy that does not match the first: an InvalidInputError naming its file when it was read
// from one, else an InvalidArgumentError.
[[noreturn]] void mismatch(const Mesh& copy, const std::string& what) {
  const std::string detail = what + ": colluders merge copies of one original, vertex by vertex";
  if (!copy.source_path.empty()) throw InvalidInputError(copy.source_path, 0, detail);
  throw InvalidArgumentError(detail);
}

// Throws unless every copy has the first one's vertex count and faces.
void check_copies(const std::vector<Mesh>& copies) {
  if (copies.size() < 2)
    throw InvalidArgumentError(
        fmt::format("a collusion needs at least 2 copies, got {}", copies.size()));
  const Mesh& first = copies.front();
  const std::string one =
      first.source_path.empty() ? "copy 1" : fmt::format("copy 1 ({})", first.source_path);
  for (std::size_t j = 1; j < copies.size(); ++j) {
    const Mesh& c = copies[j];
    if (c.V.rows() != first.V.rows())
      mismatch(c, fmt::format("copy {} has {} vertices, {} has {}", j + 1, c.V.rows(), one,
                              first.V.rows()));
    if (c.F.rows() != first.F.rows() || c.F != first.F)
      mismatch(c, fmt::format("copy {} has other faces than {} ({} and {} faces)", j + 1, one,
                              c.F.rows(), first.F.rows()));
  }
  for (std::size_t j = 0; j < copies.size(); ++j)  // finite positions, faces in range
    validate_mesh(copies[j], fmt::format("copy {}", j + 1));
}

// The weights normalized to sum 1 (equal when none are given).
std::vector<double> normalized_weights(const std::vector<double>& weights, std::size_t n) {
  if (weights.empty()) return std::vector<double>(n, 1.0 / static_cast<double>(n));
  if (weights.size() != n)
    throw InvalidArgumentError(
        fmt::format("{} collusion weights for {} copies: give one per copy", weights.size(), n));
  double largest = 0;
  for (std::size_t j = 0; j < n; ++j) {
    if (!(weights[j] >= 0) || !std::isfinite(weights[j]))
      throw InvalidArgumentError(fmt::format(
          "collusion weight {} of copy {} is not a finite number >= 0", weights[j], j + 1));
    largest = std::max(largest, weights[j]);
  }
  if (!(largest > 0)) throw InvalidArgumentError("the collusion weights sum to 0");
  // Scaled by the largest first: weights near the largest double must not sum to infinity.
  std::vector<double> w(weights);
  double sum = 0;
  for (double& x : w) sum += x /= largest;
  for (double& x : w) x /= sum;
  return w;
}

// Region of every vertex: the index of the nearest of `count` centers picked by farthest-point
// sampling (Euclidean) from a random first vertex.
std::vector<int> splice_regions(const Eigen::MatrixX3d& V, int count, std::uint64_t seed) {
  const Eigen::Index n = V.rows();
  std::vector<int> region(static_cast<std::size_t>(n), 0);
  if (n == 0) return region;
  std::vector<double> nearest(static_cast<std::size_t>(n), std::numeric_limits<double>::infinity());
  Random rng(seed);
  auto center = static_cast<Eigen::Index>(rng.index(static_cast<std::uint64_t>(n)));
  for (int r = 0; r < count; ++r) {
    const Eigen::RowVector3d c = V.row(center);
    Eigen::Index farthest = 0;
    for (Eigen::Index i = 0; i < n; ++i) {
      const double d = (V.row(i) - c).squaredNorm();
      if (d < nearest[i]) nearest[i] = d, region[i] = r;
      if (nearest[i] > nearest[farthest]) farthest = i;
    }
    center = farthest;
  }
  return region;
}

}  // namespace

std::vector<double> random_collusion_weights(int count, std::uint64_t seed) {
  if (count < 1)
    throw InvalidArgumentError(fmt::format("{} colluders: at least 1 is needed", count));
  Random rng(seed);
  std::vector<double> w(static_cast<std::size_t>(count));
  double sum = 0;
  for (double& x : w) sum += x = -std::log1p(-rng.uniform());         // uniform() < 1: finite
  if (!(sum > 0)) return std::vector<double>(w.size(), 1.0 / count);  // all draws exactly 0
  for (double& x : w) x /= sum;
  return w;
}

Mesh attack_collude(const std::vector<Mesh>& copies, const CollusionOptions& options,
                    std::uint64_t seed) {
  check_copies(copies);
  Mesh out = copies.front();
  if (options.kind == CollusionKind::Average) {
    const std::vector<double> w = normalized_weights(options.weights, copies.size());
    out.V = w[0] * copies[0].V;
    for (std::size_t j = 1; j < copies.size(); ++j) out.V += w[j] * copies[j].V;
    return out;
  }
  if (!options.weights.empty())
    throw InvalidArgumentError("weights apply to an average, not to a splice");
  const std::vector<int> region =
      splice_regions(copies.front().V, static_cast<int>(copies.size()), seed);
  for (Eigen::Index i = 0; i < out.V.rows(); ++i) out.V.row(i) = copies[region[i]].V.row(i);
  return out;
}

}  // namespace meshmark
