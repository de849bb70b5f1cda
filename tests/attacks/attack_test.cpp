// Each attack's defining property, on real meshes, checked from scratch.

#include <gtest/gtest.h>
#include <sys/resource.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <map>
#include <numeric>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include <fmt/format.h>

#include "meshmark/attacks/attack.h"
#include "meshmark/core/error.h"
#include "meshmark/io/io.h"
#include "metrics/closest_point.h"
#include "test_data.h"

using namespace meshmark;
using namespace meshmark::test;

namespace {

// A strength each kind is meant to take, chosen here (not from the registry).
double test_strength(const std::string& kind) {
  if (kind == "noise" || kind == "noise-radius") return 0.002;
  if (kind == "quant") return 9;
  if (kind == "smooth" || kind == "taubin") return 3;
  if (kind == "soup") return 0.9;
  if (kind == "simplify" || kind == "qsimplify") return 0.5;
  if (kind == "crop") return 0.1;
  return 0;
}

std::string ply_bytes(const Mesh& m) {
  return write_mesh_to_bytes(m, FileFormat::Ply);
}

Mesh real(const std::string& path) {
  return read_mesh(path);
}

std::size_t undirected_edges(const Eigen::MatrixX3i& F) {
  std::set<std::pair<int, int>> edges;
  for (Eigen::Index t = 0; t < F.rows(); ++t)
    for (int c = 0; c < 3; ++c) edges.insert(std::minmax(F(t, c), F(t, (c + 1) % 3)));
  return edges.size();
}

bool closed_two_manifold_edges(const Eigen::MatrixX3i& F) {
  std::map<std::pair<int, int>, int> count;
  for (Eigen::Index t = 0; t < F.rows(); ++t)
    for (int c = 0; c < 3; ++c) ++count[std::minmax(F(t, c), F(t, (c + 1) % 3))];
  for (const auto& [e, n] : count)
    if (n != 2) return false;
  return true;
}

double diagonal(const Eigen::MatrixX3d& V) {
  return (V.colwise().maxCoeff() - V.colwise().minCoeff()).norm();
}

// An n x n grid of vertices (x, y in 0..n-1, z a fixed bump), two triangles per cell: an open
// surface whose boundary vertices are those with x or y at 0 or n - 1.
Mesh bumpy_grid(int n) {
  Eigen::MatrixX3d V(n * n, 3);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) V.row(y * n + x) << x, y, 0.3 * std::sin(1.7 * x + 0.9 * y * y);
  Eigen::MatrixX3i F(2 * (n - 1) * (n - 1), 3);
  int t = 0;
  for (int y = 0; y + 1 < n; ++y)
    for (int x = 0; x + 1 < n; ++x) {
      const int a = y * n + x;
      F.row(t++) << a, a + 1, a + n + 1;
      F.row(t++) << a, a + n + 1, a + n;
    }
  return make_mesh(V, F);
}

bool on_grid_border(int i, int n) {
  const int x = i % n, y = i / n;
  return x == 0 || y == 0 || x == n - 1 || y == n - 1;
}

}  // namespace

TEST(Attack, NoiseStaysWithinItsAmplitudeForBothReferences) {
  const std::string path = data_mesh("bunny.ply");
  MESHMARK_REQUIRE(path, "bunny.ply");
  const Mesh m = real(path);
  // bunny.ply has unreferenced vertices: the references are over the referenced ones.
  const auto used = referenced_vertices(m.F, m.V.rows());
  Eigen::RowVector3d lo = Eigen::RowVector3d::Constant(1e300), hi = -lo,
                     c = Eigen::RowVector3d::Zero();
  double n = 0;
  for (Eigen::Index i = 0; i < m.V.rows(); ++i)
    if (used[i])
      lo = lo.cwiseMin(m.V.row(i)), hi = hi.cwiseMax(m.V.row(i)), c += m.V.row(i), n += 1;
  c /= n;
  double mean_radius = 0;
  for (Eigen::Index i = 0; i < m.V.rows(); ++i)
    if (used[i]) mean_radius += (m.V.row(i) - c).norm() / n;
  const double diag = (hi - lo).norm();
  for (auto [ref, length] : {std::pair{NoiseReference::Diagonal, diag},
                             std::pair{NoiseReference::MeanRadius, mean_radius}}) {
    const double A = 0.003 * length;
    const Mesh a = attack_noise(m, 0.003, ref, 5);
    const double biggest = (a.V - m.V).cwiseAbs().maxCoeff();
    EXPECT_LE(biggest, A * (1 + 1e-12));
    EXPECT_GE(biggest, 0.95 * A) << "uniform noise over 24k coordinates comes close to its bound";
  }
}

