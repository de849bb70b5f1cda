#include "meshmark/metrics.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "meshmark/closest_point.h"
#include "meshmark/curvature.h"
#include "meshmark/error.h"
#include "meshmark/mesh.h"
#include "meshmark/random.h"
#include "parallel.h"

namespace meshmark {

double vertex_rms_percent(const Eigen::MatrixX3d& A, const Eigen::MatrixX3d& B,
                          const Eigen::MatrixX3i& F) {
  if (A.rows() != B.rows())
    throw InvalidArgumentError(
        fmt::format("vertex RMS needs the same vertices ({} and {})", A.rows(), B.rows()));
  const auto used = referenced_vertices(F, A.rows());
  double sum = 0, n = 0;
  for (Eigen::Index i = 0; i < A.rows(); ++i)
    if (used[i]) sum += (B.row(i) - A.row(i)).squaredNorm(), n += 1;
  const double diag = bounding_box_diagonal(A, used);
  return n > 0 && diag > 0 ? 100 * std::sqrt(sum / n) / diag : 0;
}

Eigen::MatrixX3d sample_surface(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, int count,
                                std::uint64_t seed) {
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
  SurfaceDistance d;
  d.diagonal = bounding_box_diagonal(VA, referenced_vertices(FA, VA.rows()));
  auto one_side = [&](const Eigen::MatrixX3d& V1, const Eigen::MatrixX3i& F1,
                      const Eigen::MatrixX3d& V2, const Eigen::MatrixX3i& F2, std::uint64_t seed,
                      double& rms, double& max) {
    const int n = o.samples > 0 ? o.samples : std::max<int>(50000, 2 * static_cast<int>(V1.rows()));
    const Eigen::VectorXd dist = closest_points(V2, F2, sample_surface(V1, F1, n, seed)).distance;
    rms = std::sqrt(dist.squaredNorm() / static_cast<double>(dist.size()));
    max = dist.maxCoeff();
  };
  one_side(VA, FA, VB, FB, o.seed, d.rms_ab, d.max_ab);
  one_side(VB, FB, VA, FA, o.seed + 1, d.rms_ba, d.max_ba);
  d.mrms = std::max(d.rms_ab, d.rms_ba);
  d.hausdorff = std::max(d.max_ab, d.max_ba);
  return d;
}

namespace {

double longest_side(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F) {
  const auto used = referenced_vertices(F, V.rows());
  Eigen::RowVector3d lo = Eigen::RowVector3d::Constant(1e300), hi = -lo;
  for (Eigen::Index i = 0; i < V.rows(); ++i)
    if (used[i]) lo = lo.cwiseMin(V.row(i)), hi = hi.cwiseMax(V.row(i));
  return (hi - lo).maxCoeff();
}

// Gaussian-weighted statistics of x and y over each vertex's window, combined into a local
// score by `combine(L, C, S)` (MSDM's comparison functions, with the +1 of curvatures scaled
// by D / 2).
template <class Combine>
Eigen::VectorXd window_scores(const Eigen::MatrixX3d& P, const Neighborhoods& near, double radius,
                              double sigma, const Eigen::VectorXd& x, const Eigen::VectorXd& y,
                              Combine&& combine) {
  Eigen::VectorXd local = Eigen::VectorXd::Zero(P.rows());
  const double r2 = radius * radius, inv = 1.0 / (2 * sigma * sigma);
  detail::parallel_chunks(P.rows(), [&](int, std::int64_t begin, std::int64_t end) {
    for (Eigen::Index i = begin; i < end; ++i) {
      double w = 0, mx = 0, my = 0;
      for (auto k = near.offsets[i]; k < near.offsets[i + 1]; ++k) {
        const int v = near.indices[k];
        const double d2 = (P.row(v) - P.row(i)).squaredNorm();
        if (d2 > r2) continue;
        const double g = std::exp(-d2 * inv);
        w += g, mx += g * x(v), my += g * y(v);
      }
      if (w <= 0) continue;
      mx /= w, my /= w;
      double vx = 0, vy = 0, cxy = 0;
      for (auto k = near.offsets[i]; k < near.offsets[i + 1]; ++k) {
        const int v = near.indices[k];
        const double d2 = (P.row(v) - P.row(i)).squaredNorm();
        if (d2 > r2) continue;
        const double g = std::exp(-d2 * inv);
        vx += g * (x(v) - mx) * (x(v) - mx), vy += g * (y(v) - my) * (y(v) - my),
            cxy += g * (x(v) - mx) * (y(v) - my);
      }
      const double sx = std::sqrt(vx / w), sy = std::sqrt(vy / w), sxy = cxy / w;
      const double L = std::abs(mx - my) / (std::max(mx, my) + 1);
      const double C = std::abs(sx - sy) / (std::max(sx, sy) + 1);
      const double S = std::abs(sx * sy - sxy) / (sx * sy + 1);
      local(i) = combine(L, C, S);
    }
  });
  return local;
}

// (mean of local^3)^(1/3) over the referenced vertices.
double pool3(const Eigen::VectorXd& local, const Eigen::MatrixX3i& F) {
  const auto used = referenced_vertices(F, local.size());
  double sum = 0, n = 0;
  for (Eigen::Index i = 0; i < local.size(); ++i)
    if (used[i]) sum += local(i) * local(i) * local(i), n += 1;
  return n > 0 ? std::cbrt(sum / n) : 0.0;
}

// MSDM2 in one direction: local scores of X's vertices against Y.
Eigen::VectorXd msdm2_local(const Eigen::MatrixX3d& VX, const Eigen::MatrixX3i& FX,
                            const Eigen::MatrixX3d& VY, const Eigen::MatrixX3i& FY, double D,
                            const Msdm2Options& o) {
  const ClosestPoints match = closest_points(VY, FY, VX);
  const double largest = *std::max_element(std::begin(o.scales), std::end(o.scales));
  const Neighborhoods nx =
      ball_neighborhoods(VX, vertex_adjacency(FX, VX.rows()), o.window_factor * largest * D);
  const Neighborhoods ny = ball_neighborhoods(VY, vertex_adjacency(FY, VY.rows()), largest * D);
  const Neighborhoods nxc = ball_neighborhoods(VX, vertex_adjacency(FX, VX.rows()), largest * D);
  Eigen::VectorXd local = Eigen::VectorXd::Zero(VX.rows());
  for (double h : o.scales) {
    const Eigen::VectorXd cx = normal_cycle_curvature(VX, FX, h * D, nxc).magnitude() * (D / 2);
    const Eigen::VectorXd cy_vertices =
        normal_cycle_curvature(VY, FY, h * D, ny).magnitude() * (D / 2);
    Eigen::VectorXd cy(VX.rows());
    for (Eigen::Index i = 0; i < VX.rows(); ++i) {
      const int f = match.face[i];
      cy(i) = match.barycentric.row(i).dot(
          Eigen::RowVector3d(cy_vertices(FY(f, 0)), cy_vertices(FY(f, 1)), cy_vertices(FY(f, 2))));
    }
    local += window_scores(VX, nx, o.window_factor * h * D, o.sigma_factor * h * D, cx, cy,
                           [](double L, double C, double S) { return (L + C + 0.5 * S) / 2.5; });
  }
  return local / 3.0;
}

}  // namespace

PerceptualDistance msdm(const Eigen::MatrixX3d& A, const Eigen::MatrixX3d& B,
                        const Eigen::MatrixX3i& F, const MsdmOptions& o) {
  if (A.rows() != B.rows())
    throw InvalidArgumentError(
        fmt::format("MSDM needs the same vertices ({} and {}); use MSDM2", A.rows(), B.rows()));
  const double D = longest_side(A, F);
  const Neighborhoods near = ball_neighborhoods(A, vertex_adjacency(F, A.rows()),
                                                std::max(o.window_radius, o.curvature_radius) * D);
  const Eigen::VectorXd cx =
      normal_cycle_curvature(A, F, o.curvature_radius * D, near).magnitude() * (D / 2);
  // B's curvature over the same neighborhoods (same connectivity), filtered by B's distances.
  const Eigen::VectorXd cy =
      normal_cycle_curvature(B, F, o.curvature_radius * D, near).magnitude() * (D / 2);
  PerceptualDistance out;
  out.local = window_scores(A, near, o.window_radius * D, o.window_sigma * D, cx, cy,
                            [](double L, double C, double S) {
                              return std::cbrt(0.4 * L * L * L + 0.4 * C * C * C + 0.2 * S * S * S);
                            });
  out.global = pool3(out.local, F);
  return out;
}

PerceptualDistance msdm2(const Eigen::MatrixX3d& VA, const Eigen::MatrixX3i& FA,
                         const Eigen::MatrixX3d& VB, const Eigen::MatrixX3i& FB,
                         const Msdm2Options& o) {
  const double D = std::max(longest_side(VA, FA), longest_side(VB, FB));  // the same both ways
  PerceptualDistance out;
  out.local = msdm2_local(VA, FA, VB, FB, D, o);
  const Eigen::VectorXd back = msdm2_local(VB, FB, VA, FA, D, o);
  out.global = 0.5 * (pool3(out.local, FA) + pool3(back, FB));
  return out;
}

}  // namespace meshmark
