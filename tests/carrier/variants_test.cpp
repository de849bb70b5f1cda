// Every one of the 27 variants on real meshes, closed and open; and the Laplacian cost's
// optimum against Ipopt on the same problem built independently.

#include <gtest/gtest.h>

#include <chrono>
#include <set>

#include "mark/embed_problem.h"
#include "meshmark/core/random.h"
#include "meshmark/io/io.h"
#include "meshmark/mark/decode.h"
#include "meshmark/mark/embed.h"
#include "solve/admm_qp.h"
#include "solve/ipopt_reference.h"
#include "test_data.h"

using namespace meshmark;
using namespace meshmark::test;

namespace {

std::vector<std::string> variant_names() {
  std::vector<std::string> names;
  for (char c : {'D', 'S', 'V'})
    for (char d : {'R', 'N', 'S'})
      for (char k : {'S', 'Q', 'L'}) names.push_back(std::string{c, d, k});
  return names;
}

// Eight real meshes: closed (spot, fandisk, elephant, cow, pig, dragon) and open
// (bunny.ply with holes and non-manifold edges, mech-holes-shark).
std::vector<std::string> variant_meshes() {
  std::vector<std::string> paths = {data_mesh("spot.obj"),    data_mesh("bunny.ply"),
                                    cgal_mesh("fandisk.off"), cgal_mesh("elephant.off"),
                                    cgal_mesh("cow.off"),     cgal_mesh("mech-holes-shark.off"),
                                    cgal_mesh("pig.stl"),     cgal_mesh("ChineseDragon-10kv.off")};
  paths.erase(std::remove(paths.begin(), paths.end(), std::string()), paths.end());
  return paths;
}

class AllVariants : public ::testing::TestWithParam<std::string> {};

}  // namespace

TEST_P(AllVariants, EmbedSixtyFourBitsOnEightRealMeshes) {
  const auto paths = variant_meshes();
  if (paths.empty())
    GTEST_FAIL() << "no real mesh available (data/meshes, libcgal-demo: scripts/setup.sh)";
  EXPECT_EQ(paths.size(), 8u) << "some real meshes are missing";
  EmbedOptions o;
  o.variant = parse_variant(GetParam());
  for (std::size_t k = 0; k < paths.size(); ++k) {
    SCOPED_TRACE(paths[k]);
    const Mesh m = read_mesh(paths[k]);
    const Payload p = random_payload(64, 500 + k);
    const EmbedResult r = embed(m.V, m.F, p, o);
    ASSERT_EQ(r.status, EmbedStatus::Embedded) << r.message;
    ExtractOptions eo;
    eo.center = o.variant.center;
    const ExtractResult before = extract(m.V, m.F, eo), after = extract(r.V, m.F, eo);
    EXPECT_EQ(bit_error_rate(after.bits, p), 0.0);
    EXPECT_GE(after.min_margin(), o.strength - o.margin_tolerance);
    const double s = before.histogram.step;
    EXPECT_LE((after.center.point - before.center.point).norm(), o.center_tolerance * s)
        << "the center moved";
    EXPECT_NEAR(after.histogram.rho_min, before.histogram.rho_min, 1e-6 * s)
        << "the histogram's range changed";
    EXPECT_NEAR(after.histogram.rho_max, before.histogram.rho_max, 1e-6 * s);
    const double rms = r.rms_percent;
    EXPECT_GT(rms, 0.0);
    EXPECT_LT(rms, 1.0)
        << "an imperceptible watermark moves vertices by far less than 1 % of the diagonal";
  }
}

INSTANTIATE_TEST_SUITE_P(Framework, AllVariants, ::testing::ValuesIn(variant_names()),
                         [](const auto& info) { return info.param; });