// Colluders' copies: three copies of spot, each the original with its own noise. An average is
// the weighted mean of the three at every vertex; a splice takes every vertex whole from one
// copy, in a few contiguous regions (few edges join two copies), each copy one of them.
TEST(Attack, ColludersMergeCopiesVertexByVertexOrByRegion) {
  const std::string path = data_mesh("spot.obj");
  MESHMARK_REQUIRE(path, "spot.obj");
  const Mesh m = real(path);
  std::vector<Mesh> copies;
  for (std::uint64_t seed = 1; seed <= 3; ++seed)
    copies.push_back(attack_noise(m, 0.001, NoiseReference::Diagonal, seed));
  const double scale = m.V.cwiseAbs().maxCoeff();
  const auto worst_gap = [&](const Mesh& merged, const std::array<double, 3>& w) {
    double worst = 0;
    for (Eigen::Index i = 0; i < m.V.rows(); ++i)
      for (int a = 0; a < 3; ++a) {
        const double expect =
            w[0] * copies[0].V(i, a) + w[1] * copies[1].V(i, a) + w[2] * copies[2].V(i, a);
        worst = std::max(worst, std::abs(merged.V(i, a) - expect));
      }
    return worst;
  };
  const double tolerance = 4e-16 * scale;  // a few roundings of a sum of three products
  const Mesh equal = attack_collude(copies, {});
  EXPECT_LE(worst_gap(equal, {1.0 / 3, 1.0 / 3, 1.0 / 3}), tolerance);
  EXPECT_EQ(equal.F, m.F);
  const Mesh weighted = attack_collude(copies, {CollusionKind::Average, {3, 1, 0}});
  EXPECT_LE(worst_gap(weighted, {0.75, 0.25, 0}), tolerance);
  // Weights whose sum overflows double are the same weights.
  const Mesh huge = attack_collude(copies, {CollusionKind::Average, {1.5e308, 0.5e308, 0}});
  EXPECT_LE(worst_gap(huge, {0.75, 0.25, 0}), tolerance);

  const Mesh spliced = attack_collude(copies, {CollusionKind::Splice, {}}, 7);
  std::vector<int> from(static_cast<std::size_t>(m.V.rows()), -1);
  std::array<int, 3> count{};
  for (Eigen::Index i = 0; i < m.V.rows(); ++i) {
    int matches = 0;
    for (int j = 0; j < 3; ++j)
      if (spliced.V.row(i) == copies[j].V.row(i)) from[i] = j, ++matches;
    ASSERT_EQ(matches, 1) << "vertex " << i << " is not one copy's, exactly";
    ++count[from[i]];
  }
  for (int j = 0; j < 3; ++j)
    EXPECT_GT(count[j], m.V.rows() / 20) << "copy " << j + 1 << " pastes a region";
  int edges = 0, cut = 0;
  for (Eigen::Index f = 0; f < m.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      ++edges;
      cut += from[m.F(f, k)] != from[m.F(f, (k + 1) % 3)];
    }
  EXPECT_LT(cut, edges / 10) << "regions, not scattered vertices: " << cut << " of " << edges;
  EXPECT_EQ(attack_collude(copies, {CollusionKind::Splice, {}}, 7).V, spliced.V);
  EXPECT_NE(attack_collude(copies, {CollusionKind::Splice, {}}, 8).V, spliced.V);

  // What cannot be merged, or merged that way.
  // A copy read from a file is named (InvalidInputError, the CLI's bad input); one made in
  // memory is an argument error.
  Mesh fewer = copies[1];
  fewer.V.conservativeResize(fewer.V.rows() - 1, 3);
  fewer.source_path = "fewer.ply";
  Mesh flipped = copies[2];
  flipped.source_path.clear();
  std::swap(flipped.F(0, 0), flipped.F(0, 1));
  Mesh broken = copies[1];
  broken.V(5, 1) = NAN;
  const std::vector<std::pair<std::function<Mesh()>, std::string>> refused = {
      {[&] { return attack_collude({copies[0]}, {}); }, "at least 2 copies, got 1"},
      {[&] {
         return attack_collude({copies[0], fewer}, {});
       },
       "fewer.ply: copy 2 has 2929 vertices, copy 1"},
      {[&] {
         return attack_collude({copies[0], copies[1], flipped}, {});
       },
       "copy 3 has other faces than copy 1"},
      {[&] {
         return attack_collude({copies[0], broken}, {});
       },
       "copy 2: vertex 5 has a non-finite coordinate"},
      {[&] {
         return attack_collude(copies, {CollusionKind::Average, {1, 1}});
       },
       "2 collusion weights for 3 copies"},
      {[&] {
         return attack_collude(copies, {CollusionKind::Average, {1, -1, 1}});
       },
       "weight -1 of copy 2"},
      {[&] {
         return attack_collude(copies, {CollusionKind::Average, {1, NAN, 1}});
       },
       "of copy 2 is not a finite number"},
      {[&] {
         return attack_collude(copies, {CollusionKind::Average, {0, 0, 0}});
       },
       "sum to 0"},
      {[&] {
         return attack_collude(copies, {CollusionKind::Splice, {1, 1, 1}});
       },
       "not to a splice"}};
  for (const auto& [merge, expect] : refused) {
    try {
      (void)merge();
      ADD_FAILURE() << "accepted; expected: " << expect;
    } catch (const InvalidInputError& e) {
      EXPECT_NE(std::string(e.what()).find(expect), std::string::npos) << e.what();
      EXPECT_EQ(e.file(), "fewer.ply");
    } catch (const InvalidArgumentError& e) {
      EXPECT_NE(std::string(e.what()).find(expect), std::string::npos) << e.what();
    }
  }
}

// Unequal weights are flat Dirichlet: positive, summing to 1, reproducible for a seed, and each
// colluder's weight has mean 1/k and variance (k - 1) / (k^2 (k + 1)), checked over 20,000 seeds
// within 5 standard errors.
TEST(Attack, UnequalCollusionWeightsAreFlatDirichlet) {
  for (const int k : {2, 3, 5}) {
    const int n = 20000;
    double sum = 0, sum2 = 0;
    for (int s = 0; s < n; ++s) {
      const std::vector<double> w = random_collusion_weights(k, static_cast<std::uint64_t>(s));
      ASSERT_EQ(w.size(), static_cast<std::size_t>(k));
      EXPECT_NEAR(std::accumulate(w.begin(), w.end(), 0.0), 1.0, 1e-12);
      for (const double x : w) ASSERT_GT(x, 0);
      sum += w[0], sum2 += w[0] * w[0];
    }
    EXPECT_EQ(random_collusion_weights(k, 9), random_collusion_weights(k, 9));
    const double mean = sum / n, var = sum2 / n - mean * mean;
    const double expect_var = (k - 1.0) / (k * k * (k + 1.0));
    EXPECT_NEAR(mean, 1.0 / k, 5 * std::sqrt(expect_var / n)) << k;
    // The variance of a sample variance is about (m4 - var^2) / n, and m4 <= 4 var^2 for
    // w[0] ~ Beta(1, k - 1), k <= 5 (its kurtosis is 3.7 at k = 5).
    EXPECT_NEAR(var, expect_var, 5 * std::sqrt(3 * expect_var * expect_var / n)) << k;
  }
}

TEST(Attack, QuantizedPointsLieOnTheGrid) {
  const std::string path = closed_binary_ply();
  MESHMARK_REQUIRE(path, "bunny00.off");
  const Mesh m = real(path);
  for (int bits : {7, 10, 12}) {
    const Mesh q = attack_quantize(m, bits);
    for (int a = 0; a < 3; ++a) {
      const double lo = m.V.col(a).minCoeff(), hi = m.V.col(a).maxCoeff();
      const double step = (hi - lo) / (std::pow(2.0, bits) - 1);
      std::set<long> levels;
      for (Eigen::Index i = 0; i < q.V.rows(); ++i) {
        const double k = (q.V(i, a) - lo) / step;
        EXPECT_NEAR(k, std::round(k), 1e-6);
        EXPECT_LE(std::abs(q.V(i, a) - m.V(i, a)), 0.5 * step * (1 + 1e-9));
        levels.insert(std::lround(k));
      }
      EXPECT_LE(levels.size(), std::size_t{1} << bits);
    }
  }
}

