#include "meshmark/metrics/metrics.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "core/progress_counter.h"
#include "meshmark/core/error.h"
#include "meshmark/core/mesh.h"
#include "meshmark/core/random.h"
#include "metrics/closest_point.h"

namespace meshmark {

double vertex_rms_percent(const Eigen::MatrixX3d& A, const Eigen::MatrixX3d& B,
                          const Eigen::MatrixX3i& F) {
  if (A.rows() != B.rows())
    throw InvalidArgumentError(
        fmt::format("vertex RMS needs the same vertices ({} and {})", A.rows(), B.rows()));
  validate_mesh(A, F, "the first mesh");
  validate_mesh(B, F, "the second mesh");
  const auto used = referenced_vertices(F, A.rows());
  double sum = 0, n = 0;
  for (Eigen::Index i = 0; i < A.rows(); ++i)
    if (used[i]) sum += (B.row(i) - A.row(i)).squaredNorm(), n += 1;
  const double diag = bounding_box_diagonal(A, used);
  return n > 0 && diag > 0 ? 100 * std::sqrt(sum / n) / diag : 0;
}

Eigen::MatrixX3d sample_surface(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, int count,
                                std::uint64_t seed) {
  validate_mesh(V, F);
  const auto used = referenced_vertices(F, V.rows());
  std::vector<double> cumulative;
  cumulative.reserve(static_cast<std::size_t>(F.rows()));
  double total = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    total += 0.5 * (V.row(F(f, 1)) - V.row(F(f, 0))).cross(V.row(F(f, 2)) - V.row(F(f, 0))).norm();
    cumulative.push_back(total);
  }
  const Eigen::Index nref = std::count(used.begin(), used.end(), 1);
  const int extra = total > 0 ? std::max(count, 0) : 0;
  Eigen::MatrixX3d S(nref + extra, 3);
  Eigen::Index row = 0;
  for (Eigen::Index i = 0; i < V.rows(); ++i)
    if (used[i]) S.row(row++) = V.row(i);
  Random rng(seed);
  struct Draw {
    Eigen::Index t;
    double r1, r2;
  };
  std::vector<Draw> draws(static_cast<std::size_t>(extra));
  for (Draw& d : draws) {
    const double pick = rng.uniform() * total;
    const auto f = static_cast<Eigen::Index>(
        std::upper_bound(cumulative.begin(), cumulative.end(), pick) - cumulative.begin());
    d.t = std::min(f, F.rows() - 1);
    d.r1 = std::sqrt(rng.uniform()), d.r2 = rng.uniform();  // uniform in the triangle
  }
  // In face order, so that consecutive samples lie close together (closest-point queries start
  // from the previous answer); the set of samples is the same.
  std::stable_sort(draws.begin(), draws.end(),
                   [](const Draw& a, const Draw& b) { return a.t < b.t; });
  for (const Draw& d : draws)
    S.row(row++) = (1 - d.r1) * V.row(F(d.t, 0)) + d.r1 * (1 - d.r2) * V.row(F(d.t, 1)) +
                   d.r1 * d.r2 * V.row(F(d.t, 2));
  return S;
}

SurfaceDistance surface_distance(const Eigen::MatrixX3d& VA, const Eigen::MatrixX3i& FA,
                                 const Eigen::MatrixX3d& VB, const Eigen::MatrixX3i& FB,
                                 const SurfaceDistanceOptions& o) {
  validate_mesh(VA, FA, "the first mesh");
  validate_mesh(VB, FB, "the second mesh");
  if (FA.rows() == 0 || FB.rows() == 0)
    throw InvalidArgumentError(
        fmt::format("surface distance between meshes of {} and {} faces: both need triangles",
                    FA.rows(), FB.rows()));
  SurfaceDistance d;
  d.diagonal = bounding_box_diagonal(VA, referenced_vertices(FA, VA.rows()));
  detail::ProgressCounter counter(o.progress, "measuring surface distances", 2);
  auto one_side = [&](const Eigen::MatrixX3d& V1, const Eigen::MatrixX3i& F1,
                      const Eigen::MatrixX3d& V2, const Eigen::MatrixX3i& F2, std::uint64_t seed,
                      double& rms, double& max) {
    const int n = o.samples > 0 ? o.samples : std::max<int>(50000, 2 * static_cast<int>(V1.rows()));
    const Eigen::VectorXd dist = closest_points(V2, F2, sample_surface(V1, F1, n, seed)).distance;
    rms = std::sqrt(dist.squaredNorm() / static_cast<double>(dist.size()));
    max = dist.maxCoeff();
    counter.step(1, "");
  };
  one_side(VA, FA, VB, FB, o.seed, d.rms_ab, d.max_ab);
  one_side(VB, FB, VA, FA, o.seed + 1, d.rms_ba, d.max_ba);
  d.mrms = std::max(d.rms_ab, d.rms_ba);
  d.hausdorff = std::max(d.max_ab, d.max_ba);
  return d;
}

namespace {

// Refuses a mesh whose surface cannot be measured, naming its file: no triangle of finite,
// non-zero area (all collinear or repeated points, or coordinates whose squares overflow).
void check_measurable(const Mesh& m, const char* which) {
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    const Eigen::Vector3d a = m.V.row(m.F(f, 0)), b = m.V.row(m.F(f, 1)), c = m.V.row(m.F(f, 2));
    const double area2 = (b - a).cross(c - a).squaredNorm();
    if (area2 > 0 && std::isfinite(area2) && std::isfinite((b - a).squaredNorm()) &&
        std::isfinite((c - a).squaredNorm()))
      return;
  }
  throw InvalidInputError(m.source_path.empty() ? which : m.source_path, 0,
                          "no triangle has a finite, non-zero area (collinear or repeated "
                          "points, or coordinates too large to square): its surface cannot be "
                          "measured");
}

}  // namespace

MeshComparison compare_meshes(const Mesh& A, const Mesh& B, const CompareOptions& options) {
  check_measurable(A, "the reference mesh");
  check_measurable(B, "the distorted mesh");
  MeshComparison out;
  // Eigen compares matrices of equal sizes only.
  out.same_connectivity = A.V.rows() == B.V.rows() && A.F.rows() == B.F.rows() && A.F == B.F;
  if (out.same_connectivity) {
    out.rms_percent = vertex_rms_percent(A.V, B.V, A.F);
    out.msdm = msdm(A.V, B.V, A.F, MsdmOptions{}, options.progress).global;
  }
  SurfaceDistanceOptions sampling = options.sampling;
  sampling.progress = options.progress;
  out.surface = surface_distance(A.V, A.F, B.V, B.F, sampling);
  Msdm2Options o2;
  o2.progress = options.progress;
  out.msdm2 = msdm2(A.V, A.F, B.V, B.F, o2);
  return out;
}

}  // namespace meshmark
