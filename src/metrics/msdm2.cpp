// MSDM2 (Lavoue, SGP 2011) as MEPP2's msdm2.h computes it, in both directions.

#include <cmath>
#include <iterator>
#include <vector>

#include "carrier/curvature.h"
#include "carrier/sphere_walk.h"
#include "core/parallel.h"
#include "core/progress_counter.h"
#include "meshmark/core/mesh.h"
#include "meshmark/metrics/metrics.h"
#include "metrics/closest_point.h"
#include "metrics/msdm_common.h"

namespace meshmark {

namespace {

using detail::RowPoints;

// One sample of a window on both sides: X's curvature at a point of X, the matched curvature
// at the corresponding point of Y.
struct PairedSample {
  double x, y;
  Eigen::RowVector3d px, py;
};

// MEPP2's window (process_msdm2_per_vertex): the center, every vertex the ball walk reaches
// (once), every point where an edge leaves the sphere, values and matched points interpolated
// along the edge. M holds the match of every vertex of X on Y, cm its curvature.
void paired_window(const RowPoints& P, const RowPoints& M, const Adjacency& adj,
                   const Eigen::VectorXd& c, const Eigen::VectorXd& cm, int center, double radius,
                   detail::WalkScratch& scratch, std::vector<PairedSample>& out) {
  out.clear();
  out.push_back({c(center), cm(center), P.row(center), M.row(center)});
  detail::walk_sphere(
      P, adj, center, radius, scratch,
      [&](int v, int, int w, const detail::Clip& clip, bool fresh) {
        if (clip.inside && !fresh) return;  // sampled when first reached
        const double t = clip.t;
        out.push_back({(1 - t) * c(v) + t * c(w), (1 - t) * cm(v) + t * cm(w),
                       P.row(v) + t * (P.row(w) - P.row(v)), M.row(v) + t * (M.row(w) - M.row(v))});
      });
}

// MEPP2's compute_statistics: Gaussian weights from the distance to the vertex on X's side
// and to its match on Y's; the covariance weighted by Y's weights and normalized by X's sum,
// as MEPP2 does (the two sums differ by the matching's distortion only). Per-scale value
// (L + C + 0.5 S) / 2.5.
double paired_score(const std::vector<PairedSample>& s, double inv) {
  const Eigen::RowVector3d cx = s.front().px, cy = s.front().py;
  std::vector<double> wx(s.size()), wy(s.size());
  double sx = 0, sy = 0, mx = 0, my = 0;
  for (std::size_t k = 0; k < s.size(); ++k) {
    wx[k] = std::exp(-(s[k].px - cx).squaredNorm() * inv);
    wy[k] = std::exp(-(s[k].py - cy).squaredNorm() * inv);
    sx += wx[k], sy += wy[k], mx += wx[k] * s[k].x, my += wy[k] * s[k].y;
  }
  mx /= sx, my /= sy;
  double vx = 0, vy = 0, cov = 0;
  for (std::size_t k = 0; k < s.size(); ++k) {
    vx += wx[k] * (s[k].x - mx) * (s[k].x - mx);
    vy += wy[k] * (s[k].y - my) * (s[k].y - my);
    cov += wy[k] * (s[k].x - mx) * (s[k].y - my);
  }
  const detail::WindowStats x{mx, std::sqrt(vx / sx)}, y{my, std::sqrt(vy / sy)};
  const detail::MsdmTerms t = detail::msdm_terms(x, y, cov / sx);
  return (t.L + t.C + 0.5 * t.S) / 2.5;
}

// MSDM2 in one direction: local scores of X's vertices against Y.
Eigen::VectorXd msdm2_local(const Eigen::MatrixX3d& VX, const Eigen::MatrixX3i& FX,
                            const Eigen::MatrixX3d& VY, const Eigen::MatrixX3i& FY, double D,
                            const Msdm2Options& o, detail::ProgressCounter& counter) {
  const ClosestPoints match = closest_points(VY, FY, VX);
  const Adjacency ax = vertex_adjacency(FX, VX.rows()), ay = vertex_adjacency(FY, VY.rows());
  const RowPoints P = VX, M = match.point;
  Eigen::VectorXd local = Eigen::VectorXd::Zero(VX.rows());
  for (double h : o.scales) {
    constexpr BallEdges walk = BallEdges::kReferenceWalk;
    const Eigen::VectorXd cx = normal_cycle_curvature(VX, FX, ax, h * D, walk).magnitude() * D / 2;
    const Eigen::VectorXd cy = normal_cycle_curvature(VY, FY, ay, h * D, walk).magnitude() * D / 2;
    Eigen::VectorXd cm(VX.rows());
    for (Eigen::Index i = 0; i < VX.rows(); ++i) {
      const int f = match.face[i];
      cm(i) = match.barycentric.row(i).dot(
          Eigen::RowVector3d(cy(FY(f, 0)), cy(FY(f, 1)), cy(FY(f, 2))));
    }
    const double sigma = o.sigma_factor * h * D, inv = 1 / (2 * sigma * sigma);
    detail::parallel_chunks(VX.rows(), [&](int, std::int64_t begin, std::int64_t end) {
      detail::WalkScratch scratch(VX.rows());
      std::vector<PairedSample> samples;
      detail::ProgressBatch done(counter);
      for (auto i = begin; i < end; ++i) {
        done.add();
        if (ax.degree(static_cast<int>(i)) == 0) continue;
        paired_window(P, M, ax, cx, cm, static_cast<int>(i), o.window_factor * h * D, scratch,
                      samples);
        local(i) += paired_score(samples, inv);
      }
      done.flush();
    });
  }
  return local / static_cast<double>(std::size(o.scales));
}

}  // namespace

PerceptualDistance msdm2(const Eigen::MatrixX3d& VA, const Eigen::MatrixX3i& FA,
                         const Eigen::MatrixX3d& VB, const Eigen::MatrixX3i& FB,
                         const Msdm2Options& o) {
  validate_mesh(VA, FA, "the first mesh");
  validate_mesh(VB, FB, "the second mesh");
  // The same D both ways.
  const double D = std::max(detail::longest_side(VA, FA), detail::longest_side(VB, FB));
  const long scales = static_cast<long>(std::size(o.scales));
  detail::ProgressCounter counter(o.progress, "measuring MSDM2", scales * (VA.rows() + VB.rows()));
  PerceptualDistance out;
  out.local = msdm2_local(VA, FA, VB, FB, D, o, counter);
  const Eigen::VectorXd back = msdm2_local(VB, FB, VA, FA, D, o, counter);
  out.global = 0.5 * (detail::pool3(out.local, FA) + detail::pool3(back, FB));
  return out;
}

}  // namespace meshmark