TEST(Attack, SimplificationReachesTheFaceTargetWithinOnePercent) {
  for (const std::string& path :
       {closed_binary_ply(), data_mesh("bunny.ply"), cgal_mesh("fandisk.off")}) {
    if (path.empty()) continue;
    SCOPED_TRACE(path);
    const Mesh m = real(path);
    for (const SimplifyCost cost : {SimplifyCost::LindstromTurk, SimplifyCost::GarlandHeckbert})
      for (double ratio : {0.7, 0.3, 0.1}) {
        const Mesh s = attack_simplify(m, ratio, cost);
        const double target = ratio * static_cast<double>(m.F.rows());
        EXPECT_NEAR(static_cast<double>(s.F.rows()), target, 0.01 * target) << ratio;
        EXPECT_LT(s.V.rows(), m.V.rows());
      }
  }
}

// Isotropic remeshing: every vertex on the input surface (the distance to it computed by the
// closest-point index, to 1e-6 of the diagonal), the mean edge length within 20 % of the
// target, and a new sampling (not the input's vertices).
TEST(Attack, RemeshingKeepsTheSurfaceAndReachesTheEdgeLength) {
  for (const std::string& path : {data_mesh("bunny.ply"), cgal_mesh("fandisk.off")}) {
    if (path.empty()) continue;
    SCOPED_TRACE(path);
    const Mesh m = real(path);
    auto mean_edge = [](const Mesh& mesh) {
      double sum = 0;
      for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
        for (int k = 0; k < 3; ++k)
          sum += (mesh.V.row(mesh.F(f, k)) - mesh.V.row(mesh.F(f, (k + 1) % 3))).norm();
      return sum / (3.0 * static_cast<double>(mesh.F.rows()));
    };
    const double diagonal = (m.V.colwise().maxCoeff() - m.V.colwise().minCoeff()).norm();
    for (const double factor : {1.0, 2.0}) {
      const Mesh r = attack_remesh(m, factor);
      ASSERT_GT(r.F.rows(), 0);
      const ClosestPoints cp = closest_points(m.V, m.F, r.V);
      EXPECT_LT(cp.distance.maxCoeff(), 1e-6 * diagonal) << factor;
      EXPECT_NEAR(mean_edge(r), factor * mean_edge(m), 0.2 * factor * mean_edge(m)) << factor;
      std::set<std::array<double, 3>> before;
      for (Eigen::Index i = 0; i < m.V.rows(); ++i)
        before.insert({m.V(i, 0), m.V(i, 1), m.V(i, 2)});
      Eigen::Index kept = 0;
      for (Eigen::Index i = 0; i < r.V.rows(); ++i)
        kept += before.count({r.V(i, 0), r.V(i, 1), r.V(i, 2)});
      EXPECT_LT(kept, r.V.rows() / 2) << "most vertices should be new";
    }
  }
  EXPECT_THROW(attack_remesh(Mesh{}, 0.01), InvalidArgumentError);
}

TEST(Attack, SubdivisionVertexAndFaceCountsOnAClosedMesh) {
  const std::string path = closed_binary_ply();
  MESHMARK_REQUIRE(path, "bunny00.off");
  const Mesh m = real(path);
  ASSERT_TRUE(closed_two_manifold_edges(m.F)) << "the horse is expected to be closed";
  const auto V = static_cast<std::size_t>(m.V.rows()), F = static_cast<std::size_t>(m.F.rows());
  const std::size_t E = undirected_edges(m.F);
  const Mesh loop = attack_subdivide(m, Subdivision::Loop, 1);
  EXPECT_EQ(static_cast<std::size_t>(loop.V.rows()), V + E);
  EXPECT_EQ(static_cast<std::size_t>(loop.F.rows()), 4 * F);
  const Mesh mid = attack_subdivide(m, Subdivision::Midpoint, 1);
  EXPECT_EQ(static_cast<std::size_t>(mid.V.rows()), V + E);
  EXPECT_EQ(static_cast<std::size_t>(mid.F.rows()), 4 * F);
  // Midpoint subdivision keeps the old vertices and puts the new ones on the old edges.
  EXPECT_EQ(Eigen::MatrixX3d(mid.V.topRows(m.V.rows())), m.V);
  const Mesh s3 = attack_subdivide(m, Subdivision::Sqrt3, 1);
  EXPECT_EQ(static_cast<std::size_t>(s3.V.rows()), V + F);
  EXPECT_EQ(static_cast<std::size_t>(s3.F.rows()), 3 * F);
  const Mesh loop2 = attack_subdivide(m, Subdivision::Loop, 2);
  EXPECT_EQ(static_cast<std::size_t>(loop2.F.rows()), 16 * F);
}

// What a progress callback hears. Records every report and checks that each phase's counts never
// go back and never pass its total.
struct Heard {
  std::vector<std::tuple<std::string, long, long>> reports;
  ProgressCallback callback() {
    return [this](const std::string& phase, long done, long total, const std::string&) {
      reports.emplace_back(phase, done, total);
    };
  }
  std::vector<std::string> phases() const {
    std::vector<std::string> out;
    for (const auto& [phase, done, total] : reports)
      if (out.empty() || out.back() != phase) out.push_back(phase);
    return out;
  }
  // The reports of one phase, checked to count up from 0 to at most their total.
  std::vector<long> counts(const std::string& phase, long& total) const {
    std::vector<long> done;
    total = -1;
    for (const auto& [p, d, t] : reports) {
      if (p != phase) continue;
      EXPECT_TRUE(total < 0 || t == total) << phase << ": the total changed";
      EXPECT_TRUE(done.empty() ? d == 0 : d >= done.back()) << phase << ": went back to " << d;
      EXPECT_LE(d, t) << phase;
      total = t, done.push_back(d);
    }
    return done;
  }
};

