// Center Jacobians against central finite differences of the centers themselves.

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "meshmark/carrier/center.h"
#include "meshmark/core/random.h"
#include "meshmark/io/io.h"
#include "test_data.h"

using namespace meshmark;
using namespace meshmark::test;

namespace {

using Vec3L = Eigen::Matrix<long double, 3, 1>;

// The three centers written out again, in long double, for finite differences whose rounding
// stays far below the tolerance.
Vec3L center_ld(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                const std::vector<std::uint8_t>& used, CenterKind kind) {
  Vec3L O = Vec3L::Zero();
  long double n = 0;
  for (Eigen::Index i = 0; i < V.rows(); ++i)
    if (used[i]) O += V.row(i).transpose().cast<long double>(), n += 1;
  O /= n;
  if (kind == CenterKind::Discrete) return O;
  Vec3L sum = Vec3L::Zero();
  long double W = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Vec3L p0 = V.row(F(f, 0)).transpose().cast<long double>(),
                p1 = V.row(F(f, 1)).transpose().cast<long double>(),
                p2 = V.row(F(f, 2)).transpose().cast<long double>();
    if (kind == CenterKind::Surface) {
      const long double area = 0.5L * (p1 - p0).cross(p2 - p0).norm();
      sum += area * (p0 + p1 + p2) / 3.0L;
      W += area;
    } else {
      const long double w = (p0 - O).dot((p1 - O).cross(p2 - O)) / 6.0L;
      sum += w * (O + p0 + p1 + p2) / 4.0L;
      W += w;
    }
  }
  return sum / W;
}

void expect_jacobians_match_differences(const Mesh& input, CenterKind kind, int samples) {
  Mesh m = input;
  const auto used = referenced_vertices(m.F, m.V.rows());
  const CenterJacobians cj = center_jacobians(m.V, m.F, used, kind);
  const double n_ref = static_cast<double>(std::count(used.begin(), used.end(), 1));
  const double h = 1e-5 * bounding_box_diagonal(m.V, used);
  Random rng(17);
  int checked = 0;
  while (checked < samples) {
    const auto i = static_cast<Eigen::Index>(rng.index(static_cast<std::uint64_t>(m.V.rows())));
    if (!used[i]) continue;
    // Fourth-order central differences: small truncation error at a step large enough for
    // rounding in C not to matter.
    auto C = [&](int a, double step) {
      Eigen::MatrixX3d moved = m.V;
      moved(i, a) += step;
      return center_ld(moved, m.F, used, kind);
    };
    Eigen::Matrix3d fd;
    for (int a = 0; a < 3; ++a)
      fd.col(a) =
          ((8 * (C(a, h) - C(a, -h)) - (C(a, 2 * h) - C(a, -2 * h))) / (12 * h)).cast<double>();
    // Relative error 1e-6, measured against the vertex's Jacobian or, for vertices whose
    // faces have (almost) no area and so almost no Jacobian, against the typical one, I / n.
    const double scale = std::max(cj.J[i].norm(), std::sqrt(3.0) / n_ref);
    EXPECT_LE((fd - cj.J[i]).norm(), 1e-6 * scale) << "vertex " << i << "\nanalytic\n"
                                                   << cj.J[i] << "\ndifferences\n"
                                                   << fd;
    ++checked;
  }
}

}  // namespace

TEST(CenterJacobians, MatchFiniteDifferencesOnRealMeshes) {
  int meshes = 0;
  for (const std::string& path : {data_mesh("spot.obj"), data_mesh("bunny.ply"),
                                  cgal_mesh("fandisk.off"), cgal_mesh("mech-holes-shark.off")}) {
    if (path.empty()) continue;
    SCOPED_TRACE(path);
    const Mesh m = read_mesh(path);
    for (CenterKind kind : {CenterKind::Discrete, CenterKind::Surface, CenterKind::Volume}) {
      SCOPED_TRACE(center_letter(kind));
      expect_jacobians_match_differences(m, kind, 25);
    }
    ++meshes;
  }
  if (meshes == 0)
    GTEST_FAIL() << "no real mesh available (data/meshes, libcgal-demo: scripts/setup.sh)";
}

TEST(CenterJacobians, VolumeCenterWithoutVolumeIsReportedIllDefined) {
  Mesh m = bumpy_sphere(10, 12, 3);
  const auto used = referenced_vertices(m.F, m.V.rows());
  EXPECT_TRUE(center_of_mass(m.V, m.F, used, CenterKind::Volume).well_defined);
  // Inconsistently oriented: every other triangle flipped, the signed volumes cancel.
  Eigen::MatrixX3i flipped = m.F;
  for (Eigen::Index t = 0; t < flipped.rows(); t += 2) std::swap(flipped(t, 1), flipped(t, 2));
  EXPECT_FALSE(center_of_mass(m.V, flipped, used, CenterKind::Volume).well_defined);
  // Flat and open: every tetrahedron on the discrete center has no volume.
  Mesh flat = m;
  flat.V.col(2).setZero();
  EXPECT_FALSE(center_of_mass(flat.V, flat.F, used, CenterKind::Volume).well_defined);
}

