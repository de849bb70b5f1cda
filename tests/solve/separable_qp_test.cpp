// The structured solver against Ipopt on random problems of the same shape, and an
// independent check of the KKT conditions of its answers.

#include <gtest/gtest.h>

#include "meshmark/core/random.h"
#include "meshmark/io/io.h"
#include "meshmark/mark/embed.h"
#include "meshmark/solve/separable_qp.h"
#include "solve/ipopt_reference.h"
#include "test_data.h"

using namespace meshmark;

namespace {

SeparableQp random_problem(int n, int m, std::uint64_t seed) {
  Random rng(seed);
  SeparableQp qp;
  qp.h.resize(n);
  qp.lo.resize(n);
  qp.hi.resize(n);
  qp.a.resize(n);
  qp.row.assign(n, -1);
  qp.e.resize(3, n);
  std::vector<int> count(m, 0);
  for (int i = 0; i < n; ++i) {
    qp.h(i) = rng.uniform(0.5, 2.0);
    const double t = rng.uniform();  // position in a bin, as in the embedding problem
    qp.lo(i) = 0.05 - t;
    qp.hi(i) = 0.95 - t;
    if (rng.uniform() < 0.03) qp.lo(i) = qp.hi(i) = 0;  // fixed vertices
    if (rng.uniform() < 0.8) qp.row[i] = static_cast<int>(rng.index(m));
    if (qp.row[i] >= 0) ++count[qp.row[i]];
    Eigen::Vector3d u(rng.normal(), rng.normal(), rng.normal());
    qp.e.col(i) = u.normalized() / n;
  }
  for (int i = 0; i < n; ++i)
    if (qp.row[i] >= 0) qp.a(i) = (qp.row[i] % 2 ? 1.0 : -1.0) / count[qp.row[i]];
  qp.b.resize(m);
  for (int j = 0; j < m; ++j) qp.b(j) = rng.uniform(-0.1, 0.3);  // some rows inactive
  return qp;
}

GeneralQp as_reference(const SeparableQp& qp) {
  const Eigen::Index n = qp.h.size(), m = qp.b.size();
  GeneralQp r;
  r.c = qp.h;
  r.x_lo = qp.lo;
  r.x_hi = qp.hi;
  r.row_lo.resize(m + 3);
  r.row_hi.resize(m + 3);
  r.row_lo.head(m) = qp.b;
  r.row_hi.head(m).setConstant(1e19);
  r.row_lo.tail(3).setZero();
  r.row_hi.tail(3).setZero();
  for (Eigen::Index i = 0; i < n; ++i) {
    if (qp.row[i] >= 0) r.A.emplace_back(qp.row[i], i, qp.a(i));
    for (int k = 0; k < 3; ++k) r.A.emplace_back(m + k, i, qp.e(k, i));
  }
  return r;
}

// KKT conditions, written out independently of the solver.
void expect_kkt(const SeparableQp& qp, const QpResult& r, double tol) {
  const Eigen::Index n = qp.h.size(), m = qp.b.size();
  Eigen::VectorXd rows = Eigen::VectorXd::Zero(m);
  Eigen::Vector3d ex = Eigen::Vector3d::Zero();
  for (Eigen::Index i = 0; i < n; ++i) {
    EXPECT_GE(r.x(i), qp.lo(i));
    EXPECT_LE(r.x(i), qp.hi(i));
    if (qp.row[i] >= 0) rows(qp.row[i]) += qp.a(i) * r.x(i);
    ex += qp.e.col(i) * r.x(i);
    // Stationarity over the box: 2 h x - (M^T y)_i is >= 0 at lo, <= 0 at hi, 0 inside.
    const double z =
        (qp.row[i] >= 0 ? qp.a(i) * r.y(qp.row[i]) : 0.0) + qp.e.col(i).dot(r.y.tail<3>());
    const double grad = 2 * qp.h(i) * r.x(i) - z;
    if (qp.lo(i) < r.x(i) && r.x(i) < qp.hi(i))
      EXPECT_NEAR(grad, 0, 1e-8);
    else if (r.x(i) == qp.lo(i) && qp.lo(i) < qp.hi(i))
      EXPECT_GE(grad, -1e-8);
    else if (r.x(i) == qp.hi(i) && qp.lo(i) < qp.hi(i))
      EXPECT_LE(grad, 1e-8);
  }
  for (Eigen::Index j = 0; j < m; ++j) {
    EXPECT_GE(rows(j), qp.b(j) - tol);
    EXPECT_GE(r.y(j), 0.0);
    if (r.y(j) > 1e-9) EXPECT_NEAR(rows(j), qp.b(j), tol) << "complementarity, row " << j;
  }
  EXPECT_LE(ex.cwiseAbs().maxCoeff(), tol);
}

}  // namespace