TEST(LaplacianCost, OptimumMatchesIpoptOnSmallMeshes) {
  std::vector<std::pair<std::string, Mesh>> meshes = {{"bumpy sphere", bumpy_sphere(40, 60, 7)}};
  for (const std::string& path : {cgal_mesh("elephant.off"), data_mesh("spot.obj")})
    if (!path.empty()) meshes.push_back({path, read_mesh(path)});
  for (const auto& [label, m] : meshes) {
    SCOPED_TRACE(label);
    // Distinct positions, so that the independent problem (one unknown per vertex) and the
    // library's (one per group of identical positions) are the same.
    std::set<std::tuple<double, double, double>> distinct;
    for (Eigen::Index i = 0; i < m.V.rows(); ++i)
      distinct.insert({m.V(i, 0), m.V(i, 1), m.V(i, 2)});
    ASSERT_EQ(distinct.size(), static_cast<std::size_t>(m.V.rows()));
    const double lambda = 0.5;
    const Payload p = random_payload(64, 8);
    EmbedOptions o;
    o.variant = parse_variant("DRL");
    o.lambda = lambda;
    o.max_rounds = 1;  // D and R make the one round's problem the whole problem
    const EmbedResult ours = embed(m.V, m.F, p, o);
    ASSERT_EQ(ours.status, EmbedStatus::Embedded) << ours.message;

    std::vector<int> referenced;
    Eigen::MatrixX3d dirs;
    GeneralQp qp = drs_reference_problem(m.V, m.F, std::vector<int>(p.bits.begin(), p.bits.end()),
                                         o.strength, o.bin_offset, referenced, dirs);
    // Cost L written out: lambda sum r_i^2 + (1 - lambda) sum_i |r_i u_i - mean_{j in N1(i)} r_j
    // u_j|^2.
    const auto n = static_cast<Eigen::Index>(referenced.size());
    std::vector<int> index_of(m.V.rows(), -1);
    for (Eigen::Index k = 0; k < n; ++k) index_of[referenced[k]] = static_cast<int>(k);
    std::vector<std::set<int>> ring(m.V.rows());
    for (Eigen::Index t = 0; t < m.F.rows(); ++t)
      for (int c = 0; c < 3; ++c)
        if (m.F(t, c) != m.F(t, (c + 1) % 3))
          ring[m.F(t, c)].insert(m.F(t, (c + 1) % 3)), ring[m.F(t, (c + 1) % 3)].insert(m.F(t, c));
    std::vector<Eigen::Triplet<double>> tb;
    for (Eigen::Index k = 0; k < n; ++k) {
      const auto& nb = ring[referenced[k]];
      for (int a = 0; a < 3; ++a) {
        tb.emplace_back(3 * k + a, k, dirs(k, a));
        for (int j : nb)
          tb.emplace_back(3 * k + a, index_of[j],
                          -dirs(index_of[j], a) / static_cast<double>(nb.size()));
      }
    }
    Eigen::SparseMatrix<double> B(3 * n, n);
    B.setFromTriplets(tb.begin(), tb.end());
    qp.Q = (1 - lambda) * Eigen::SparseMatrix<double>(B.transpose() * B);
    qp.c = Eigen::VectorXd::Constant(n, lambda);
    const GeneralQpSolution ref = solve_general_qp_with_ipopt(qp);
    ASSERT_TRUE(ref.ok) << "Ipopt status " << ref.status;

    Eigen::VectorXd r(n);
    for (Eigen::Index k = 0; k < n; ++k)
      r(k) = (ours.V.row(referenced[k]) - m.V.row(referenced[k])).dot(dirs.row(k));
    const double our_cost = lambda * r.squaredNorm() + (1 - lambda) * (B * r).squaredNorm();
    EXPECT_NEAR(our_cost, ref.objective, 1e-5 * ref.objective);
  }
}

TEST(LaplacianCost, MatrixFreeHessianMatchesTheAssembledOneOverGroups) {
  // The operator the ADMM solver applies, against lambda I + (1 - lambda) B^T B assembled here
  // from the definition (one row of B per referenced vertex with neighbours, one column per
  // group of identical positions, whose squared displacement counts once), on a mesh with
  // unwelded seams and random unit directions.
  const std::string path = data_mesh("spider.obj");
  MESHMARK_REQUIRE(path, "spider.obj");
  const Mesh m = read_mesh(path);
  detail::EmbedContext ctx;
  ctx.referenced = referenced_vertices(m.F, m.V.rows());
  ctx.groups = group_identical_positions(m.V, ctx.referenced);
  ctx.adjacency = vertex_adjacency(m.F, m.V.rows());
  ctx.laplacian = detail::laplacian_rows(ctx.groups, ctx.adjacency);
  const int ng = ctx.groups.count();
  ASSERT_LT(ng, m.V.rows());
  Random rng(3);
  Eigen::MatrixX3d U(ng, 3);
  for (int g = 0; g < ng; ++g)
    U.row(g) = Eigen::RowVector3d(rng.normal(), rng.normal(), rng.normal()).normalized();
  std::vector<std::set<int>> ring(m.V.rows());
  for (Eigen::Index t = 0; t < m.F.rows(); ++t)
    for (int c = 0; c < 3; ++c) {
      const int a = m.F(t, c), b = m.F(t, (c + 1) % 3);
      if (a != b) ring[a].insert(b), ring[b].insert(a);
    }
  std::vector<Eigen::Triplet<double>> tb;
  for (Eigen::Index i = 0; i < m.V.rows(); ++i) {
    const int gi = ctx.groups.group_of[i];
    if (gi < 0 || ring[i].empty()) continue;
    for (int a = 0; a < 3; ++a) {
      tb.emplace_back(3 * i + a, gi, U(gi, a));
      for (int j : ring[i]) {
        const int gj = ctx.groups.group_of[j];
        tb.emplace_back(3 * i + a, gj, -U(gj, a) / static_cast<double>(ring[i].size()));
      }
    }
  }
  Eigen::SparseMatrix<double> B(3 * m.V.rows(), ng);
  B.setFromTriplets(tb.begin(), tb.end());
  for (double lambda : {0.0, 0.5, 1.0}) {
    SCOPED_TRACE(lambda);
    const Eigen::VectorXd w = Eigen::VectorXd::Ones(ng);  // a position counts once
    const Eigen::SparseMatrix<double> H =
        Eigen::SparseMatrix<double>((1 - lambda) * Eigen::SparseMatrix<double>(B.transpose() * B)) +
        Eigen::SparseMatrix<double>(Eigen::VectorXd(lambda * w).asDiagonal());
    const detail::LaplacianOperator op(ctx, U, lambda);
    const Eigen::VectorXd d = op.diagonal();
    EXPECT_LE((d - H.diagonal()).cwiseAbs().maxCoeff(), 1e-13 * H.diagonal().cwiseAbs().maxCoeff());
    for (int trial = 0; trial < 3; ++trial) {
      Eigen::VectorXd x(ng);
      for (int g = 0; g < ng; ++g) x(g) = rng.normal();
      Eigen::VectorXd Hx;
      op.apply(x, Hx);
      const Eigen::VectorXd expected = H * x;
      EXPECT_LE((Hx - expected).norm(), 1e-12 * expected.norm());
    }
  }
}