// Simplification reports its collapses: the faces removed of the faces to remove (the input's
// triangles less the target, round(ratio x triangles), counted here), at least every 4,097
// faces, up to the total; and it ends with the same mesh as without a callback.
TEST(Attack, SimplificationReportsItsCollapsesAndEndsWhereItWouldWithout) {
  const std::string path = cgal_mesh("refined_elephant.off");
  MESHMARK_REQUIRE(path, "refined_elephant.off");
  const Mesh m = real(path);
  for (const SimplifyCost cost : {SimplifyCost::LindstromTurk, SimplifyCost::GarlandHeckbert}) {
    Heard heard;
    const Mesh reported = attack_simplify(m, 0.3, cost, heard.callback());
    const Mesh plain = attack_simplify(m, 0.3, cost);
    EXPECT_TRUE(reported.V == plain.V);
    EXPECT_TRUE(reported.F == plain.F);
    EXPECT_EQ(heard.phases(), (std::vector<std::string>{"preparing the mesh", "collapsing edges"}));
    long total = 0;
    EXPECT_EQ(heard.counts("preparing the mesh", total), (std::vector<long>{0, 1}));
    const std::vector<long> done = heard.counts("collapsing edges", total);
    const long faces = static_cast<long>(m.F.rows());
    EXPECT_EQ(total, faces - std::lround(0.3 * static_cast<double>(faces)));
    ASSERT_FALSE(done.empty());
    EXPECT_EQ(done.back(), total);
    for (std::size_t k = 1; k < done.size(); ++k) EXPECT_LE(done[k] - done[k - 1], 4097);
    EXPECT_GE(faces - static_cast<long>(plain.F.rows()), total);
  }
}

// Subdivision one step at a time, for progress, gives the mesh CGAL's number_of_iterations gives
// (sqrt(3) refines the border on odd steps only: an open mesh over three steps shows it).
TEST(Attack, SubdivisionReportsEachIterationAndGivesTheSameMesh) {
  const std::string path = data_mesh("bunny.ply");
  MESHMARK_REQUIRE(path, "data/meshes/bunny.ply");
  const Mesh m = real(path);
  for (const Subdivision s : {Subdivision::Loop, Subdivision::Sqrt3, Subdivision::Midpoint}) {
    const int iterations = s == Subdivision::Loop ? 2 : 3;
    Heard heard;
    const Mesh reported = attack_subdivide(m, s, iterations, heard.callback());
    const Mesh plain = attack_subdivide(m, s, iterations);
    EXPECT_TRUE(reported.V == plain.V) << static_cast<int>(s);
    EXPECT_TRUE(reported.F == plain.F) << static_cast<int>(s);
    long total = 0;
    std::vector<long> expected(static_cast<std::size_t>(iterations) + 1);
    std::iota(expected.begin(), expected.end(), 0L);
    EXPECT_EQ(heard.counts("subdividing", total), expected);
    EXPECT_EQ(total, iterations);
  }
}

// A chain names its steps in their phases; a step that reports nothing is one phase of its own.
TEST(Attack, AChainNamesEachStepInItsPhases) {
  const std::string path = data_mesh("bunny.ply");
  MESHMARK_REQUIRE(path, "data/meshes/bunny.ply");
  const Mesh m = real(path);
  const std::vector<AttackStep> steps = parse_attack_chain("noise:0.001,simplify:0.5");
  Heard heard;
  const Mesh reported = apply_attack_chain(m, steps, 5, heard.callback());
  const Mesh plain = apply_attack_chain(m, steps, 5);
  EXPECT_TRUE(reported.V == plain.V);
  EXPECT_TRUE(reported.F == plain.F);
  EXPECT_EQ(heard.phases(), (std::vector<std::string>{"step 1 of 2: noise", "step 2 of 2: simplify",
                                                      "step 2 of 2: preparing the mesh",
                                                      "step 2 of 2: collapsing edges"}));
  long total = 0;
  EXPECT_EQ(heard.counts("step 1 of 2: noise", total), (std::vector<long>{0, 1}));
  EXPECT_EQ(heard.counts("step 2 of 2: simplify", total), (std::vector<long>{0}));
  Heard alone;
  (void)apply_attack(m, steps[1], 5, alone.callback());
  EXPECT_EQ(alone.phases(),
            (std::vector<std::string>{"simplify", "preparing the mesh", "collapsing edges"}));
}

TEST(Attack, SubdivisionHandlesOpenAndNonManifoldMeshes) {
  for (const std::string& path :
       {data_mesh("bunny.ply"), data_mesh("bunny.ply"), cgal_mesh("mech-holes-shark.off")}) {
    if (path.empty()) continue;
    const Mesh m = real(path);
    for (Subdivision s : {Subdivision::Loop, Subdivision::Sqrt3, Subdivision::Midpoint}) {
      const Mesh d = attack_subdivide(m, s, 1);
      EXPECT_GT(d.F.rows(), 2 * m.F.rows() * 9 / 10) << path;
      EXPECT_TRUE(d.V.allFinite());
      // Subdivision smooths but does not move the surface far: the bounding box stays.
      EXPECT_LE((d.V.colwise().maxCoeff() - m.V.colwise().maxCoeff()).norm(), 0.05 * diagonal(m.V));
    }
  }
}

TEST(Attack, CroppingRemovesTheAskedFraction) {
  const std::string path = data_mesh("bunny.ply");
  MESHMARK_REQUIRE(path, "bunny.ply");
  const Mesh m = real(path);
  const auto used = referenced_vertices(m.F, m.V.rows());
  const auto n_ref = std::count(used.begin(), used.end(), 1);
  for (double fraction : {0.05, 0.2, 0.5}) {
    const Mesh c = attack_crop(m, fraction, 11);
    EXPECT_EQ(m.V.rows() - c.V.rows(), std::llround(fraction * static_cast<double>(n_ref)));
    for (Eigen::Index t = 0; t < c.F.rows(); ++t) EXPECT_LT(c.F.row(t).maxCoeff(), c.V.rows());
  }
}

