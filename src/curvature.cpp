#include "meshmark/curvature.h"

#include <array>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numeric>

#include "parallel.h"

namespace meshmark {

namespace {

// Unique undirected edges with their signed dihedral angle (0 on boundary and non-manifold
// edges).
struct EdgeTable {
  std::vector<std::array<int, 2>> ends;
  std::vector<double> beta;
};

EdgeTable dihedral_edges(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F) {
  // Half-edges (max, face, +1 if the face runs min->max) bucketed by their min vertex, each
  // bucket sorted: linear in the faces, no global sort.
  const auto nv = static_cast<std::size_t>(V.rows());
  std::vector<int> start(nv + 1, 0);
  for (Eigen::Index t = 0; t < F.rows(); ++t)
    for (int c = 0; c < 3; ++c) {
      const int a = F(t, c), b = F(t, (c + 1) % 3);
      if (a != b) ++start[std::min(a, b) + 1];
    }
  std::partial_sum(start.begin(), start.end(), start.begin());
  std::vector<std::array<int, 4>> half(static_cast<std::size_t>(start[nv]));
  std::vector<int> fill(start.begin(), start.end() - 1);
  for (Eigen::Index t = 0; t < F.rows(); ++t)
    for (int c = 0; c < 3; ++c) {
      const int a = F(t, c), b = F(t, (c + 1) % 3);
      if (a != b)
        half[fill[std::min(a, b)]++] = {std::min(a, b), std::max(a, b), static_cast<int>(t),
                                        a < b ? 1 : -1};
    }
  for (std::size_t v = 0; v < nv; ++v)
    std::sort(half.begin() + start[v], half.begin() + start[v + 1]);
  auto normal = [&](int t) {
    const Eigen::Vector3d p0 = V.row(F(t, 0)), p1 = V.row(F(t, 1)), p2 = V.row(F(t, 2));
    const Eigen::Vector3d n = (p1 - p0).cross(p2 - p0);
    const double len = n.norm();
    return len > 0 ? Eigen::Vector3d(n / len) : Eigen::Vector3d::Zero();
  };
  EdgeTable table;
  for (std::size_t k = 0; k < half.size();) {
    std::size_t e = k;
    while (e < half.size() && half[e][0] == half[k][0] && half[e][1] == half[k][1]) ++e;
    double beta = 0;
    if (e - k == 2 && half[k][3] != half[k + 1][3]) {  // manifold, consistently oriented
      // f1 runs a -> b (a = min), f2 runs b -> a.
      const int f1 = half[k][3] > 0 ? half[k][2] : half[k + 1][2];
      const int f2 = half[k][3] > 0 ? half[k + 1][2] : half[k][2];
      const Eigen::Vector3d n1 = normal(f1), n2 = normal(f2);
      const Eigen::Vector3d dir = V.row(half[k][1]) - V.row(half[k][0]);
      const double len = dir.norm();
      if (len > 0) beta = std::atan2(n1.cross(n2).dot(dir / len), n1.dot(n2));
    }
    table.ends.push_back({half[k][0], half[k][1]});
    table.beta.push_back(beta);
    k = e;
  }
  return table;
}

}  // namespace

Neighborhoods ball_neighborhoods(const Eigen::MatrixX3d& V, const Adjacency& adj, double radius) {
  // Each chunk of vertices gathers its lists on its own thread; the lists are then joined in
  // vertex order.
  const std::int64_t nv = V.rows();
  const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> P =
      V;  // one cache line per point
  std::vector<Neighborhoods> parts(static_cast<std::size_t>(detail::chunk_count(nv)));
  detail::parallel_chunks(nv, [&](int chunk, std::int64_t begin, std::int64_t end) {
    Neighborhoods& part = parts[chunk];
    std::vector<int> stamp(static_cast<std::size_t>(nv), -1), queue;
    for (std::int64_t i = begin; i < end; ++i) {
      if (adj.degree(static_cast<int>(i)) > 0)
        for_each_vertex_in_ball(P, adj, static_cast<int>(i), P.row(i), radius, stamp, queue,
                                static_cast<int>(i), [&](int v) { part.indices.push_back(v); });
      part.offsets.push_back(static_cast<std::int64_t>(part.indices.size()));
    }
  });
  Neighborhoods near;
  for (const Neighborhoods& part : parts) {
    const std::int64_t base = static_cast<std::int64_t>(near.indices.size());
    for (std::size_t k = 1; k < part.offsets.size(); ++k)
      near.offsets.push_back(base + part.offsets[k]);
    near.indices.insert(near.indices.end(), part.indices.begin(), part.indices.end());
  }
  return near;
}

CurvatureField normal_cycle_curvature(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                                      double radius) {
  return normal_cycle_curvature(V, F, radius,
                                ball_neighborhoods(V, vertex_adjacency(F, V.rows()), radius));
}

CurvatureField normal_cycle_curvature(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F,
                                      double radius, const Neighborhoods& near) {
  const Eigen::Index nv = V.rows();
  CurvatureField field;
  field.kmin = Eigen::VectorXd::Zero(nv);
  field.kmax = Eigen::VectorXd::Zero(nv);
  const EdgeTable edges = dihedral_edges(V, F);
  // A third of the incident triangle areas per vertex: the ball's surface area is the sum over
  // the vertices inside it.
  Eigen::VectorXd vertex_area = Eigen::VectorXd::Zero(nv);
  for (Eigen::Index t = 0; t < F.rows(); ++t) {
    const Eigen::Vector3d p0 = V.row(F(t, 0)), p1 = V.row(F(t, 1)), p2 = V.row(F(t, 2));
    const double a = 0.5 * (p1 - p0).cross(p2 - p0).norm() / 3;
    for (int c = 0; c < 3; ++c) vertex_area(F(t, c)) += a;
  }
  const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> P =
      V;  // one cache line per point
  const double r2 = radius * radius;
  // Edges count the way the area does, by vertices: half an edge per endpoint inside the ball,
  // so that their ratio carries no bias. The ball's tensor is then half the sum, over the
  // vertices inside, of each vertex's sum of its edges' tensors beta / |d| d d^T (6 distinct
  // entries), which is computed once: no edge is visited per ball.
  std::vector<std::array<double, 6>> tensor(static_cast<std::size_t>(nv), {0, 0, 0, 0, 0, 0});
  for (std::size_t e = 0; e < edges.ends.size(); ++e) {
    if (edges.beta[e] == 0) continue;
    const Eigen::Vector3d d = (P.row(edges.ends[e][1]) - P.row(edges.ends[e][0])).transpose();
    const double length = d.norm();
    if (length == 0) continue;
    const double w = 0.5 * edges.beta[e] / length;
    const std::array<double, 6> te = {w * d(0) * d(0), w * d(0) * d(1), w * d(0) * d(2),
                                      w * d(1) * d(1), w * d(1) * d(2), w * d(2) * d(2)};
    for (int v : edges.ends[e])
      for (int c = 0; c < 6; ++c) tensor[v][c] += te[c];
  }
  // Vertices are independent: chunks of them on separate threads.
  detail::parallel_chunks(nv, [&](int, std::int64_t begin, std::int64_t end) {
    for (Eigen::Index i = begin; i < end; ++i) {
      double area = 0;
      double t[6] = {0, 0, 0, 0, 0, 0};
      for (auto k = near.offsets[i]; k < near.offsets[i + 1]; ++k) {
        const int v = near.indices[k];
        if ((P.row(v) - P.row(i)).squaredNorm() > r2) continue;
        area += vertex_area(v);
        for (int c = 0; c < 6; ++c) t[c] += tensor[v][c];
      }
      if (area <= 0) continue;
      Eigen::Matrix3d T;
      T << t[0], t[1], t[2], t[1], t[3], t[4], t[2], t[4], t[5];
      T /= area;
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
      eig.computeDirect(T, Eigen::EigenvaluesOnly);  // closed form for 3 x 3
      Eigen::Vector3d ev = eig.eigenvalues();
      std::sort(ev.data(), ev.data() + 3,
                [](double x, double y) { return std::abs(x) < std::abs(y); });
      // The smallest magnitude belongs to the normal; the other two are the principal curvatures.
      field.kmin(i) = ev(1);
      field.kmax(i) = ev(2);
    }
  });
  return field;
}

}  // namespace meshmark