TEST(SeparableQp, MatchesIpoptOnRandomProblems) {
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    SCOPED_TRACE(seed);
    const SeparableQp qp = random_problem(400, 12, seed);
    const QpResult ours = solve_separable_qp(qp);
    ASSERT_EQ(ours.status, QpStatus::Solved);
    expect_kkt(qp, ours, 1e-10);
    const auto ref = solve_general_qp_with_ipopt(as_reference(qp));
    ASSERT_TRUE(ref.ok) << "Ipopt status " << ref.status;
    EXPECT_NEAR(ours.objective, ref.objective, 1e-7 * ref.objective);
    EXPECT_LE(ours.objective, ref.objective * (1 + 1e-9))
        << "an exact optimum is never worse than Ipopt's";
    EXPECT_LE((ours.x - ref.x).cwiseAbs().maxCoeff(), 1e-5);
  }
}

TEST(SeparableQp, WarmStartReachesTheSameOptimumFaster) {
  const SeparableQp qp = random_problem(2000, 40, 77);
  const QpResult cold = solve_separable_qp(qp);
  ASSERT_EQ(cold.status, QpStatus::Solved);
  const QpResult warm = solve_separable_qp(qp, {}, &cold.y);
  ASSERT_EQ(warm.status, QpStatus::Solved);
  EXPECT_LE(warm.iterations, 1);
  EXPECT_NEAR(warm.objective, cold.objective, 1e-12 * cold.objective);
}

TEST(SeparableQp, UnreachableRowsAreReportedAsInfeasible) {
  SeparableQp qp = random_problem(300, 10, 5);
  // Row 3 asks for more than its bounds allow: sum a_i x_i <= sum |a_i| max(|lo|,|hi|) < 1.
  qp.b(3) = 1.0;
  const QpResult r = solve_separable_qp(qp);
  EXPECT_EQ(r.status, QpStatus::Infeasible);
  EXPECT_EQ(r.infeasible_rows, std::vector<int>{3});
}

TEST(SeparableQp, RowWithoutVariablesIsInfeasibleOnlyWhenItAsksForSomething) {
  SeparableQp qp = random_problem(200, 6, 9);
  for (int i = 0; i < 200; ++i)
    if (qp.row[i] == 2) qp.row[i] = -1;  // row 2 now empty
  qp.b(2) = -0.1;
  EXPECT_EQ(solve_separable_qp(qp).status, QpStatus::Solved);
  qp.b(2) = 0.05;
  const QpResult r = solve_separable_qp(qp);
  EXPECT_EQ(r.status, QpStatus::Infeasible);
  EXPECT_EQ(r.infeasible_rows, std::vector<int>{2});
}

// Ipopt's iteration count comes from its own intermediate callback: a solve cut at N iterations
// by Ipopt's max_iter reports N, and an embedding with the Ipopt backend counts its rounds'
// iterations (it reported 0 before).
TEST(SeparableQp, IpoptReportsTheIterationsItRan) {
  const SeparableQp qp = random_problem(400, 12, 3);
  const auto full = solve_general_qp_with_ipopt(as_reference(qp));
  ASSERT_TRUE(full.ok) << "Ipopt status " << full.status;
  ASSERT_GT(full.iterations, 2);
  IpoptOptions cut_short;
  cut_short.max_iterations = full.iterations / 2;
  const auto cut = solve_general_qp_with_ipopt(as_reference(qp), cut_short);
  EXPECT_FALSE(cut.ok);
  EXPECT_EQ(cut.iterations, cut_short.max_iterations);
  const Mesh spot = read_mesh(test::data_mesh("spot.obj"));
  EmbedOptions o;
  o.backend = SolverBackend::Ipopt;
  const EmbedResult r = embed(spot.V, spot.F, random_payload(64, 5), o);
  ASSERT_EQ(r.status, EmbedStatus::Embedded) << r.message;
  EXPECT_GE(r.solver_iterations, r.rounds);
}
