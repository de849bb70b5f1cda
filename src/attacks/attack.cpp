// Attacks that need no CGAL: similarity, reordering, noise, quantization, triangle soup,
// cropping and format conversion. The kinds' table, the chain parser and apply_attack are in
// attack_registry.cpp, smoothing in attack_smooth.cpp, the parameters' names in
// attack_params.cpp; simplification and subdivision in cgal_simplify.cpp, cgal_remesh.cpp and
// cgal_subdivide.cpp.

#include "meshmark/attacks/attack.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numeric>

#include <fmt/format.h>

#include "meshmark/core/error.h"
#include "meshmark/core/random.h"
#include "meshmark/io/io.h"

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

// A mesh made of new positions and polygons, with the source's format but no file image.
Mesh rebuilt(const Mesh& like, Eigen::MatrixX3d V, Polygons faces) {
  Mesh out;
  out.format = like.format;
  out.encoding = like.encoding;
  out.V = std::move(V);
  set_faces(out, std::move(faces));
  return out;
}

}  // namespace

Mesh attack_reorder(const Mesh& mesh, std::uint64_t seed) {
  Random rng(seed);
  const std::vector<int> new_of_old =
      random_permutation(static_cast<std::size_t>(mesh.V.rows()), rng);
  const FaceView from(mesh);
  const std::vector<int> face_order = random_permutation(from.size(), rng);
  Eigen::MatrixX3d V(mesh.V.rows(), 3);
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i) V.row(new_of_old[i]) = mesh.V.row(i);
  Polygons faces;
  std::vector<int> face;
  for (int k : face_order) {
    const auto f = static_cast<std::size_t>(k);
    const std::size_t n = from.size_of(f);
    face.resize(n);
    const std::size_t shift = n > 0 ? rng.index(n) : 0;
    for (std::size_t c = 0; c < n; ++c) face[c] = new_of_old[from.corner(f, (c + shift) % n)];
    faces.push_back(face.data(), n);
  }
  return rebuilt(mesh, std::move(V), std::move(faces));
}

Mesh attack_noise(const Mesh& mesh, double amplitude, NoiseReference reference,
                  std::uint64_t seed) {
  if (!(amplitude >= 0))
    throw InvalidArgumentError(fmt::format("noise amplitude {} is negative", amplitude));
  const auto used = referenced_vertices(mesh.F, mesh.V.rows());
  double length = bounding_box_diagonal(mesh.V, used);
  if (reference == NoiseReference::MeanRadius) {
    Eigen::RowVector3d c = Eigen::RowVector3d::Zero();
    double n = 0;
    for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
      if (used[i]) c += mesh.V.row(i), n += 1;
    c /= std::max(n, 1.0);
    length = 0;
    for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
      if (used[i]) length += (mesh.V.row(i) - c).norm();
    length /= std::max(n, 1.0);
  }
  const double A = amplitude * length;
  Random rng(seed);
  Mesh out = mesh;
  for (Eigen::Index i = 0; i < out.V.rows(); ++i)
    for (int a = 0; a < 3; ++a) out.V(i, a) += rng.uniform(-A, A);
  return out;
}

Mesh attack_quantize(const Mesh& mesh, int bits, QuantizeConvention convention) {
  if (bits < 1 || bits > 52)
    throw InvalidArgumentError(fmt::format("quantization to {} bits (expected 1 to 52)", bits));
  Mesh out = mesh;
  if (mesh.V.rows() == 0) return out;
  const bool benchmark = convention == QuantizeConvention::Benchmark;
  const double intervals = benchmark ? std::ldexp(1.0, bits) : std::ldexp(1.0, bits) - 1;
  for (int a = 0; a < 3; ++a) {
    const double lo = mesh.V.col(a).minCoeff(), hi = mesh.V.col(a).maxCoeff();
    const double step = (hi - lo) / intervals;
    if (step <= 0) continue;
    for (Eigen::Index i = 0; i < out.V.rows(); ++i) {
      const double t = (mesh.V(i, a) - lo) / step;
      if (!benchmark) {
        out.V(i, a) = lo + std::round(t) * step;
        continue;
      }
      // MEPP's rule: the grid point below, or the next one when more than half a step above.
      const double below = lo + std::floor(t) * step;
      out.V(i, a) = mesh.V(i, a) - below <= 0.5 * step ? below : below + step;
    }
  }
  return out;
}