TEST(LaplacianCost, CholeskyAndConjugateGradientXStepsReachTheSameOptimum) {
  // The two x-steps of the ADMM solver (exact sparse LDL^T of the assembled matrix, inexact
  // matrix-free CG) must converge to the same embedding cost on real meshes, closed and open.
  int meshes = 0;
  for (const std::string& path : {data_mesh("spot.obj"), data_mesh("bunny.ply")}) {
    if (path.empty()) continue;
    SCOPED_TRACE(path);
    const Mesh m = read_mesh(path);
    const Payload p = random_payload(64, 4);
    EmbedOptions cg;
    cg.variant = parse_variant("VRL");
    EmbedOptions chol = cg;
    chol.admm.x_step = AdmmXStep::Cholesky;
    const EmbedResult a = embed(m.V, m.F, p, cg), b = embed(m.V, m.F, p, chol);
    ASSERT_EQ(a.status, EmbedStatus::Embedded) << a.message;
    ASSERT_EQ(b.status, EmbedStatus::Embedded) << b.message;
    EXPECT_NEAR(a.squared_displacement, b.squared_displacement, 1e-6 * b.squared_displacement);
    ++meshes;
  }
  if (meshes == 0)
    GTEST_FAIL() << "no real mesh available (data/meshes, libcgal-demo: scripts/setup.sh)";
}

TEST(LaplacianCost, CholeskyFactorsAreKeptForAnUnchangedHessian) {
  const Mesh m = bumpy_sphere(12, 16, 2);
  detail::EmbedContext ctx;
  ctx.referenced = referenced_vertices(m.F, m.V.rows());
  ctx.groups = group_identical_positions(m.V, ctx.referenced);
  ctx.adjacency = vertex_adjacency(m.F, m.V.rows());
  const Eigen::SparseMatrix<double> C = detail::laplacian_topology(ctx.groups, ctx.adjacency);
  Eigen::SparseMatrix<double> H = C;
  H.diagonal().array() += 0.5;
  AdmmSettings s;
  s.x_step = AdmmXStep::Cholesky;
  AdmmQpSolver solver;
  solver.set_hessian(H, s);
  solver.set_hessian(H, s);  // the next round, same Hessian: no new factorization
  EXPECT_EQ(solver.factorizations(), 1);
  // The kept factors still solve: an unconstrained-enough problem's x-step is exact, so a
  // solve over a trivial constraint set (one row, no bounds binding) must succeed.
  SeparableQp qp;
  const Eigen::Index n = H.rows();
  qp.h = Eigen::VectorXd::Ones(n);
  qp.lo = Eigen::VectorXd::Constant(n, -10);
  qp.hi = Eigen::VectorXd::Constant(n, 10);
  qp.row.assign(static_cast<std::size_t>(n), 0);
  qp.a = Eigen::VectorXd::Ones(n);
  qp.b = Eigen::VectorXd::Constant(1, 1.0);
  qp.e = Eigen::Matrix3Xd::Zero(3, n);
  const QpResult r = solver.solve(qp);
  EXPECT_EQ(r.status, QpStatus::Solved);
  EXPECT_GE(qp.a.dot(r.x), 1.0 - 1e-9);
  Eigen::SparseMatrix<double> H2 = H;
  H2.diagonal().array() += 0.25;
  solver.set_hessian(H2, s);
  EXPECT_EQ(solver.factorizations(), 2);
}

// A one-shot embed() reports the time of the whole computation, the preparation included (VSS's
// roughness field was left out of its seconds): at least 80 % of the wall time measured around
// the call, and no more than it.
TEST(EmbedTiming, AOneShotEmbedCountsItsPreparation) {
  const Mesh m = read_mesh(test::cgal_mesh("elephant.off"));
  EmbedOptions o;
  o.variant = parse_variant("VSS");
  const auto start = std::chrono::steady_clock::now();
  const EmbedResult r = embed(m.V, m.F, random_payload(64, 3), o);
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_EQ(r.status, EmbedStatus::Embedded) << r.message;
  EXPECT_GE(r.seconds, 0.8 * wall);
  EXPECT_LE(r.seconds, wall);
}