TEST(Attack, TriangleSoupHasThreeVerticesPerFaceAndScaledEdges) {
  const std::string path = data_mesh("spot.obj");
  MESHMARK_REQUIRE(path, "spot.obj");
  const Mesh m = real(path);
  const double ratio = 0.8, A = 1e-4 * diagonal(m.V);
  const Mesh s = attack_triangle_soup(m, ratio, 3);
  ASSERT_EQ(s.F.rows(), m.F.rows());
  EXPECT_EQ(s.V.rows(), 3 * m.F.rows());
  std::set<int> seen;
  for (Eigen::Index t = 0; t < s.F.rows(); ++t)
    for (int c = 0; c < 3; ++c)
      EXPECT_TRUE(seen.insert(s.F(t, c)).second) << "vertices are not shared";
  for (Eigen::Index t = 0; t < m.F.rows(); ++t)
    for (int c = 0; c < 3; ++c) {
      const double before = (m.V.row(m.F(t, c)) - m.V.row(m.F(t, (c + 1) % 3))).norm();
      const double after = (s.V.row(s.F(t, c)) - s.V.row(s.F(t, (c + 1) % 3))).norm();
      EXPECT_NEAR(after, ratio * before, 2 * std::sqrt(3.0) * A);
    }
}

TEST(Attack, LaplacianSmoothingStepMatchesAHandComputation) {
  const Mesh m = bumpy_sphere(6, 8, 4);
  const Mesh s = attack_smooth_laplacian(m, 1, 0.3);
  std::vector<std::set<int>> ring(m.V.rows());
  for (Eigen::Index t = 0; t < m.F.rows(); ++t)
    for (int c = 0; c < 3; ++c) {
      ring[m.F(t, c)].insert(m.F(t, (c + 1) % 3));
      ring[m.F(t, (c + 1) % 3)].insert(m.F(t, c));
    }
  for (Eigen::Index i = 0; i < m.V.rows(); ++i) {
    Eigen::RowVector3d mean = Eigen::RowVector3d::Zero();
    for (int j : ring[i]) mean += m.V.row(j) / static_cast<double>(ring[i].size());
    EXPECT_LE((s.V.row(i) - (m.V.row(i) + 0.3 * (mean - m.V.row(i)))).norm(), 1e-14);
  }
}

TEST(Attack, FixedBoundaryVerticesStayAndTheOthersMove) {
  const int n = 9;
  const Mesh m = bumpy_grid(n);
  const std::vector<std::uint8_t> boundary = boundary_vertices(m.F, m.V.rows());
  for (int i = 0; i < n * n; ++i) EXPECT_EQ(boundary[i] != 0, on_grid_border(i, n)) << i;
  LaplacianOptions fixed;
  fixed.lambda = 0.03;
  fixed.fixed_boundary = true;
  TaubinOptions taubin;
  taubin.fixed_boundary = true;
  taubin.weighting = SmoothWeighting::InverseDistance;
  for (const Mesh& s : {attack_smooth_laplacian(m, 50, fixed), attack_smooth_taubin(m, 10, taubin)})
    for (int i = 0; i < n * n; ++i) {
      if (on_grid_border(i, n))
        EXPECT_EQ(s.V.row(i), m.V.row(i)) << i;
      else
        EXPECT_GT((s.V.row(i) - m.V.row(i)).norm(), 1e-6) << i;
    }
  // Without the option the boundary moves too (a corner toward its two neighbours).
  EXPECT_GT((attack_smooth_laplacian(m, 1, 0.03).V.row(0) - m.V.row(0)).norm(), 1e-3);
}

TEST(Attack, LambdaScalesTheFirstStepAndTheBenchmarksIsTenTimesWeaker) {
  const Mesh m = bumpy_sphere(6, 8, 4);
  std::vector<std::set<int>> ring(m.V.rows());
  for (Eigen::Index t = 0; t < m.F.rows(); ++t)
    for (int c = 0; c < 3; ++c) {
      ring[m.F(t, c)].insert(m.F(t, (c + 1) % 3));
      ring[m.F(t, (c + 1) % 3)].insert(m.F(t, c));
    }
  AttackStep benchmark{"smooth", 1, {}}, paper{"smooth", 1, {}};
  benchmark.params.lambda = 0.03;
  const Mesh a = apply_attack(m, benchmark, 1), b = apply_attack(m, paper, 1);
  for (Eigen::Index i = 0; i < m.V.rows(); ++i) {
    Eigen::RowVector3d mean = Eigen::RowVector3d::Zero();
    for (int j : ring[i]) mean += m.V.row(j) / static_cast<double>(ring[i].size());
    EXPECT_LE((a.V.row(i) - (m.V.row(i) + 0.03 * (mean - m.V.row(i)))).norm(), 1e-14);
    EXPECT_NEAR((a.V.row(i) - m.V.row(i)).norm(), 0.1 * (b.V.row(i) - m.V.row(i)).norm(), 1e-14);
  }
}

TEST(Attack, InverseDistanceTaubinMatchesAHandComputedIteration) {
  // A fan: centre 0 and four boundary vertices at distances 2, 1, 1 and sqrt(2) (fixed).
  Eigen::MatrixX3d V(5, 3);
  V << 0, 0, 0.5, 2, 0, 0, 0, 1, 0, -1, 0, 0, 1, -1, 0;
  Eigen::MatrixX3i F(4, 3);
  F << 0, 1, 2, 0, 2, 3, 0, 3, 4, 0, 4, 1;
  const Mesh m = make_mesh(V, F);
  TaubinOptions o;
  o.lambda = 0.5;
  o.mu = -0.53;
  o.fixed_boundary = true;
  o.weighting = SmoothWeighting::InverseDistance;
  // By hand: p += f (sum_j w_j p_j / sum_j w_j - p), w_j = 1 / |p_j - p|, with f = lambda,
  // then again with f = mu from the new centre.
  auto step = [&](Eigen::RowVector3d p, double f) {
    Eigen::RowVector3d sum = Eigen::RowVector3d::Zero();
    double total = 0;
    for (int j = 1; j < 5; ++j) {
      const double w = 1 / (std::sqrt((V.row(j) - p).squaredNorm()) + 1e-12);
      sum += w * V.row(j), total += w;
    }
    return Eigen::RowVector3d(p + f * (sum / total - p));
  };
  const Eigen::RowVector3d expect = step(step(V.row(0), 0.5), -0.53);
  const Mesh s = attack_smooth_taubin(m, 1, o);
  EXPECT_LE((s.V.row(0) - expect).norm(), 1e-15);
  for (int j = 1; j < 5; ++j) EXPECT_EQ(s.V.row(j), V.row(j));
  // Uniform weights give another point (the far vertex weighs as much as the near ones).
  o.weighting = SmoothWeighting::Uniform;
  EXPECT_GT((attack_smooth_taubin(m, 1, o).V.row(0) - expect).norm(), 1e-3);
}

