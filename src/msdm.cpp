// MSDM (Lavoue et al., SPIE 2006) as its reference implementation computes it (MEPP's
// MSDM_Component): curvature windows sampled by the ball walk, statistics of each mesh on its
// own walk, covariance from paired samples.

#include <fmt/format.h>

#include <cmath>
#include <cstdint>
#include <memory>
#include <vector>

#include "curvature_edges.h"
#include "meshmark/curvature.h"
#include "meshmark/error.h"
#include "meshmark/mesh.h"
#include "meshmark/metrics.h"
#include "msdm_common.h"
#include "parallel.h"
#include "sphere_walk.h"

namespace meshmark {

namespace {

using detail::RowPoints;
using detail::WindowStats;

// A window's samples, structure of arrays: curvature value, point, Gaussian weight.
struct Samples {
  std::vector<double> value, x, y, z, weight;
  std::size_t size() const { return value.size(); }
  void clear() { value.clear(), x.clear(), y.clear(), z.clear(), weight.clear(); }
  // The sample at fraction t of the edge v -> w (positions P, curvature c).
  void add(const RowPoints& P, const Eigen::VectorXd& c, int v, int w, double t) {
    value.push_back((1 - t) * c(v) + t * c(w));
    x.push_back(P(v, 0) + t * (P(w, 0) - P(v, 0)));
    y.push_back(P(v, 1) + t * (P(w, 1) - P(v, 1)));
    z.push_back(P(v, 2) + t * (P(w, 2) - P(v, 2)));
  }
};

// A's windows, compact (what compare needs to rebuild their samples exactly): per sample its
// edge's adjacency slot times two, plus one when the edge leaves the sphere before its end,
// whose fraction t is then the next entry of `fractions` (t = 1 otherwise). Vertex i's
// samples are codes[offsets[i], offsets[i + 1]), its fractions from fraction_offsets[i].
struct WindowCodes {
  std::vector<std::int64_t> offsets{0}, fraction_offsets{0};
  std::vector<std::uint32_t> codes;
  std::vector<double> fractions;
};

// MEPP's MSDM window around `center` (Processroughness_per_vertex_curve): one sample per edge
// the ball walk sees, at its far end or where it leaves the sphere, its curvature interpolated
// linearly along the edge. An inner vertex counts once per edge that reaches it; the center is
// no sample of its own. With `codes`, the window is also appended to them.
void window(const RowPoints& P, const Adjacency& adj, const Eigen::VectorXd& c, int center,
            double radius, detail::WalkScratch& scratch, Samples& out,
            WindowCodes* codes = nullptr) {
  out.clear();
  detail::walk_sphere(
      P, adj, center, radius, scratch, [&](int v, int slot, int w, const detail::Clip& clip, bool) {
        out.add(P, c, v, w, clip.t);
        if (!codes) return;
        codes->codes.push_back(2 * static_cast<std::uint32_t>(slot) + (clip.t != 1));
        if (clip.t != 1) codes->fractions.push_back(clip.t);
      });
  if (!codes) return;
  codes->offsets.push_back(static_cast<std::int64_t>(codes->codes.size()));
  codes->fraction_offsets.push_back(static_cast<std::int64_t>(codes->fractions.size()));
}

// Vertex i's window rebuilt from its codes (the same samples as window() gives); source[slot]
// is the vertex an adjacency slot leaves from.
void decode_window(const WindowCodes& codes, const std::vector<int>& source, const Adjacency& adj,
                   const RowPoints& P, const Eigen::VectorXd& c, std::size_t i, Samples& out) {
  out.clear();
  std::int64_t f = codes.fraction_offsets[i];
  for (std::int64_t k = codes.offsets[i]; k < codes.offsets[i + 1]; ++k) {
    const std::uint32_t code = codes.codes[static_cast<std::size_t>(k)];
    const std::size_t slot = code >> 1;
    const double t = (code & 1) ? codes.fractions[static_cast<std::size_t>(f++)] : 1.0;
    out.add(P, c, source[slot], adj.indices[slot], t);
  }
}

// Sets every sample's weight from its distance to `center`; inv = 1 / (2 sigma^2). The
// squared distance is summed as Eigen's squaredNorm sums it.
void weigh(Samples& s, const Eigen::RowVector3d& center, double inv) {
  s.weight.resize(s.size());
  for (std::size_t k = 0; k < s.size(); ++k) {
    const double dx = s.x[k] - center(0), dy = s.y[k] - center(1), dz = s.z[k] - center(2);
    s.weight[k] = std::exp(-(dx * dx + dy * dy + dz * dz) * inv);
  }
}

// Weighted mean and deviation of the samples' values.
WindowStats statistics(const Samples& s) {
  double w = 0, sum = 0;
  for (std::size_t k = 0; k < s.size(); ++k) w += s.weight[k], sum += s.weight[k] * s.value[k];
  WindowStats out;
  if (!(w > 0)) return out;
  out.mean = sum / w;
  double var = 0;
  for (std::size_t k = 0; k < s.size(); ++k)
    var += s.weight[k] * (s.value[k] - out.mean) * (s.value[k] - out.mean);
  out.deviation = std::sqrt(var / w);
  return out;
}

// Which sample of the other window each sample is paired with, for both windows; reused.
struct Pairing {
  std::vector<int> a_to_b, b_to_a;
  std::vector<double> distances;
};

// The first k < n with d[k] minimal, as the scan "best = 0; if (d[k] < d[best]) best = k"
// finds it (a NaN d[0] stays, later NaNs never win), without its chain of dependent
// comparisons: the least value by four independent running minima, then its first index.
int first_minimum(const double* d, int n) {
  if (std::isnan(d[0])) return 0;
  double m[4] = {d[0], d[0], d[0], d[0]};
  int k = 1;
  for (; k + 4 <= n; k += 4)
    for (int c = 0; c < 4; ++c) m[c] = d[k + c] < m[c] ? d[k + c] : m[c];
  for (; k < n; ++k) m[0] = d[k] < m[0] ? d[k] : m[0];
  for (int c = 1; c < 4; ++c) m[0] = m[c] < m[0] ? m[c] : m[0];
  k = 0;
  while (d[k] != m[0]) ++k;
  return k;
}

// MEPP's pairing (ProcessCovariance), one way: sample i of x goes with the nearest sample j of
// y among those with |i - j| <= reach (the first on ties). Reach >= |nx - ny| keeps every such
// range inside y. Per sample, the distances first (a loop the compiler vectorizes), then the
// nearest.
void pair_one_way(const Samples& x, const Samples& y, int reach, std::vector<double>& distances,
                  std::vector<int>& pair) {
  const int nx = static_cast<int>(x.size()), ny = static_cast<int>(y.size());
  pair.resize(x.size());
  if (reach == 0) {
    for (int i = 0; i < nx; ++i) pair[i] = i;
    return;
  }
  distances.resize(static_cast<std::size_t>(2 * reach + 1));
  const double *yx = y.x.data(), *yy = y.y.data(), *yz = y.z.data();
  double* d = distances.data();
  for (int i = 0; i < nx; ++i) {
    const int lo = std::max(0, i - reach), n = std::min(ny - 1, i + reach) - lo + 1;
    const double px = x.x[i], py = x.y[i], pz = x.z[i];
    for (int k = 0; k < n; ++k) {
      const double dx = yx[lo + k] - px, dy = yy[lo + k] - py, dz = yz[lo + k] - pz;
      d[k] = dx * dx + dy * dy + dz * dz;
    }
    pair[i] = lo + first_minimum(d, n);
  }
}

// Both ways, with reach = 2 |na - nb|: by index when the sizes agree (as when both walks saw
// the same edges).
void pair_samples(const Samples& a, const Samples& b, Pairing& p) {
  const int reach = 2 * std::abs(static_cast<int>(a.size()) - static_cast<int>(b.size()));
  pair_one_way(a, b, reach, p.distances, p.a_to_b);
  pair_one_way(b, a, reach, p.distances, p.b_to_a);
}

// One side of MEPP's covariance: x's samples weighted by x's weights, each against the sample
// of y it is paired with.
double one_sided_covariance(const Samples& x, double mx, const Samples& y, double my,
                            const std::vector<int>& pair) {
  double w = 0, sum = 0;
  for (std::size_t i = 0; i < x.size(); ++i)
    w += x.weight[i], sum += x.weight[i] * (x.value[i] - mx) * (y.value[pair[i]] - my);
  return w > 0 ? sum / w : 0;
}

// MEPP's covariance of the two windows: the mean of both sides.
double covariance(const Samples& a, double ma, const Samples& b, double mb, Pairing& p) {
  if (a.size() == 0 || b.size() == 0) return 0;
  pair_samples(a, b, p);
  return 0.5 * (one_sided_covariance(a, ma, b, mb, p.a_to_b) +
                one_sided_covariance(b, mb, a, ma, p.b_to_a));
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
  std::vector<int> source;    // per adjacency slot, the vertex it leaves from
  Eigen::VectorXd curvature;  // A's, scaled as MSDM compares it
  std::vector<WindowStats> stats;
  WindowCodes windows;  // A's, for compare to rebuild without walking
};

namespace {

// A's window statistics (weights centered on A's vertices) and the windows' codes, chunks of
// vertices on separate threads, their codes joined in vertex order.
void prepare_windows(const RowPoints& A, const Adjacency& adj, const Eigen::VectorXd& c,
                     double radius, double inv, std::vector<WindowStats>& stats, WindowCodes& all) {
  const std::int64_t nv = A.rows();
  stats.resize(static_cast<std::size_t>(nv));
  std::vector<WindowCodes> parts(static_cast<std::size_t>(detail::chunk_count(nv)));
  detail::parallel_chunks(nv, [&](int chunk, std::int64_t begin, std::int64_t end) {
    detail::WalkScratch scratch(nv);
    Samples samples;
    for (auto i = begin; i < end; ++i) {
      window(A, adj, c, static_cast<int>(i), radius, scratch, samples,
             &parts[static_cast<std::size_t>(chunk)]);
      weigh(samples, A.row(i), inv);
      stats[static_cast<std::size_t>(i)] = statistics(samples);
    }
  });
  std::size_t codes = 0, fractions = 0;
  for (const WindowCodes& part : parts)
    codes += part.codes.size(), fractions += part.fractions.size();
  all.codes.reserve(codes), all.fractions.reserve(fractions);
  all.offsets.reserve(static_cast<std::size_t>(nv) + 1);
  all.fraction_offsets.reserve(static_cast<std::size_t>(nv) + 1);
  for (WindowCodes& part : parts) {
    const auto base = static_cast<std::int64_t>(all.codes.size()),
               fraction_base = static_cast<std::int64_t>(all.fractions.size());
    for (std::size_t k = 1; k < part.offsets.size(); ++k) {
      all.offsets.push_back(base + part.offsets[k]);
      all.fraction_offsets.push_back(fraction_base + part.fraction_offsets[k]);
    }
    all.codes.insert(all.codes.end(), part.codes.begin(), part.codes.end());
    all.fractions.insert(all.fractions.end(), part.fractions.begin(), part.fractions.end());
    part = WindowCodes();
  }
}

}  // namespace

MsdmReference::MsdmReference(const Eigen::MatrixX3d& A, const Eigen::MatrixX3i& F,
                             const MsdmOptions& options) {
  auto s = std::make_shared<State>();
  s->A = A, s->F = F, s->options = options;
  s->D = detail::longest_side(A, F);
  s->adj = vertex_adjacency(F, A.rows());
  if (s->adj.indices.size() >= (std::size_t{1} << 31))
    throw InvalidArgumentError("MSDM: too many edges");
  s->source.resize(s->adj.indices.size());
  for (Eigen::Index v = 0; v < A.rows(); ++v)
    for (int k = s->adj.offsets[v]; k < s->adj.offsets[v + 1]; ++k)
      s->source[static_cast<std::size_t>(k)] = static_cast<int>(v);
  s->edges = detail::edge_table(F, s->adj, A.rows());
  s->curvature = msdm_curvature(A, F, s->adj, s->edges, options.curvature_radius * s->D, s->D);
  const double radius = options.window_radius * s->D, sigma = options.window_sigma * s->D;
  prepare_windows(s->A, s->adj, s->curvature, radius, sigma > 0 ? 1 / (2 * sigma * sigma) : 0,
                  s->stats, s->windows);
  state_ = std::move(s);
}

double MsdmReference::longest_side() const {
  return state_->D;
}

const Eigen::VectorXd& MsdmReference::curvature() const {
  return state_->curvature;
}

PerceptualDistance MsdmReference::compare(const Eigen::MatrixX3d& B) const {
  const State& s = *state_;
  if (B.rows() != s.A.rows())
    throw InvalidArgumentError(
        fmt::format("MSDM needs the same vertices ({} and {}); use MSDM2", s.A.rows(), B.rows()));
  const RowPoints PB = B;
  const Eigen::VectorXd cb =
      msdm_curvature(B, s.F, s.adj, s.edges, s.options.curvature_radius * s.D, s.D);
  const double radius = s.options.window_radius * s.D, sigma = s.options.window_sigma * s.D;
  const double inv = sigma > 0 ? 1 / (2 * sigma * sigma) : 0;
  PerceptualDistance out;
  out.local = Eigen::VectorXd::Zero(B.rows());
  // Each mesh is walked on its own geometry, as MEPP does: B may see other edges than A near
  // the sphere, and the pairing of samples absorbs the difference. A's walks are replayed from
  // their codes.
  detail::parallel_chunks(B.rows(), [&](int, std::int64_t begin, std::int64_t end) {
    detail::WalkScratch scratch(B.rows());
    Samples a, b;
    Pairing pairing;
    for (auto i = begin; i < end; ++i) {
      const int v = static_cast<int>(i);
      if (s.adj.degree(v) == 0) continue;
      decode_window(s.windows, s.source, s.adj, s.A, s.curvature, static_cast<std::size_t>(i), a);
      window(PB, s.adj, cb, v, radius, scratch, b);
      // Both covariances weigh by the distance to B's vertex, as MEPP does.
      weigh(a, PB.row(i), inv);
      weigh(b, PB.row(i), inv);
      const WindowStats x = s.stats[static_cast<std::size_t>(i)], y = statistics(b);
      const detail::MsdmTerms t =
          detail::msdm_terms(x, y, covariance(a, x.mean, b, y.mean, pairing));
      out.local(i) = std::cbrt((t.L * t.L * t.L + t.C * t.C * t.C + 0.5 * t.S * t.S * t.S) / 2.5);
    }
  });
  out.global = detail::pool3(out.local, s.F);
  return out;
}

PerceptualDistance msdm(const Eigen::MatrixX3d& A, const Eigen::MatrixX3d& B,
                        const Eigen::MatrixX3i& F, const MsdmOptions& options) {
  if (A.rows() != B.rows())
    throw InvalidArgumentError(
        fmt::format("MSDM needs the same vertices ({} and {}); use MSDM2", A.rows(), B.rows()));
  return MsdmReference(A, F, options).compare(B);
}

}  // namespace meshmark
