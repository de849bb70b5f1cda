// Distortion metrics: zero for identical meshes, growing with the noise, Hausdorff against a
// brute-force point-to-triangle computation, sampled RMS against vertex RMS, MSDM2 symmetric
// and blind to vertex order.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "meshmark/attacks/attack.h"
#include "meshmark/core/error.h"
#include "meshmark/io/io.h"
#include "meshmark/metrics/metrics.h"
#include "metrics/msdm_common.h"
#include "test_data.h"

using namespace meshmark;
using namespace meshmark::test;

namespace {

// Closest point on triangle abc to p (Ericson, Real-Time Collision Detection, 5.1.5), written
// out here independently of CGAL.
Eigen::Vector3d closest_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                    const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + d1 / (d1 - d3) * ab;
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + d2 / (d2 - d6) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
    return b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b);
  const double denom = 1 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

double brute_max_distance(const Eigen::MatrixX3d& S, const Eigen::MatrixX3d& V,
                          const Eigen::MatrixX3i& F) {
  double worst = 0;
  for (Eigen::Index i = 0; i < S.rows(); ++i) {
    double best = 1e300;
    for (Eigen::Index f = 0; f < F.rows(); ++f) {
      const Eigen::Vector3d q =
          closest_on_triangle(S.row(i).transpose(), V.row(F(f, 0)).transpose(),
                              V.row(F(f, 1)).transpose(), V.row(F(f, 2)).transpose());
      best = std::min(best, (q - S.row(i).transpose()).norm());
    }
    worst = std::max(worst, best);
  }
  return worst;
}

}  // namespace

TEST(Metrics, IdenticalMeshesScoreZero) {
  const std::string path = data_mesh("spot.obj");
  MESHMARK_REQUIRE(path, "spot.obj");
  const Mesh m = read_mesh(path);
  const double diag = bounding_box_diagonal(m.V);
  EXPECT_EQ(vertex_rms_percent(m.V, m.V, m.F), 0.0);
  const SurfaceDistance d = surface_distance(m.V, m.F, m.V, m.F);
  EXPECT_LE(d.mrms, 1e-12 * diag);
  EXPECT_LE(d.hausdorff, 1e-12 * diag);
  EXPECT_LE(msdm(m.V, m.V, m.F).global, 1e-12)
      << "zero up to rounding (sigma_X sigma_Y against sigma_XY)";
  EXPECT_LE(msdm2(m.V, m.F, m.V, m.F).global, 1e-9);
}

TEST(Metrics, EveryMetricGrowsWithTheNoise) {
  const std::string path = cgal_mesh("elephant.off");
  MESHMARK_REQUIRE(path, "libcgal-demo elephant.off");
  const Mesh m = read_mesh(path);
  double last[5] = {0, 0, 0, 0, 0};
  for (double amplitude : {0.0005, 0.002, 0.008}) {
    const Mesh n = attack_noise(m, amplitude, NoiseReference::Diagonal, 3);
    const SurfaceDistance d = surface_distance(m.V, m.F, n.V, n.F);
    const double now[5] = {vertex_rms_percent(m.V, n.V, m.F), d.mrms, d.hausdorff,
                           msdm(m.V, n.V, m.F).global, msdm2(m.V, m.F, n.V, n.F).global};
    for (int k = 0; k < 5; ++k)
      EXPECT_GT(now[k], last[k]) << "metric " << k << " at amplitude " << amplitude;
    std::copy(now, now + 5, last);
  }
}

TEST(Metrics, HausdorffMatchesBruteForceOnSmallMeshes) {
  const Mesh a = bumpy_sphere(8, 10, 1), b = bumpy_sphere(9, 11, 2);
  SurfaceDistanceOptions o;
  o.samples = 300;
  const SurfaceDistance d = surface_distance(a.V, a.F, b.V, b.F, o);
  // The same samples (same seeds), distances by brute force over every triangle.
  const double ab = brute_max_distance(sample_surface(a.V, a.F, o.samples, o.seed), b.V, b.F);
  const double ba = brute_max_distance(sample_surface(b.V, b.F, o.samples, o.seed + 1), a.V, a.F);
  EXPECT_NEAR(d.max_ab, ab, 1e-9 * ab);
  EXPECT_NEAR(d.max_ba, ba, 1e-9 * ba);
  EXPECT_NEAR(d.hausdorff, std::max(ab, ba), 1e-9 * std::max(ab, ba));
}