namespace {

// A closed 2 x 1 x 1 box, outward-facing, with irregular vertex density (a ninth vertex on an
// edge of the bottom).
Mesh irregular_box() {
  Eigen::MatrixX3d V(9, 3);
  V << 0, 0, 0, 2, 0, 0, 2, 1, 0, 0, 1, 0, 0, 0, 1, 2, 0, 1, 2, 1, 1, 0, 1, 1, 0.5, 0, 0;
  Eigen::MatrixX3i F(13, 3);
  F << 0, 3, 2, 0, 2, 1, 4, 5, 6, 4, 6, 7, 0, 8, 5, 0, 5, 4, 8, 1, 5, 3, 7, 6, 3, 6, 2, 0, 4, 7, 0,
      7, 3, 1, 2, 6, 1, 6, 5;
  return make_mesh(V, F);
}

}  // namespace

TEST(CenterJacobians, CentersOfAnAxisAlignedBoxAreItsMiddle) {
  // A closed box with irregular vertex density: S and V centers are the box's middle, D is not.
  const Mesh box = irregular_box();
  const Eigen::MatrixX3d& V = box.V;
  const Eigen::MatrixX3i& F = box.F;
  const auto used = referenced_vertices(F, 9);
  for (CenterKind kind : {CenterKind::Surface, CenterKind::Volume}) {
    const Center c = center_of_mass(V, F, used, kind);
    EXPECT_LE((c.point - Eigen::Vector3d(1, 0.5, 0.5)).norm(), 1e-12) << center_letter(kind);
  }
  EXPECT_GT((center_of_mass(V, F, used, CenterKind::Discrete).point - Eigen::Vector3d(1, 0.5, 0.5))
                .norm(),
            0.01);
}

TEST(CenterJacobians, MassIsTheVertexCountTheAreaOrTheVolume) {
  // The closed 2 x 1 x 1 box above, outward-facing (face 0 at z = 0 has normal -z): 9 vertices,
  // area 2 (2 + 2 + 1) = 10, volume 2; its triangles are consistently oriented.
  const Mesh box = irregular_box();
  const Eigen::MatrixX3d& V = box.V;
  const Eigen::MatrixX3i& F = box.F;
  const auto used = referenced_vertices(F, 9);
  constexpr double kTol = 1e-12;
  EXPECT_EQ(center_of_mass(V, F, used, CenterKind::Discrete).mass, 9);
  EXPECT_NEAR(center_of_mass(V, F, used, CenterKind::Surface).mass, 10, kTol);
  const Center v = center_of_mass(V, F, used, CenterKind::Volume);
  EXPECT_NEAR(v.mass, 2, kTol);
  EXPECT_NEAR(v.volume_consistency, 1, kTol);
  // Turned inside out: the signed volume changes sign, the consistency does not.
  const Eigen::MatrixX3i inward = F.rowwise().reverse();
  const Center w = center_of_mass(V, inward, used, CenterKind::Volume);
  EXPECT_NEAR(w.mass, -2, kTol);
  EXPECT_NEAR(w.volume_consistency, 1, kTol);
}

TEST(CenterJacobians, ProductsAndCenterOfTheFusedPassAgreeWithTheMatricesAndLongDouble) {
  // center_jacobian_products gathers different per-vertex sums than center_jacobians (a 3-vector
  // and a scalar instead of a matrix): each J_i u_i must match the (finite-difference checked)
  // matrix times u_i, and its center the long-double one, on closed and open real meshes.
  int meshes = 0;
  for (const std::string& path : {data_mesh("spot.obj"), cgal_mesh("mech-holes-shark.off")}) {
    if (path.empty()) continue;
    SCOPED_TRACE(path);
    const Mesh m = read_mesh(path);
    const auto used = referenced_vertices(m.F, m.V.rows());
    const double diag = bounding_box_diagonal(m.V, used);
    Random rng(5);
    Eigen::MatrixX3d U(m.V.rows(), 3);
    for (Eigen::Index i = 0; i < U.rows(); ++i) {
      const Eigen::Vector3d u(rng.normal(), rng.normal(), rng.normal());
      U.row(i) = u.normalized().transpose();
    }
    for (CenterKind kind : {CenterKind::Discrete, CenterKind::Surface, CenterKind::Volume}) {
      SCOPED_TRACE(center_letter(kind));
      const CenterJacobians cj = center_jacobians(m.V, m.F, used, kind);
      const CenterProducts cp = center_jacobian_products(m.V, m.F, used, kind, U);
      const Vec3L ref = center_ld(m.V, m.F, used, kind);
      EXPECT_LE((cp.center.point - ref.cast<double>()).norm(), 1e-12 * diag);
      EXPECT_LE((cp.center.point - center_of_mass(m.V, m.F, used, kind).point).norm(),
                1e-13 * diag);
      double scale = 0, worst = 0;
      for (Eigen::Index i = 0; i < U.rows(); ++i) {
        const Eigen::Vector3d expected = cj.J[i] * U.row(i).transpose();
        scale = std::max(scale, expected.norm());
        worst = std::max(worst, (cp.E.row(i).transpose() - expected).norm());
      }
      EXPECT_LE(worst, 1e-12 * scale);
    }
    ++meshes;
  }
  if (meshes == 0)
    GTEST_FAIL() << "no real mesh available (data/meshes, libcgal-demo: scripts/setup.sh)";
}
