#include "meshmark/attack.h"

#include <Eigen/Geometry>
#include <cmath>
#include <numeric>

#include "meshmark/error.h"
#include "meshmark/random.h"

namespace meshmark {

double Random::normal() {
  const double u1 = 1.0 - uniform(), u2 = uniform();
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}

Eigen::Matrix3d random_rotation(std::uint64_t seed) {
  Random rng(seed);
  const double u1 = rng.uniform(), u2 = rng.uniform(), u3 = rng.uniform();
  const double a = std::sqrt(1 - u1), b = std::sqrt(u1);
  const Eigen::Quaterniond q(a * std::sin(2 * M_PI * u2), a * std::cos(2 * M_PI * u2),
                             b * std::sin(2 * M_PI * u3), b * std::cos(2 * M_PI * u3));
  return q.normalized().toRotationMatrix();
}

Mesh attack_similarity(const Mesh& mesh, std::uint64_t seed, const SimilarityOptions& options) {
  if (!(options.max_scale >= 1)) throw InvalidArgumentError("max_scale must be at least 1");
  Random rng(seed);
  const Eigen::Matrix3d R = random_rotation(rng.next());
  const double diag = bounding_box_diagonal(mesh.V);
  Eigen::RowVector3d t;
  for (int a = 0; a < 3; ++a) t(a) = rng.uniform(-1, 1) * options.translation * diag;
  const double scale = std::exp(rng.uniform(-1, 1) * std::log(options.max_scale));
  Mesh out = mesh;
  out.V = (scale * (mesh.V * R.transpose())).rowwise() + t;
  return out;
}

namespace {
std::vector<int> random_permutation(std::size_t n, Random& rng) {
  std::vector<int> p(n);
  std::iota(p.begin(), p.end(), 0);
  for (std::size_t i = n; i > 1; --i) std::swap(p[i - 1], p[rng.index(i)]);
  return p;
}
}  // namespace

Mesh attack_reorder(const Mesh& mesh, std::uint64_t seed) {
  Random rng(seed);
  const std::vector<int> new_of_old =
      random_permutation(static_cast<std::size_t>(mesh.V.rows()), rng);
  const std::vector<int> face_order = random_permutation(mesh.faces.size(), rng);
  Mesh out;
  out.format = mesh.format;
  out.encoding = mesh.encoding;
  out.V.resize(mesh.V.rows(), 3);
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i) out.V.row(new_of_old[i]) = mesh.V.row(i);
  std::vector<int> face;
  for (int k : face_order) {
    const auto b = mesh.faces.offsets[k], e = mesh.faces.offsets[k + 1];
    const auto n = static_cast<std::size_t>(e - b);
    face.resize(n);
    const std::size_t shift = n > 0 ? rng.index(n) : 0;
    for (std::size_t c = 0; c < n; ++c)
      face[c] = new_of_old[mesh.faces.indices[b + (c + shift) % n]];
    out.faces.push_back(face.data(), n);
  }
  out.F = triangulate(out.faces);
  return out;
}

}  // namespace meshmark