TEST(Metrics, SampledRmsAgreesWithVertexRmsForSmallSmoothDisplacements) {
  Mesh m = bumpy_sphere(60, 90, 5);
  for (Eigen::Index i = 0; i < m.V.rows(); ++i) m.V.row(i).normalize();  // a round sphere
  Mesh moved = m;
  for (Eigen::Index i = 0; i < m.V.rows(); ++i) {
    const double z = m.V(i, 2);
    moved.V.row(i) *= 1 + 1e-4 * (1 + 0.5 * std::sin(3 * z));  // smooth, along the normal
  }
  const double vertex = vertex_rms_percent(m.V, moved.V, m.F);
  const SurfaceDistance d = surface_distance(m.V, m.F, moved.V, moved.F);
  EXPECT_NEAR(d.mrms_percent(), vertex, 0.05 * vertex)
      << "vertex RMS " << vertex << " %, MRMS " << d.mrms_percent() << " %";
}

TEST(Metrics, Msdm2IsSymmetricAndBlindToVertexOrder) {
  const std::string path = data_mesh("spot.obj");
  MESHMARK_REQUIRE(path, "spot.obj");
  const Mesh m = read_mesh(path);
  const Mesh n = attack_noise(m, 0.002, NoiseReference::Diagonal, 9);
  const double ab = msdm2(m.V, m.F, n.V, n.F).global, ba = msdm2(n.V, n.F, m.V, m.F).global;
  EXPECT_NEAR(ab, ba, 1e-12);
  const Mesh shuffled = attack_reorder(n, 4);
  EXPECT_NEAR(msdm2(m.V, m.F, shuffled.V, shuffled.F).global, ab, 1e-9);
  EXPECT_GT(ab, 0.0);
}

TEST(Metrics, PreparedMsdmEqualsTheOneCall) {
  const std::string path = data_mesh("spot.obj");
  MESHMARK_REQUIRE(path, "spot.obj");
  const Mesh m = read_mesh(path);
  const MsdmReference reference(m.V, m.F);
  for (double amplitude : {0.0005, 0.002}) {  // one reference, several candidates
    const Mesh n = attack_noise(m, amplitude, NoiseReference::Diagonal, 5);
    const PerceptualDistance once = msdm(m.V, n.V, m.F), prepared = reference.compare(n.V);
    EXPECT_EQ(prepared.global, once.global) << amplitude;
    EXPECT_EQ((prepared.local - once.local).cwiseAbs().maxCoeff(), 0.0) << amplitude;
  }
  EXPECT_THROW(reference.compare(m.V.topRows(10)), InvalidArgumentError);
}

// The estimate that steers the strength search is MSDM's pooling over every k-th vertex,
// each valued as the full comparison values it: computed here from compare's local values at
// those vertices (only the ones F references count). Stride 1 is the full value; on a real
// mesh, every 9th vertex (about 4,000 windows, as the search uses on bunny00) lands within
// kEstimateTolerance of it.
TEST(Metrics, MsdmEstimateIsThePoolOfEveryKthLocalValue) {
  constexpr double kSamePool = 1e-14;          // the same sum, in the same order
  constexpr double kEstimateTolerance = 0.03;  // relative, at 4,000 windows
  const std::string path = cgal_mesh("bunny00.off");
  MESHMARK_REQUIRE(path, "libcgal-demo bunny00.off");
  Mesh m = read_mesh(path);
  // An unreferenced vertex, which pools as nothing: the last vertex, out of every face.
  const Eigen::Index spare = m.V.rows();
  m.V.conservativeResize(spare + 1, 3);
  m.V.row(spare) = m.V.row(0);
  const Mesh n = attack_noise(m, 0.0005, NoiseReference::Diagonal, 11);
  const MsdmReference reference(m.V, m.F);
  const PerceptualDistance full = reference.compare(n.V);
  EXPECT_EQ(reference.estimate(n.V, 1), full.global);
  const std::vector<std::uint8_t> used = referenced_vertices(m.F, m.V.rows());
  ASSERT_FALSE(used[spare]);
  ASSERT_EQ(spare % 2, 0) << "stride 2 should meet the unreferenced vertex";
  for (const int stride : {2, 9, 50}) {
    double sum = 0;
    int count = 0;
    for (Eigen::Index i = 0; i < m.V.rows(); ++i)
      if (i % stride == 0 && used[i]) sum += std::pow(full.local(i), 3), ++count;
    const double expected = std::cbrt(sum / count);
    EXPECT_NEAR(reference.estimate(n.V, stride), expected, kSamePool * expected) << stride;
    if (stride == 9)
      EXPECT_NEAR(expected, full.global, kEstimateTolerance * full.global)
          << "every 9th vertex's windows misjudge the whole";
  }
  EXPECT_THROW(reference.estimate(n.V, 0), InvalidArgumentError);
  EXPECT_THROW(reference.estimate(n.V.topRows(10), 2), InvalidArgumentError);
}