Mesh attack_triangle_soup(const Mesh& mesh, double ratio, std::uint64_t seed,
                          double noise_amplitude) {
  if (!(ratio > 0))
    throw InvalidArgumentError(fmt::format("soup edge ratio {} must be positive", ratio));
  const Eigen::Index nt = mesh.F.rows();
  Eigen::MatrixX3d V(3 * nt, 3);
  Polygons faces;
  for (Eigen::Index t = 0; t < nt; ++t) {
    const Eigen::RowVector3d c =
        (mesh.V.row(mesh.F(t, 0)) + mesh.V.row(mesh.F(t, 1)) + mesh.V.row(mesh.F(t, 2))) / 3;
    int tri[3];
    for (int k = 0; k < 3; ++k) {
      V.row(3 * t + k) = c + ratio * (mesh.V.row(mesh.F(t, k)) - c);
      tri[k] = static_cast<int>(3 * t + k);
    }
    faces.push_back(tri, 3);
  }
  return attack_noise(rebuilt(mesh, std::move(V), std::move(faces)), noise_amplitude,
                      NoiseReference::Diagonal, seed);
}

Mesh attack_crop(const Mesh& mesh, double fraction, std::uint64_t seed) {
  if (!(fraction >= 0 && fraction < 1))
    throw InvalidArgumentError(fmt::format("crop fraction {} is outside [0, 1)", fraction));
  Random rng(seed);
  const Eigen::Vector3d dir =
      Eigen::Vector3d(rng.normal(), rng.normal(), rng.normal()).normalized();
  const auto used = referenced_vertices(mesh.F, mesh.V.rows());
  std::vector<int> order;
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    if (used[i]) order.push_back(static_cast<int>(i));
  const auto n_remove =
      static_cast<std::size_t>(std::llround(fraction * static_cast<double>(order.size())));
  // The n_remove vertices farthest along dir lie beyond a plane orthogonal to it.
  std::nth_element(
      order.begin(), order.begin() + static_cast<std::ptrdiff_t>(order.size() - n_remove),
      order.end(), [&](int a, int b) { return mesh.V.row(a).dot(dir) < mesh.V.row(b).dot(dir); });
  std::vector<char> removed(static_cast<std::size_t>(mesh.V.rows()), 0);
  for (std::size_t k = order.size() - n_remove; k < order.size(); ++k) removed[order[k]] = 1;
  std::vector<int> new_index(static_cast<std::size_t>(mesh.V.rows()), -1);
  int kept = 0;
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    if (!removed[i]) new_index[i] = kept++;
  Eigen::MatrixX3d V(kept, 3);
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    if (new_index[i] >= 0) V.row(new_index[i]) = mesh.V.row(i);
  Polygons faces;
  std::vector<int> face;
  const FaceView from(mesh);
  for (std::size_t k = 0; k < from.size(); ++k) {
    face.clear();
    bool keep = true;
    for (std::size_t c = 0; c < from.size_of(k) && keep; ++c) {
      keep = new_index[from.corner(k, c)] >= 0;
      face.push_back(new_index[from.corner(k, c)]);
    }
    if (keep) faces.push_back(face.data(), face.size());
  }
  return rebuilt(mesh, std::move(V), std::move(faces));
}

Mesh attack_format(const Mesh& mesh, const std::string& format, bool single_precision) {
  const FileFormat f = parse_enum<FileFormat>(format);
  WriteOptions wo;
  wo.single_precision = single_precision;
  wo.keep_source = false;
  if (f == FileFormat::Ply || f == FileFormat::Stl) wo.encoding = Encoding::BinaryLittleEndian;
  ReadOptions ro;
  ro.keep_image = false;
  Mesh out = read_mesh_from_bytes(write_mesh_to_bytes(mesh, f, wo), f, "converted." + format, ro);
  out.format = mesh.format;
  out.encoding = mesh.encoding;
  return out;
}

}  // namespace meshmark