TEST(Attack, BenchmarkQuantizationStepIsTheRangeOverTwoToTheBits) {
  // x spans [0, 8]: 3 bits give step 1 (benchmark) or 8/7 (levels).
  Eigen::MatrixX3d V(6, 3);
  V << 0, 0, 0, 8, 1, 1, 2.5, 0.5, 0.25, 2.6, 0.2, 0.7, 7.4, 0.9, 0.1, 3.49, 0.3, 0.6;
  const Mesh m = make_mesh(V, Eigen::MatrixX3i(0, 3));
  const Mesh b = attack_quantize(m, 3, QuantizeConvention::Benchmark);
  const Mesh l = attack_quantize(m, 3);
  const double expect_b[] = {0, 8, 2, 3, 7, 3};  // a tie (2.5) goes down, as in MEPP
  for (int i = 0; i < 6; ++i) {
    EXPECT_DOUBLE_EQ(b.V(i, 0), expect_b[i]) << i;
    EXPECT_NEAR(l.V(i, 0), std::round(V(i, 0) / (8.0 / 7)) * (8.0 / 7), 1e-12) << i;
  }
  // On a real mesh: every coordinate within half a step of the input, on the grid.
  const std::string path = data_mesh("bunny.ply");
  MESHMARK_REQUIRE(path, "bunny.ply");
  const Mesh r = real(path);
  const Mesh q = attack_quantize(r, 9, QuantizeConvention::Benchmark);
  for (int c = 0; c < 3; ++c) {
    const double lo = r.V.col(c).minCoeff(), step = (r.V.col(c).maxCoeff() - lo) / 512;
    for (Eigen::Index i = 0; i < r.V.rows(); ++i) {
      const double k = (q.V(i, c) - lo) / step;
      EXPECT_NEAR(k, std::round(k), 1e-6);
      EXPECT_LE(std::abs(q.V(i, c) - r.V(i, c)), 0.5 * step * (1 + 1e-9));
    }
  }
}

// Each parameter, given to each kind: refused by the kinds the registry says do not read it,
// and changing the result of those it says do (on the bunny, whose holes give a boundary).
TEST(Attack, EveryKindReadsExactlyTheParametersTheRegistryNames) {
  const std::string path = data_mesh("bunny.ply");
  MESHMARK_REQUIRE(path, "bunny.ply");
  const Mesh m = real(path);
  const std::vector<std::uint8_t> boundary = boundary_vertices(m.F, m.V.rows());
  ASSERT_GT(std::count(boundary.begin(), boundary.end(), 1), 0);
  const std::pair<unsigned, std::function<void(AttackParams&)>> params[] = {
      {kReadsLambda, [](AttackParams& p) { p.lambda = 0.1; }},
      {kReadsMu, [](AttackParams& p) { p.mu = -0.2; }},
      {kReadsFixedBoundary, [](AttackParams& p) { p.fixed_boundary = true; }},
      {kReadsWeighting, [](AttackParams& p) { p.weighting = SmoothWeighting::InverseDistance; }},
      {kReadsConvention, [](AttackParams& p) { p.convention = QuantizeConvention::Benchmark; }},
  };
  int read = 0;
  for (const AttackKind& kind : attack_registry())
    for (const auto& [bit, set] : params) {
      SCOPED_TRACE(fmt::format("{} bit {}", kind.name, bit));
      AttackStep step{kind.name, test_strength(kind.name)};
      set(step.params);
      if (!(kind.params & bit)) {
        EXPECT_THROW(apply_attack(m, step, 5), InvalidArgumentError);
        continue;
      }
      ++read;
      const AttackStep plain{kind.name, step.strength};
      EXPECT_NE(apply_attack(m, step, 5).V, apply_attack(m, plain, 5).V);
    }
  EXPECT_EQ(read, 8);  // smooth: 3 parameters; taubin: 4; quant: 1
}

// The kinds with a levels function give, from one run, what apply gives at each strength.
TEST(Attack, LevelsOfAKindAreItsSingleRuns) {
  const std::string path = cgal_mesh("elephant.off");
  MESHMARK_REQUIRE(path, "elephant.off");
  const Mesh m = real(path);
  int kinds = 0;
  for (const AttackKind& kind : attack_registry()) {
    if (!kind.levels) continue;
    SCOPED_TRACE(kind.name);
    ++kinds;
    const std::vector<double> ratios = {0.7, 0.4};
    const std::vector<Mesh> levels = kind.levels(m, ratios);
    ASSERT_EQ(levels.size(), ratios.size());
    for (std::size_t k = 0; k < ratios.size(); ++k)
      EXPECT_EQ(ply_bytes(levels[k]), ply_bytes(apply_attack(m, {kind.name, ratios[k]}, 1)));
  }
  EXPECT_EQ(kinds, 2);  // simplify and qsimplify
}

TEST(Attack, ParametersGoToTheStepsThatReadThemAndNowhereElse) {
  AttackParams p;
  EXPECT_TRUE(attack_params_default(p));
  p.lambda = 0.03;
  p.fixed_boundary = true;
  EXPECT_EQ(attack_params_label(p), "lambda=0.03 fixed_boundary");
  std::vector<AttackStep> steps = parse_attack_chain("noise:0.001,smooth:5");
  set_chain_params(steps, p);
  EXPECT_TRUE(attack_params_default(steps[0].params));
  EXPECT_EQ(steps[1].params.lambda, 0.03);
  EXPECT_TRUE(steps[1].params.fixed_boundary);
  AttackParams q;
  q.convention = QuantizeConvention::Benchmark;
  EXPECT_THROW(set_chain_params(steps, q), InvalidArgumentError);  // no quant step
  AttackParams mu;
  mu.mu = -0.5;
  EXPECT_THROW(set_chain_params(steps, mu), InvalidArgumentError);  // no taubin step
  AttackStep noise{"noise", 0.001, p};
  EXPECT_THROW(apply_attack(bumpy_sphere(5, 5, 1), noise, 1), InvalidArgumentError);
  EXPECT_EQ(parse_smooth_weighting("inverse-distance"), SmoothWeighting::InverseDistance);
  EXPECT_EQ(parse_quantize_convention("benchmark"), QuantizeConvention::Benchmark);
  EXPECT_THROW(parse_smooth_weighting("cotangent"), InvalidArgumentError);
  EXPECT_THROW(parse_quantize_convention("2^b"), InvalidArgumentError);
}