// Every vertex's window is computed on its own and the pooling runs in vertex order: the
// values do not depend on how many threads share the vertices (MESHMARK_THREADS, parallel.h).
// Spot subdivided once (12k vertices) is above the size from which the work is split.
TEST(Metrics, MsdmDoesNotDependOnTheThreadCount) {
  const std::string path = data_mesh("spot.obj");
  MESHMARK_REQUIRE(path, "spot.obj");
  const Mesh m = attack_subdivide(read_mesh(path), Subdivision::Loop, 1);
  const Mesh n = attack_noise(m, 0.001, NoiseReference::Diagonal, 3);
  auto with_threads = [&](const char* threads) {
    setenv("MESHMARK_THREADS", threads, 1);
    PerceptualDistance d = MsdmReference(m.V, m.F).compare(n.V);
    unsetenv("MESHMARK_THREADS");
    return d;
  };
  const PerceptualDistance one = with_threads("1"), three = with_threads("3");
  EXPECT_GT(one.global, 0.0);
  EXPECT_EQ(one.global, three.global);
  EXPECT_EQ((one.local - three.local).cwiseAbs().maxCoeff(), 0.0);
}

// MSDM's radii are fractions of the bounding box's longest side D and its curvature is scaled
// by D: a scaling and a shift of both meshes leave every value unchanged (up to rounding,
// which may move an edge across a window's sphere). A rotation would not: it changes the
// axis-aligned box, hence D.
TEST(Metrics, MsdmIsBlindToScaleAndShiftOfBothMeshes) {
  const std::string path = cgal_mesh("cow.off");
  MESHMARK_REQUIRE(path, "libcgal-demo cow.off");
  const Mesh m = read_mesh(path);
  const Mesh n = attack_noise(m, 0.001, NoiseReference::Diagonal, 2);
  const Eigen::RowVector3d shift(4, -2, 9);
  auto move = [&](const Eigen::MatrixX3d& V) {
    return Eigen::MatrixX3d(((37.5 * V).rowwise() + shift).eval());
  };
  const double before = msdm(m.V, n.V, m.F).global, after = msdm(move(m.V), move(n.V), m.F).global;
  EXPECT_GT(before, 0.0);
  EXPECT_NEAR(after, before, 1e-6 * before);
  const double before2 = msdm2(m.V, m.F, n.V, n.F).global;
  EXPECT_NEAR(msdm2(move(m.V), m.F, move(n.V), n.F).global, before2, 1e-6 * before2);
}

TEST(Metrics, SurfaceDistanceRefusesAMeshWithoutFaces) {
  // No triangle, no surface to sample: an error naming it, never a read past empty samples.
  const Mesh m = bumpy_sphere(8, 8, 3);
  const Eigen::MatrixX3i none(0, 3);
  EXPECT_THROW(surface_distance(m.V, none, m.V, m.F), InvalidArgumentError);
  EXPECT_THROW(surface_distance(m.V, m.F, m.V, none), InvalidArgumentError);
}

