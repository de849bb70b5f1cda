// The library's own closest-point tree (src/metrics/closest_point.cpp) against CGAL's AABB tree,
// which it replaced so that the core links no GPL code: on the project's meshes and libcgal-demo's,
// for points near the surface (what registration and trace ask), far from it and on it, every
// distance agrees within 1e-12 of the bounding box diagonal, and so does every closest point
// but where the two trees found different points at the same distance (a tie: the query is as
// far from two parts of the surface), which is then checked to be a tie.

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <random>

#include "cgal_closest_reference.h"
#include "meshmark/core/error.h"
#include "meshmark/io/io.h"
#include "meshmark/metrics/metrics.h"
#include "metrics/closest_point.h"
#include "test_data.h"

using namespace meshmark;
using namespace meshmark::test;

namespace {

// Queries: 2,000 surface samples pushed off the surface by Gaussian offsets of 1e-3, 1e-2 and
// 1e-1 of the diagonal, 500 uniform in the box grown by half the diagonal, and 200 vertices.
Eigen::MatrixX3d queries(const Mesh& m, double diag) {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> gauss;
  const Eigen::MatrixX3d S = sample_surface(m.V, m.F, 2000, 5);
  const int uniform = 500, vertices = 200;
  Eigen::MatrixX3d Q(S.rows() + uniform + vertices, 3);
  const double scales[3] = {1e-3, 1e-2, 1e-1};
  for (Eigen::Index i = 0; i < S.rows(); ++i)
    for (int c = 0; c < 3; ++c) Q(i, c) = S(i, c) + scales[i % 3] * diag * gauss(rng);
  const Eigen::RowVector3d lo = m.V.colwise().minCoeff(), hi = m.V.colwise().maxCoeff();
  std::uniform_real_distribution<double> u(-0.5, 1.5);
  for (int k = 0; k < uniform; ++k)
    for (int c = 0; c < 3; ++c) Q(S.rows() + k, c) = lo(c) + u(rng) * (hi(c) - lo(c));
  for (int k = 0; k < vertices; ++k)
    Q.row(S.rows() + uniform + k) = m.V.row((k * 7919) % m.V.rows());
  return Q;
}

}  // namespace

TEST(ClosestPoint, AgreesWithCgalsAabbTreeOnRealMeshes) {
  const double tolerance = 1e-12;  // of the diagonal
  int meshes = 0;
  for (const auto& [path, label] : {std::pair{data_mesh("spot.obj"), "spot.obj"},
                                    {data_mesh("bunny.ply"), "bunny.ply"},
                                    {cgal_mesh("fandisk.off"), "fandisk.off"},
                                    {cgal_mesh("elephant.off"), "elephant.off"},
                                    {cgal_mesh("cheese.off"), "cheese.off"},
                                    {cgal_mesh("knot1.off"), "knot1.off"}}) {
    if (path.empty()) continue;
    SCOPED_TRACE(label);
    ++meshes;
    const Mesh m = read_mesh(path);
    const double diag = bounding_box_diagonal(m.V);
    const Eigen::MatrixX3d Q = queries(m, diag);
    const ClosestPoints ours = closest_points(m.V, m.F, Q);
    const std::vector<ReferenceClosest> cgal = cgal_closest_points(m.V, m.F, Q);
    int ties = 0;
    for (Eigen::Index i = 0; i < Q.rows(); ++i) {
      const ReferenceClosest& r = cgal[static_cast<std::size_t>(i)];
      ASSERT_NEAR(ours.distance(i), r.distance, tolerance * diag) << "query " << i;
      const Eigen::Vector3d p = ours.point.row(i).transpose();
      // Our point is where we say, at the distance we say, on the face we name.
      ASSERT_NEAR((p - Q.row(i).transpose()).norm(), ours.distance(i), tolerance * diag);
      const int f = ours.face[static_cast<std::size_t>(i)];
      Eigen::Vector3d on_face = Eigen::Vector3d::Zero();
      for (int k = 0; k < 3; ++k)
        on_face += ours.barycentric(i, k) * m.V.row(m.F(f, k)).transpose();
      ASSERT_LE((on_face - p).norm(), tolerance * diag) << "query " << i;
      ASSERT_GE(ours.barycentric.row(i).minCoeff(), -1e-12);
      if ((p - r.point).norm() > tolerance * diag) ++ties;
    }
    // Ties are rare; each is a tie by the distance assertion above.
    EXPECT_LE(ties, Q.rows() / 1000) << ties << " closest points differ at equal distances";
  }
  if (meshes < 3) GTEST_SKIP() << "fewer than 3 of the meshes found";
}