TEST(Attack, TaubinShrinksLessThanLaplacian) {
  const std::string path = closed_binary_ply();
  MESHMARK_REQUIRE(path, "bunny00.off");
  const Mesh m = real(path);
  const double d0 = diagonal(m.V);
  const double lap = diagonal(attack_smooth_laplacian(m, 20, 0.5).V),
               tau = diagonal(attack_smooth_taubin(m, 10).V);
  EXPECT_LT(lap, d0);
  EXPECT_LT(std::abs(tau - d0), std::abs(lap - d0));
}

TEST(Attack, Float32StorageRoundsToFloat) {
  const Mesh m = bumpy_sphere(9, 9, 1);
  const Mesh f = attack_format(m, "ply", true);
  EXPECT_EQ(f.V, Eigen::MatrixX3d(m.V.cast<float>().cast<double>()));
  EXPECT_NE(f.V, m.V);
}

// Every kind of the registry: one seed gives the same bytes twice, and another seed gives other
// bytes exactly when the registry calls the kind seeded.
TEST(Attack, SameSeedSameBytesForEveryKindAndSeededKindsVary) {
  const std::string path = data_mesh("bunny.ply");
  MESHMARK_REQUIRE(path, "bunny.ply");
  const Mesh m = real(path);
  for (const AttackKind& kind : attack_registry()) {
    SCOPED_TRACE(kind.name);
    const AttackStep step{kind.name, test_strength(kind.name)};
    const Mesh a = apply_attack(m, step, 77), b = apply_attack(m, step, 77);
    EXPECT_EQ(ply_bytes(a), ply_bytes(b));
    EXPECT_EQ(ply_bytes(apply_attack(m, step, 78)) != ply_bytes(a), kind.seeded);
    EXPECT_EQ(attack_chain_is_deterministic(kind.name), !kind.seeded);
    EXPECT_EQ(find_attack_kind(kind.name), &kind);
  }
  EXPECT_NE(attack_noise(m, 0.001, NoiseReference::Diagonal, 1).V,
            attack_noise(m, 0.001, NoiseReference::Diagonal, 2).V);
}

TEST(Attack, ChainsParseAndApplyInOrder) {
  const Mesh m = bumpy_sphere(12, 12, 2);
  const auto steps = parse_attack_chain("noise:0.001,quant:10");
  ASSERT_EQ(steps.size(), 2u);
  EXPECT_EQ(steps[0].kind, "noise");
  EXPECT_DOUBLE_EQ(steps[1].strength, 10);
  const Mesh a = apply_attack_chain(m, steps, 5);
  // Quantization came last: every coordinate is on the 10-bit grid of the noisy mesh's box.
  for (int c = 0; c < 3; ++c) {
    const double lo = a.V.col(c).minCoeff(), step = (a.V.col(c).maxCoeff() - lo) / 1023;
    for (Eigen::Index i = 0; i < a.V.rows(); ++i) {
      const double k = (a.V(i, c) - lo) / step;
      EXPECT_NEAR(k, std::round(k), 1e-6);
    }
  }
  EXPECT_THROW(parse_attack_chain("noise:0.1,blur:3"), InvalidArgumentError);
  EXPECT_THROW(parse_attack_chain("noise:abc"), InvalidArgumentError);
  EXPECT_THROW(attack_simplify(m, 1.5), InvalidArgumentError);
  EXPECT_THROW(attack_quantize(m, 0), InvalidArgumentError);
}

// Simplification and subdivision on meshes with degenerate faces (issue 13, item 7): a face
// with a repeated corner, corners at one position or collinear corners is no surface, so the
// attack must give what it gives without that face. Each case runs in a child process whose
// address space is capped, so that a regression (CGAL looping around an edge from a vertex to
// itself until memory runs out, or crashing) fails the test instead of exhausting the machine.