// compare_meshes (what `meshmark compare` prints) gives each metric as its own function does,
// MSDM only where the connectivity is shared, and reports its phases in order: each starts at
// 0 and counts up to its total, in steps that never go back.
TEST(Metrics, CompareMeshesGivesEachMetricAndReportsItsPhases) {
  const std::string path = data_mesh("spot.obj");
  MESHMARK_REQUIRE(path, "spot.obj");
  const Mesh m = read_mesh(path);
  struct Report {
    std::string phase;
    long done, total;
  };
  auto check_phases = [](const std::vector<Report>& reports, const std::vector<std::string>& want) {
    std::vector<std::string> phases;
    for (std::size_t k = 0; k < reports.size(); ++k) {
      const Report& r = reports[k];
      if (r.done == 0) {
        if (k > 0) EXPECT_EQ(reports[k - 1].done, reports[k - 1].total) << "phase ended early";
        phases.push_back(r.phase);
        continue;
      }
      ASSERT_FALSE(phases.empty());
      EXPECT_EQ(r.phase, phases.back());
      EXPECT_GT(r.done, reports[k - 1].done);
      EXPECT_LE(r.done, r.total);
    }
    ASSERT_FALSE(reports.empty());
    EXPECT_EQ(reports.back().done, reports.back().total);
    EXPECT_EQ(phases, want);
  };
  const SurfaceDistanceOptions sampling{5000, 3};
  std::vector<Report> reports;
  auto compare_reporting = [&](const Mesh& other) {
    reports.clear();
    CompareOptions o;
    o.sampling = sampling;
    o.progress = [&](const std::string& phase, long done, long total, const std::string&) {
      reports.push_back({phase, done, total});
    };
    return compare_meshes(m, other, o);
  };
  const Mesh noisy = attack_noise(m, 0.001, NoiseReference::Diagonal, 4);
  {
    const MeshComparison c = compare_reporting(noisy);
    EXPECT_TRUE(c.same_connectivity);
    EXPECT_EQ(c.rms_percent, vertex_rms_percent(m.V, noisy.V, m.F));
    EXPECT_EQ(c.msdm, msdm(m.V, noisy.V, m.F).global);
    const SurfaceDistance d = surface_distance(m.V, m.F, noisy.V, noisy.F, sampling);
    EXPECT_EQ(c.surface.rms_ab, d.rms_ab);
    EXPECT_EQ(c.surface.hausdorff, d.hausdorff);
    EXPECT_EQ(c.msdm2.global, msdm2(m.V, m.F, noisy.V, noisy.F).global);
    check_phases(reports, {"measuring MSDM (the original's windows)", "measuring MSDM",
                           "measuring surface distances", "measuring MSDM2"});
  }
  // The same vertices with one triangle fewer, and a shuffled vertex order: other
  // connectivities, so no vertex RMS or MSDM, and no MSDM phase.
  for (const Mesh& other : {Mesh{m.V, m.F.topRows(m.F.rows() - 1), {}}, attack_reorder(m, 6)}) {
    const MeshComparison c = compare_reporting(other);
    EXPECT_FALSE(c.same_connectivity);
    EXPECT_EQ(c.msdm2.global, msdm2(m.V, m.F, other.V, other.F).global);
    check_phases(reports, {"measuring surface distances", "measuring MSDM2"});
  }
}

// MSDM pairs each sample with the nearest of a range of the other window's samples; the search
// runs four points at a time. It must pick what the point-by-point loop with Eigen picks, ties
// and distances that are not numbers included, or MSDM would change.
TEST(Metrics, MsdmsNearestSampleSearchPicksWhatThePointByPointLoopPicks) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> coordinate(-1, 1);
  std::uniform_int_distribution<int> pick(0, 9);
  const double nan = std::numeric_limits<double>::quiet_NaN(),
               inf = std::numeric_limits<double>::infinity();
  int ties = 0, checked = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    const int n = 1 + trial % 41;
    std::vector<Eigen::RowVector3d> p(static_cast<std::size_t>(n));
    for (auto& q : p) q = {coordinate(rng), coordinate(rng), coordinate(rng)};
    Eigen::RowVector3d query(coordinate(rng), coordinate(rng), coordinate(rng));
    // Structured cases: repeated points (as an inner vertex reached by several edges), the
    // query on a point, a point or a coordinate that is not finite.
    for (auto& q : p) {
      const int c = pick(rng);
      if (c == 0) q = p[static_cast<std::size_t>(pick(rng)) % p.size()];
      if (c == 1 && trial % 3 == 0) q(pick(rng) % 3) = nan;
      if (c == 2 && trial % 5 == 0) q(pick(rng) % 3) = trial % 2 ? inf : -inf;
    }
    if (trial % 4 == 0) query = p[static_cast<std::size_t>(pick(rng)) % p.size()];
    if (trial % 7 == 0) p[0] = p[static_cast<std::size_t>(n - 1)];
    std::vector<double> x, y, z;
    for (const auto& q : p) x.push_back(q(0)), y.push_back(q(1)), z.push_back(q(2));
    std::ptrdiff_t expected = 0;
    double nearest = (p[0] - query).squaredNorm();
    for (std::ptrdiff_t j = 1; j < n; ++j) {
      const double d = (p[static_cast<std::size_t>(j)] - query).squaredNorm();
      if (d == nearest) ++ties;
      if (d < nearest) nearest = d, expected = j;
    }
    ASSERT_EQ(meshmark::detail::nearest_point(x.data(), y.data(), z.data(), n, query(0), query(1),
                                              query(2)),
              expected)
        << "trial " << trial << ", " << n << " points";
    ++checked;
  }
  EXPECT_EQ(checked, 20000);
  EXPECT_GT(ties, 1000);  // the structured cases did produce ties
}