TEST(ClosestPoint, SkipsDegenerateTrianglesAndRefusesAMeshOfThemOnly) {
  Eigen::MatrixX3d V(4, 3);
  V << 0, 0, 0, 1, 0, 0, 2, 0, 0, 0, 1, 0;
  Eigen::MatrixX3i F(2, 3);
  F << 0, 1, 2,  // collinear
      0, 1, 3;
  Eigen::MatrixX3d Q(1, 3);
  Q << 2, 0, 0;  // on the degenerate one, 1 from the other's corner (1, 0, 0)
  const ClosestPoints c = closest_points(V, F, Q);
  EXPECT_EQ(c.face[0], 1);
  EXPECT_NEAR(c.distance(0), 1.0, 1e-15);
  EXPECT_THROW(closest_points(V, F.topRows(1), Q), InvalidArgumentError);
  Q(0, 0) = std::nan("");
  EXPECT_THROW(closest_points(V, F, Q), InvalidArgumentError);
}

// The tree keeps its boxes in single precision, rounded outward: a query must still find the
// exact closest triangle when the triangles differ far below float's resolution. 3,000 slivers
// side by side 1e-10 apart near x = 1, and one large triangle at x = -3 (the boxes' frame is
// centered on the whole mesh, so the slivers sit 2 from its center, where float's step is
// 2.4e-7: thousands share one float box), each sliver queried at its own centroid and 1e-11
// off it. By construction the sliver queried is the closest (its neighbours are at least
// 6e-11 away, the large triangle 4), so the answer must be that triangle, at its plane's
// distance to the query, to 1e-15.
TEST(ClosestPoint, TrianglesFinerThanSinglePrecisionAreFoundExactly) {
  const int n = 3000;
  const double step = 1e-10, tolerance = 1e-15;
  Eigen::MatrixX3d V(3 * n + 3, 3);
  Eigen::MatrixX3i F(n + 1, 3);
  V.bottomRows(3) << -3, 0, 0, -3, 1, 0, -3, 0, 1;
  F.row(n) << 3 * n, 3 * n + 1, 3 * n + 2;
  for (int i = 0; i < n; ++i) {
    const double x = 1 + i * step;
    V.row(3 * i) << x, 0, 0;
    V.row(3 * i + 1) << x + 0.4 * step, 0, 0;
    V.row(3 * i + 2) << x + 0.2 * step, 1, 0.5 * ((i * 7) % 3);  // slanted differently
    F.row(i) << 3 * i, 3 * i + 1, 3 * i + 2;
  }
  Eigen::MatrixX3d Q(2 * n, 3);
  for (int i = 0; i < n; ++i) {
    const Eigen::RowVector3d c = (V.row(3 * i) + V.row(3 * i + 1) + V.row(3 * i + 2)) / 3;
    Q.row(2 * i) = c;
    Q.row(2 * i + 1) = c + Eigen::RowVector3d(0, 0, 1e-11);
  }
  const ClosestPoints ours = closest_points(V, F, Q);
  int wrong = 0;
  for (Eigen::Index q = 0; q < Q.rows(); ++q) {
    const int f = static_cast<int>(q / 2);
    const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
    const Eigen::Vector3d normal = (b - a).cross(c - a).normalized();
    const double expected = std::abs(normal.dot(Q.row(q).transpose() - a));
    if (ours.face[static_cast<std::size_t>(q)] != f ||
        std::abs(ours.distance(q) - expected) > tolerance)
      ++wrong;
  }
  EXPECT_EQ(wrong, 0) << "of " << Q.rows() << " queries";
}
