// The roughness field: flat CAD panels read smooth, added noise reads rough, and the field does
// not depend on the resolution (Loop subdivision).

#include <gtest/gtest.h>

#include <numeric>

#include "carrier/curvature.h"
#include "meshmark/attacks/attack.h"
#include "meshmark/carrier/roughness.h"
#include "meshmark/core/random.h"
#include "meshmark/io/io.h"
#include "test_data.h"

using namespace meshmark;
using namespace meshmark::test;

namespace {

std::vector<double> ranks(const std::vector<double>& v) {
  std::vector<int> order(v.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return v[a] < v[b]; });
  std::vector<double> r(v.size());
  for (std::size_t k = 0; k < order.size();) {  // average ranks over ties
    std::size_t e = k;
    while (e < order.size() && v[order[e]] == v[order[k]]) ++e;
    for (std::size_t q = k; q < e; ++q) r[order[q]] = 0.5 * static_cast<double>(k + e - 1);
    k = e;
  }
  return r;
}

double spearman(const std::vector<double>& a, const std::vector<double>& b) {
  const auto ra = ranks(a), rb = ranks(b);
  const double n = static_cast<double>(a.size());
  const double ma = std::accumulate(ra.begin(), ra.end(), 0.0) / n,
               mb = std::accumulate(rb.begin(), rb.end(), 0.0) / n;
  double sab = 0, saa = 0, sbb = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    sab += (ra[i] - ma) * (rb[i] - mb);
    saa += (ra[i] - ma) * (ra[i] - ma);
    sbb += (rb[i] - mb) * (rb[i] - mb);
  }
  return sab / std::sqrt(saa * sbb);
}

// Nearest vertex of W to every row of V (brute force over a coarse grid of candidates).
std::vector<int> nearest(const Eigen::MatrixX3d& V, const Eigen::MatrixX3d& W) {
  std::vector<int> out(V.rows());
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    Eigen::Index best;
    (W.rowwise() - V.row(i)).rowwise().squaredNorm().minCoeff(&best);
    out[i] = static_cast<int>(best);
  }
  return out;
}

}  // namespace

TEST(Curvature, SphereHasCurvatureTwoOverRadius) {
  Mesh m = bumpy_sphere(80, 120, 1);
  // Project the bumpy sphere onto a sphere of radius 2.
  for (Eigen::Index i = 0; i < m.V.rows(); ++i) m.V.row(i) = 2 * m.V.row(i).normalized();
  // A ball of 0.6 holds 4 to 6 lattice lines of the 80 x 120 grid (spacing 0.16 and 0.10):
  // the clipped normal cycle sums them against the disc's area to within a few percent (at 0.3,
  // 2 to 3 lines, that sum is up to 10 % short: the clipped definition, unlike the former
  // half-edge count divided by the vertex areas inside, does not cancel it).
  const CurvatureField c = normal_cycle_curvature(m.V, m.F, 0.6);
  const Eigen::VectorXd k = c.magnitude();
  // Away from the poles (irregular fans), |kmin| + |kmax| = 2 / R = 1 within discretization error.
  int checked = 0;
  for (Eigen::Index i = 0; i < m.V.rows(); ++i) {
    if (std::abs(m.V(i, 2)) > 1.5) continue;
    EXPECT_NEAR(k(i), 1.0, 0.05) << i;
    EXPECT_NEAR(c.kmin(i), c.kmax(i), 0.05) << "umbilic: both principal curvatures equal";
    ++checked;
  }
  EXPECT_GT(checked, 1000);
}

TEST(Roughness, FlatCadPanelsReadSmooth) {
  const std::string path = cgal_mesh("fandisk.off");
  MESHMARK_REQUIRE(path, "libcgal-demo fandisk.off");
  const Mesh m = read_mesh(path);
  const RoughnessField f = roughness_field(m.V, m.F);
  const double smooth = (f.smoothness.array() > 0.8).cast<double>().mean();
  EXPECT_GT(smooth, 0.5) << "most of fandisk is flat panels";
  EXPECT_GE(f.smoothness.minCoeff(), 0.0);
  EXPECT_LE(f.smoothness.maxCoeff(), 1.0);
}

TEST(Roughness, NoisyHalfReadsRough) {
  for (const std::string& path : {data_mesh("spot.obj"), cgal_mesh("elephant.off")}) {
    if (path.empty()) continue;
    SCOPED_TRACE(path);
    Mesh m = read_mesh(path);
    const double diag = bounding_box_diagonal(m.V);
    std::vector<double> xs(m.V.col(0).data(), m.V.col(0).data() + m.V.rows());
    std::nth_element(xs.begin(), xs.begin() + static_cast<std::ptrdiff_t>(xs.size() / 2), xs.end());
    const double median = xs[xs.size() / 2];
    Random rng(4);
    for (Eigen::Index i = 0; i < m.V.rows(); ++i)
      if (m.V(i, 0) > median)
        for (int a = 0; a < 3; ++a) m.V(i, a) += 0.005 * diag * rng.uniform(-1, 1);
    const RoughnessField f = roughness_field(m.V, m.F);
    // Leave out a band around the cut, where windows see both halves.
    double noisy = 0, clean = 0, nn = 0, nc = 0, rough_noisy = 0, rough_clean = 0;
    for (Eigen::Index i = 0; i < m.V.rows(); ++i) {
      const bool rough = f.smoothness(i) <= f.smooth_threshold;
      if (m.V(i, 0) > median + 0.03 * diag) noisy += f.roughness(i), rough_noisy += rough, nn += 1;
      if (m.V(i, 0) < median - 0.03 * diag) clean += f.roughness(i), rough_clean += rough, nc += 1;
    }
    EXPECT_GT(noisy / nn, 2 * clean / nc)
        << "mean roughness: noisy half " << noisy / nn << ", clean half " << clean / nc;
    EXPECT_GT(rough_noisy / nn, 1.5 * rough_clean / nc)
        << "read as rough: noisy half " << rough_noisy / nn << ", clean half " << rough_clean / nc;
  }
}

TEST(Roughness, LoopSubdivisionKeepsTheFieldAtTheOriginalVertices) {
  for (const std::string& path :
       {data_mesh("spot.obj"), cgal_mesh("fandisk.off"), cgal_mesh("elephant.off")}) {
    if (path.empty()) continue;
    SCOPED_TRACE(path);
    const Mesh m = read_mesh(path);
    const Mesh fine = attack_subdivide(m, Subdivision::Loop, 1);
    const RoughnessField a = roughness_field(m.V, m.F), b = roughness_field(fine.V, fine.F);
    const auto match = nearest(m.V, fine.V);
    std::vector<double> ra, rb;
    for (Eigen::Index i = 0; i < m.V.rows(); ++i) {
      ra.push_back(a.roughness(i));
      rb.push_back(b.roughness(match[i]));
    }
    EXPECT_GE(spearman(ra, rb), 0.8) << "rank correlation " << spearman(ra, rb);
  }
}
