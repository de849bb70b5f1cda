// Normal-cycle curvature against analytic values on meshes sampled coarser than the ball,
// and, below an edge's length, against the clipped definition evaluated here by hand.

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <cmath>

#include "carrier/curvature.h"
#include "meshmark/core/mesh.h"

using namespace meshmark;

namespace {

constexpr double kPi = 3.14159265358979323846;

// A closed-side cylinder of radius R around z: `around` vertices per ring, rings `step` apart,
// each quad split along the same diagonal. Vertex (ring j, k) is j * around + k.
Mesh cylinder(double R, int around, int rings, double step) {
  Eigen::MatrixX3d V(around * rings, 3);
  for (int j = 0; j < rings; ++j)
    for (int k = 0; k < around; ++k) {
      const double a = 2 * kPi * k / around;
      V.row(j * around + k) << R * std::cos(a), R * std::sin(a), j * step;
    }
  Eigen::MatrixX3i F(2 * around * (rings - 1), 3);
  int f = 0;
  for (int j = 0; j + 1 < rings; ++j)
    for (int k = 0; k < around; ++k) {
      const int a = j * around + k, b = j * around + (k + 1) % around, c = a + around,
                d = b + around;
      F.row(f++) << a, b, d;  // outward normals
      F.row(f++) << a, d, c;
    }
  return make_mesh(V, F);
}

// Unit normal of face f.
Eigen::Vector3d face_normal(const Mesh& m, int f) {
  const Eigen::Vector3d p0 = m.V.row(m.F(f, 0)), p1 = m.V.row(m.F(f, 1)), p2 = m.V.row(m.F(f, 2));
  return (p1 - p0).cross(p2 - p0).normalized();
}

// The clipped definition for a ball of radius r smaller than the distance from vertex v to any
// edge not incident to it: only v's own edges enter, each for the length r, so the tensor is
// sum beta(e) r e e^T / (|e|^2 pi r^2). beta is the unsigned angle between the normals of the
// edge's two faces (the cylinder is convex: every angle has the same sign). Returns the two
// largest eigenvalue magnitudes, smaller first.
Eigen::Vector2d star_curvature(const Mesh& m, int v, double r) {
  Eigen::Matrix3d T = Eigen::Matrix3d::Zero();
  for (Eigen::Index t = 0; t < m.F.rows(); ++t)
    for (int c = 0; c < 3; ++c) {
      const int a = m.F(t, c), b = m.F(t, (c + 1) % 3);
      if (a != v && b != v) continue;
      // Each edge is seen from its two faces: take it from the face that runs a -> b with a = v.
      if (a != v) continue;
      int other = -1;  // the face running b -> a
      for (Eigen::Index s = 0; s < m.F.rows(); ++s)
        for (int k = 0; k < 3; ++k)
          if (m.F(s, k) == b && m.F(s, (k + 1) % 3) == a) other = static_cast<int>(s);
      if (other < 0) continue;  // boundary edge: no angle
      const double beta = std::acos(
          std::clamp(face_normal(m, static_cast<int>(t)).dot(face_normal(m, other)), -1.0, 1.0));
      const Eigen::Vector3d e = (m.V.row(b) - m.V.row(a)).transpose();
      T += beta * r * e * e.transpose() / e.squaredNorm();
    }
  T /= kPi * r * r;
  Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(T).eigenvalues().cwiseAbs();
  std::sort(ev.data(), ev.data() + 3);
  return {ev(1), ev(2)};
}

}  // namespace

// A cylinder of radius 1 with edges of about 0.13: balls of 0.5 and 0.7 hold several edges
// and stay inside the radius. The clipped normal cycle of a ball centered at a vertex sums
// whole lattice lines against the disc's area: with 4 to 5 lines across it the sum differs from
// the area integral by a few percent (Euler-Maclaurin for sqrt(r^2 - y^2) at spacing 0.13).
TEST(Curvature, CylinderReadsOneOverRadiusWithBallsOfSeveralEdges) {
  constexpr double kR = 1, kLattice = 0.06;
  const Mesh m = cylinder(kR, 48, 60, 0.13);
  for (double r : {0.5, 0.7}) {
    const CurvatureField c = normal_cycle_curvature(m.V, m.F, r);
    for (int j = 20; j < 40; j += 7)  // rings far from the open ends
      for (int k = 0; k < 48; k += 11) {
        const int v = j * 48 + k;
        EXPECT_NEAR(std::abs(c.kmax(v)), 1 / kR, kLattice * (1 / kR)) << "r " << r << " v " << v;
        EXPECT_LT(std::abs(c.kmin(v)), kLattice * (1 / kR)) << "r " << r << " v " << v;
      }
  }
}

// Below an edge's length the clipped value is the star's edges times r over pi r^2: it grows as
// 1 / r (halving r doubles it), where a one-ring average would not depend on r. Both ball modes
// agree there (the walk sees exactly the star).
TEST(Curvature, BelowAnEdgeTheStarCountsForTheRadius) {
  const Mesh m = cylinder(1, 12, 8, 0.5);  // edges of 0.52 around, 0.5 along
  const int v = 4 * 12 + 3;
  const double r = 0.1;  // less than the distance from v to any edge off its star (> 0.35)
  const Eigen::Vector2d expected = star_curvature(m, v, r);
  for (BallEdges which : {BallEdges::kClipped, BallEdges::kReferenceWalk}) {
    const CurvatureField c = normal_cycle_curvature(m.V, m.F, r, which);
    EXPECT_NEAR(std::abs(c.kmax(v)), expected(1), 1e-9 * expected(1));
    EXPECT_NEAR(std::abs(c.kmin(v)), expected(0), 1e-9 * expected(1) + 1e-12);
    const CurvatureField half = normal_cycle_curvature(m.V, m.F, r / 2, which);
    EXPECT_NEAR(half.kmax(v), 2 * c.kmax(v), 1e-9 * std::abs(c.kmax(v)));
  }
  EXPECT_GT(expected(1), 2.0) << "well above 1 / R: the ball is smaller than the edges";
}

// On a convex surface every edge bends the same way, so the reference's walk, which sees a
// subset of the edges for at most their clipped lengths, reads no more than the clipped ball,
// and less once the ball holds edges nearly tangent to its sphere.
TEST(Curvature, ReferenceWalkReadsNoMoreThanTheClippedBallOnAConvexSurface) {
  const Mesh m = cylinder(1, 48, 60, 0.13);
  const CurvatureField clipped = normal_cycle_curvature(m.V, m.F, 0.5);
  const CurvatureField walk = normal_cycle_curvature(m.V, m.F, 0.5, BallEdges::kReferenceWalk);
  for (int v = 20 * 48; v < 40 * 48; v += 5) {
    EXPECT_LE(std::abs(walk.kmax(v)), std::abs(clipped.kmax(v)) * (1 + 1e-12)) << v;
    EXPECT_LT(std::abs(walk.kmax(v)), 0.97 * std::abs(clipped.kmax(v))) << v;
  }
}