namespace {

// A mesh plus one degenerate face of a given kind, made around its first face (a, b, c).
using Degenerate = std::function<Mesh(const Mesh&)>;

// m with extra vertices appended and one more face (no file image).
Mesh with(const Mesh& m, const std::vector<Eigen::RowVector3d>& extra_vertices,
          const Eigen::RowVector3i& face) {
  Eigen::MatrixX3d V(m.V.rows() + static_cast<Eigen::Index>(extra_vertices.size()), 3);
  V.topRows(m.V.rows()) = m.V;
  for (std::size_t k = 0; k < extra_vertices.size(); ++k)
    V.row(m.V.rows() + static_cast<Eigen::Index>(k)) = extra_vertices[k];
  Eigen::MatrixX3i F(m.F.rows() + 1, 3);
  F.topRows(m.F.rows()) = m.F;
  F.row(m.F.rows()) = face;
  return make_mesh(std::move(V), std::move(F));
}

const std::vector<std::pair<std::string, Degenerate>>& degenerate_cases() {
  static const std::vector<std::pair<std::string, Degenerate>> cases = {
      {"face (0, 0, 1)",
       [](const Mesh& m) {
         return with(m, {}, {0, 0, 1});
       }},
      {"face (0, 0, 0)",
       [](const Mesh& m) {
         return with(m, {}, {0, 0, 0});
       }},
      {"face (a, b, a)",
       [](const Mesh& m) {
         return with(m, {}, {m.F(0, 0), m.F(0, 1), m.F(0, 0)});
       }},
      {"three new corners at one position",
       [](const Mesh& m) {
         const int n = static_cast<int>(m.V.rows());
         const Eigen::RowVector3d p = m.V.row(m.F(0, 0));
         return with(m, {p, p, p}, {n, n + 1, n + 2});
       }},
      {"a new corner at an existing corner's position",
       [](const Mesh& m) {
         const int n = static_cast<int>(m.V.rows());
         return with(m, {m.V.row(m.F(0, 0))}, {n, m.F(0, 0), m.F(0, 1)});
       }},
      {"collinear corners (zero area)",
       [](const Mesh& m) {
         // On a line parallel to the x axis: y and z equal, so exactly collinear.
         const int n = static_cast<int>(m.V.rows()), a = m.F(0, 0);
         const Eigen::RowVector3d p = m.V.row(a);
         return with(m, {p + Eigen::RowVector3d(1, 0, 0), p + Eigen::RowVector3d(3, 0, 0)},
                     {a, n + 1, n});
       }},
  };
  return cases;
}

// Every face has three distinct corners at distinct, non-collinear positions.
bool all_faces_proper(const Mesh& m) {
  for (Eigen::Index t = 0; t < m.F.rows(); ++t) {
    const Eigen::Vector3d a = m.V.row(m.F(t, 0)), b = m.V.row(m.F(t, 1)), c = m.V.row(m.F(t, 2));
    if ((b - a).cross(c - a).norm() == 0) return false;
  }
  return m.V.allFinite();
}

// What must hold for one attack of a closed mesh m and of m plus a degenerate face d: the
// same result, with the counts the attack gives a closed triangle mesh (V, E, F of m). Returns
// "" or what failed.
std::string check(const std::string& attack, const Mesh& m, const Mesh& d) {
  const auto nv = static_cast<std::size_t>(m.V.rows()), nf = static_cast<std::size_t>(m.F.rows());
  const std::size_t ne = undirected_edges(m.F);
  auto run = [&](const Mesh& x) {
    if (attack == "loop") return attack_subdivide(x, Subdivision::Loop, 1);
    if (attack == "sqrt3") return attack_subdivide(x, Subdivision::Sqrt3, 1);
    return attack_simplify(x, 0.5);
  };
  const Mesh a = run(m), b = run(d);
  const auto av = static_cast<std::size_t>(a.V.rows()), af = static_cast<std::size_t>(a.F.rows());
  if (attack == "loop" && (av != nv + ne || af != 4 * nf)) return "Loop counts";
  if (attack == "sqrt3" && (av != nv + nf || af != 3 * nf)) return "sqrt(3) counts";
  if (attack == "simplify" && std::abs(static_cast<double>(af) - 0.5 * static_cast<double>(nf)) >
                                  0.01 * static_cast<double>(nf))
    return "simplification face count";
  if (!all_faces_proper(b)) return "a degenerate face or a non-finite position in the output";
  if (a.V != b.V || a.F != b.F) return "the degenerate face changed the result";
  return "";
}

// The child's body: caps the address space at 3 GB, checks, exits 0 when the check holds.
[[noreturn]] void check_capped(const std::string& attack, const Mesh& m, const Mesh& d) {
#if !defined(__SANITIZE_ADDRESS__)  // AddressSanitizer's shadow memory needs terabytes of space
  const rlim_t cap = rlim_t{3} << 30;
  const rlimit limit{cap, cap};
  setrlimit(RLIMIT_AS, &limit);
#endif
  const std::string failed = check(attack, m, d);
  if (!failed.empty()) std::fprintf(stderr, "%s\n", failed.c_str());
  std::exit(failed.empty() ? 0 : 1);
}

// Runs check in a child process, so that a runaway allocation or a crash fails only it.
void expect_in_capped_child(const std::string& attack, const Mesh& m, const Mesh& d) {
  EXPECT_EXIT(check_capped(attack, m, d), ::testing::ExitedWithCode(0), "") << attack;
}

}  // namespace

TEST(AttackDegenerate, DegenerateFacesChangeNothingOnAGeneratedClosedMesh) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  const Mesh m = bumpy_sphere(16, 20, 3);
  ASSERT_TRUE(closed_two_manifold_edges(m.F));
  for (const auto& [name, add] : degenerate_cases()) {
    SCOPED_TRACE(name);
    const Mesh d = add(m);
    for (const char* attack : {"loop", "sqrt3", "simplify"}) expect_in_capped_child(attack, m, d);
  }
}

TEST(AttackDegenerate, ClosedMeshPlusFace001AsReported) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  const std::string path = closed_binary_ply();
  MESHMARK_REQUIRE(path, "bunny00.off");
  const Mesh m = read_mesh(path);
  ASSERT_TRUE(closed_two_manifold_edges(m.F));
  const Mesh d = with(m, {}, {0, 0, 1});
  for (const char* attack : {"loop", "sqrt3", "simplify"}) expect_in_capped_child(attack, m, d);
}

TEST(AttackDegenerate, NoFaceOfNonZeroAreaIsANamedError) {
  Eigen::MatrixX3d V(3, 3);
  V << 0, 0, 0, 1, 0, 0, 2, 0, 0;
  Eigen::MatrixX3i F(2, 3);
  F << 0, 1, 2, 0, 0, 1;
  const Mesh m = make_mesh(V, F);
  EXPECT_THROW(attack_simplify(m, 0.5), InvalidInputError);
  EXPECT_THROW(attack_subdivide(m, Subdivision::Loop, 1), InvalidInputError);
  EXPECT_THROW(attack_subdivide(m, Subdivision::Sqrt3, 1), InvalidInputError);
}

// Levels of detail from one run: each level is the mesh a run stopping at its ratio returns,
// exactly (the same collapses; attack_simplify stops on its own predicate, without copies).
TEST(Attack, SimplificationLevelsFromOneRunEqualSeparateRuns) {
  int meshes = 0;
  for (const std::string& path : {data_mesh("bunny.ply"), cgal_mesh("fandisk.off")}) {
    if (path.empty()) continue;
    SCOPED_TRACE(path);
    ++meshes;
    const Mesh m = real(path);
    const std::vector<double> ratios = {0.5, 0.9, 0.1, 0.3, 0.7};  // any order
    for (const SimplifyCost cost : {SimplifyCost::LindstromTurk, SimplifyCost::GarlandHeckbert}) {
      const std::vector<Mesh> levels = attack_simplify_levels(m, ratios, cost);
      ASSERT_EQ(levels.size(), ratios.size());
      for (std::size_t k = 0; k < ratios.size(); ++k) {
        const Mesh one = attack_simplify(m, ratios[k], cost);
        EXPECT_TRUE(levels[k].V == one.V) << ratios[k];
        EXPECT_TRUE(levels[k].F == one.F) << ratios[k];
      }
    }
  }
  if (meshes == 0)
    GTEST_FAIL() << "no real mesh available (data/meshes, libcgal-demo: scripts/setup.sh)";
}
