// MSDM (Lavoue et al., SPIE 2006) as its reference implementation computes it (MEPP's
// MSDM_Component): curvature windows sampled by the ball walk, statistics of each mesh on its
// own walk, covariance from paired samples.

#include <fmt/format.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <mutex>
#include <vector>

#include "carrier/curvature.h"
#include "carrier/curvature_edges.h"
#include "carrier/sphere_walk.h"
#include "core/lanes.h"
#include "core/parallel.h"
#include "core/progress_counter.h"
#include "meshmark/core/error.h"
#include "meshmark/core/mesh.h"
#include "meshmark/metrics/metrics.h"
#include "metrics/msdm_common.h"

namespace meshmark {

namespace detail {

// Four points at a time; the processor picks the wider lanes at load time.
MESHMARK_LANE_TARGETS std::ptrdiff_t nearest_point(const double* x, const double* y,
                                                   const double* z, std::ptrdiff_t n, double qx,
                                                   double qy, double qz) {
  using Lanes = double __attribute__((vector_size(32)));
  using Indices = std::int64_t __attribute__((vector_size(32)));
  constexpr double kFar = std::numeric_limits<double>::infinity();
  const Lanes QX = {qx, qx, qx, qx}, QY = {qy, qy, qy, qy}, QZ = {qz, qz, qz, qz};
  Lanes best = {kFar, kFar, kFar, kFar};
  Indices at = {-1, -1, -1, -1}, index = {0, 1, 2, 3};
  const Indices four = {4, 4, 4, 4};
  {  // a loop from the first point keeps it when its distance is not a number
    const double dx = x[0] - qx, dy = y[0] - qy, dz = z[0] - qz;
    if (std::isnan((dx * dx + dy * dy) + dz * dz)) return 0;
  }
  std::ptrdiff_t j = 0;
  for (; j + 4 <= n; j += 4) {
    Lanes a, b, c;
    std::memcpy(&a, x + j, sizeof a), std::memcpy(&b, y + j, sizeof b),
        std::memcpy(&c, z + j, sizeof c);
    a -= QX, b -= QY, c -= QZ;
    const Lanes d = (a * a + b * b) + c * c;
    const Indices closer = d < best;
    best = closer ? d : best;
    at = closer ? index : at;
    index += four;
  }
  double nearest = kFar;
  std::ptrdiff_t found = -1;
  for (int l = 0; l < 4; ++l)
    if (at[l] >= 0 && (best[l] < nearest || (best[l] == nearest && at[l] < found)))
      nearest = best[l], found = at[l];
  for (; j < n; ++j) {
    const double dx = x[j] - qx, dy = y[j] - qy, dz = z[j] - qz;
    const double d = (dx * dx + dy * dy) + dz * dz;
    if (d < nearest) nearest = d, found = j;
  }
  return found < 0 ? 0 : found;
}

}  // namespace detail

namespace {

using detail::RowPoints;
using detail::WindowStats;

// One sample of a window: a curvature value at a point, and its Gaussian weight.
struct Sample {
  double value;
  Eigen::RowVector3d point;
  double weight = 0;
};

// MEPP's MSDM window around `center` (Processroughness_per_vertex_curve): one sample per edge
// the ball walk sees, at its far end or where it leaves the sphere, its curvature interpolated
// linearly along the edge. An inner vertex counts once per edge that reaches it; the center is
// no sample of its own.
void window(const RowPoints& P, const Adjacency& adj, const Eigen::VectorXd& c, int center,
            double radius, detail::WalkScratch& scratch, std::vector<Sample>& out) {
  out.clear();
  detail::walk_sphere(
      P, adj, center, radius, scratch, [&](int v, int, int w, const detail::Clip& clip, bool) {
        const double t = clip.t;
        out.push_back({(1 - t) * c(v) + t * c(w), P.row(v) + t * (P.row(w) - P.row(v)), 0.0});
      });
}

// Sets every sample's weight from its distance to `center`; inv = 1 / (2 sigma^2).
void weigh(std::vector<Sample>& s, const Eigen::RowVector3d& center, double inv) {
  for (Sample& x : s) x.weight = std::exp(-(x.point - center).squaredNorm() * inv);
}

// Weighted mean and deviation of the samples' values.
WindowStats statistics(const std::vector<Sample>& s) {
  double w = 0, sum = 0;
  for (const Sample& x : s) w += x.weight, sum += x.weight * x.value;
  WindowStats out;
  if (!(w > 0)) return out;
  out.mean = sum / w;
  double var = 0;
  for (const Sample& x : s) var += x.weight * (x.value - out.mean) * (x.value - out.mean);
  out.deviation = std::sqrt(var / w);
  return out;
}

// A window's sample points, a column per coordinate, for nearest_point.
struct PointColumns {
  std::vector<double> x, y, z;
  void assign(const std::vector<Sample>& s) {
    x.resize(s.size()), y.resize(s.size()), z.resize(s.size());
    for (std::size_t k = 0; k < s.size(); ++k)
      x[k] = s[k].point(0), y[k] = s[k].point(1), z[k] = s[k].point(2);
  }
};

// From this many candidates on, one_sided_covariance searches four at a time.
constexpr std::ptrdiff_t kWideSearch = 8;

// One side of MEPP's covariance (ProcessCovariance): each sample of x is paired with the
// nearest sample of y among those whose index differs by at most twice the difference of the
// window sizes (by index when the sizes agree, as when both walks saw the same edges; the
// first of equally near ones); x's weights. `columns` holds y's points when the search is wide.
double one_sided_covariance(const std::vector<Sample>& x, double mx, const std::vector<Sample>& y,
                            double my, PointColumns& columns) {
  if (x.empty() || y.empty()) return 0;
  const std::ptrdiff_t nx = static_cast<std::ptrdiff_t>(x.size()),
                       ny = static_cast<std::ptrdiff_t>(y.size());
  const std::ptrdiff_t reach = 2 * std::abs(nx - ny);
  const bool wide = 2 * reach >= kWideSearch;
  if (wide) columns.assign(y);
  double w = 0, sum = 0;
  for (std::ptrdiff_t i = 0; i < nx; ++i) {
    const std::ptrdiff_t lo = std::min(std::max<std::ptrdiff_t>(0, i - reach), ny - 1),
                         hi = std::min(ny - 1, i + reach);
    std::ptrdiff_t best = lo;
    if (wide && hi - lo >= kWideSearch) {
      const auto first = static_cast<std::size_t>(lo);
      best += detail::nearest_point(columns.x.data() + first, columns.y.data() + first,
                                    columns.z.data() + first, hi - lo + 1, x[i].point(0),
                                    x[i].point(1), x[i].point(2));
    } else {
      double nearest = (y[lo].point - x[i].point).squaredNorm();
      for (std::ptrdiff_t j = lo + 1; j <= hi; ++j) {
        const double d = (y[j].point - x[i].point).squaredNorm();
        if (d < nearest) nearest = d, best = j;
      }
    }
    w += x[i].weight, sum += x[i].weight * (x[i].value - mx) * (y[best].value - my);
  }
  return w > 0 ? sum / w : 0;
}

// Curvature as MSDM compares it: (|kmax| + |kmin|) / 2, times D (MEPP's KmaxKmean).
Eigen::VectorXd msdm_curvature(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                               const Adjacency& adj, const detail::EdgeTable& edges, double radius,
                               double D) {
  return detail::normal_cycle_curvature(V, F, adj, edges, radius, BallEdges::kReferenceWalk)
             .magnitude() *
         (D / 2);
}

}  // namespace

struct MsdmReference::State {
  RowPoints A;
  Eigen::MatrixX3i F;
  MsdmOptions options;
  double D = 0;
  Adjacency adj;
  detail::EdgeTable edges;    // of F, for the curvature of every B
  Eigen::VectorXd curvature;  // A's, scaled as MSDM compares it
  std::vector<WindowStats> stats;
};

MsdmReference::MsdmReference(const Eigen::MatrixX3d& A, const Eigen::MatrixX3i& F,
                             const MsdmOptions& options, const ProgressCallback& progress) {
  auto s = std::make_shared<State>();
  s->A = A, s->F = F, s->options = options;
  s->D = detail::longest_side(A, F);
  s->adj = vertex_adjacency(F, A.rows());
  s->edges = detail::edge_table(F, s->adj, A.rows());
  s->curvature = msdm_curvature(A, F, s->adj, s->edges, options.curvature_radius * s->D, s->D);
  s->stats.resize(static_cast<std::size_t>(A.rows()));
  const double radius = options.window_radius * s->D, sigma = options.window_sigma * s->D;
  const double inv = sigma > 0 ? 1 / (2 * sigma * sigma) : 0;
  detail::ProgressCounter counter(progress, "measuring MSDM (the original's windows)", A.rows());
  detail::parallel_chunks(A.rows(), [&](int, std::int64_t begin, std::int64_t end) {
    detail::WalkScratch scratch(A.rows());
    std::vector<Sample> samples;
    detail::ProgressBatch done(counter);
    for (auto i = begin; i < end; ++i) {
      window(s->A, s->adj, s->curvature, static_cast<int>(i), radius, scratch, samples);
      weigh(samples, s->A.row(i), inv);
      s->stats[static_cast<std::size_t>(i)] = statistics(samples);
      done.add();
    }
    done.flush();
  });
  state_ = std::move(s);
}

double MsdmReference::longest_side() const {
  return state_->D;
}

const Eigen::VectorXd& MsdmReference::curvature() const {
  return state_->curvature;
}

Eigen::VectorXd MsdmReference::locals(const Eigen::MatrixX3d& B, int stride, const char* phase,
                                      const ProgressCallback& progress) const {
  const State& s = *state_;
  if (B.rows() != s.A.rows())
    throw InvalidArgumentError(
        fmt::format("MSDM needs the same vertices ({} and {}); use MSDM2", s.A.rows(), B.rows()));
  if (stride < 1) throw InvalidArgumentError(fmt::format("MSDM stride {} is below 1", stride));
  const RowPoints PB = B;
  const Eigen::VectorXd cb =
      msdm_curvature(B, s.F, s.adj, s.edges, s.options.curvature_radius * s.D, s.D);
  const double radius = s.options.window_radius * s.D, sigma = s.options.window_sigma * s.D;
  const double inv = sigma > 0 ? 1 / (2 * sigma * sigma) : 0;
  Eigen::VectorXd local = Eigen::VectorXd::Zero(B.rows());
  const std::int64_t valued = (B.rows() + stride - 1) / stride;
  // Each mesh is walked on its own geometry, as MEPP does: B may see other edges than A near
  // the sphere, and the pairing of samples absorbs the difference.
  detail::ProgressCounter counter(progress, phase, valued);
  detail::parallel_chunks(valued, [&](int, std::int64_t begin, std::int64_t end) {
    detail::WalkScratch scratch_a(B.rows()), scratch_b(B.rows());
    std::vector<Sample> a, b;
    PointColumns columns;
    detail::ProgressBatch done(counter);
    for (auto k = begin; k < end; ++k) {
      const std::int64_t i = k * stride;
      const int v = static_cast<int>(i);
      done.add();
      if (s.adj.degree(v) == 0) continue;
      window(s.A, s.adj, s.curvature, v, radius, scratch_a, a);
      window(PB, s.adj, cb, v, radius, scratch_b, b);
      // Both covariances weigh by the distance to B's vertex, as MEPP does.
      weigh(a, PB.row(i), inv);
      weigh(b, PB.row(i), inv);
      const WindowStats x = s.stats[static_cast<std::size_t>(i)], y = statistics(b);
      const double covariance = 0.5 * (one_sided_covariance(a, x.mean, b, y.mean, columns) +
                                       one_sided_covariance(b, y.mean, a, x.mean, columns));
      const detail::MsdmTerms t = detail::msdm_terms(x, y, covariance);
      local(i) = std::cbrt((t.L * t.L * t.L + t.C * t.C * t.C + 0.5 * t.S * t.S * t.S) / 2.5);
    }
    done.flush();
  });
  return local;
}

PerceptualDistance MsdmReference::compare(const Eigen::MatrixX3d& B,
                                          const ProgressCallback& progress) const {
  PerceptualDistance out;
  out.local = locals(B, 1, "measuring MSDM", progress);
  out.global = detail::pool3(out.local, state_->F);
  return out;
}

double MsdmReference::estimate(const Eigen::MatrixX3d& B, int stride,
                               const ProgressCallback& progress) const {
  return detail::pool3(locals(B, stride, "estimating MSDM", progress), state_->F, stride);
}

MsdmReference SharedMsdmReference::get(const Eigen::MatrixX3d& A, const Eigen::MatrixX3i& F,
                                       const ProgressCallback& progress) {
  const std::lock_guard<std::mutex> guard(lock_);
  if (!reference_) {
    reference_.emplace(A, F, MsdmOptions{}, progress);
  } else if (reference_->curvature().size() != A.rows() ||
             reference_->longest_side() != detail::longest_side(A, F)) {
    throw InvalidArgumentError(fmt::format(
        "the shared MSDM reference is of another mesh ({} vertices, longest side {}; asked for "
        "{} vertices, longest side {})",
        reference_->curvature().size(), reference_->longest_side(), A.rows(),
        detail::longest_side(A, F)));
  }
  return *reference_;
}

PerceptualDistance msdm(const Eigen::MatrixX3d& A, const Eigen::MatrixX3d& B,
                        const Eigen::MatrixX3i& F, const MsdmOptions& options,
                        const ProgressCallback& progress) {
  if (A.rows() != B.rows())
    throw InvalidArgumentError(
        fmt::format("MSDM needs the same vertices ({} and {}); use MSDM2", A.rows(), B.rows()));
  validate_mesh(A, F, "the first mesh");
  validate_mesh(B, F, "the second mesh");
  return MsdmReference(A, F, options, progress).compare(B, progress);
}

}  // namespace meshmark
